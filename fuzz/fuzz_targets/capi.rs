//! The C ABI of the flight core (crates/taiji-core/src/capi.rs) driven through its
//! `extern "C"` functions as a C host would: caller-owned buffers of exactly the sizes
//! the library asks for (AddressSanitizer sees any access past them), any table (raw
//! bytes, or the default table with fields overwritten by anything), any sample stream
//! (raw bytes, or real samples of the default campaign with bits flipped, special
//! values and wild ticks), and any order of init, update, solve, estimate, finish,
//! checkpoint and restore (intact checkpoints, edited ones with their checksum
//! resealed, and raw bytes), plus bad pointers, wrong header arguments and bits
//! flipped in the state between calls.
//!
//! The oracle: no crash or abort; every return code is the one the contract
//! (include/taiji_estimator.h) gives for the state the host has put the library in;
//! an estimate whose status says it is valid (no `ST_UNVERIFIED` bit) has finite
//! values and σ; `finish` is idempotent; a checkpoint restores to the same estimator;
//! a bit flipped in the state is found by the next call that checks the whole state
//! (an update checks the parts it writes and one more: it finds the flip or leaves it
//! standing, unless it overwrote the word whole).
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use std::mem::size_of;
use std::sync::OnceLock;
use taiji_core::capi::*;
use taiji_core::estimate::snapshot;
use taiji_core::estimate::EstimatorConfig;
use taiji_core::msg::{EstimateMsg, SensorSample, EST_FINAL, ST_UNVERIFIED};

const CONFIG_SIZE: usize = size_of::<EstimatorConfig>();
const CONFIG_WORDS: usize = CONFIG_SIZE / 8;
const SAMPLE_SIZE: usize = size_of::<SensorSample>();
const ESTIMATE_SIZE: usize = size_of::<EstimateMsg>();

/// Updates per input at most (about 50 µs each here): bounds an input's time.
const MAX_UPDATES: usize = 3000;
/// Solves and finishes per input at most (milliseconds each).
const MAX_SOLVES: usize = 12;

/// Real samples of the default campaign, and its table.
struct Real {
    samples: Vec<SensorSample>,
    cfg: EstimatorConfig,
}

fn real() -> &'static Real {
    static REAL: OnceLock<Real> = OnceLock::new();
    REAL.get_or_init(|| {
        use taiji::analysis::campaign::Stages;
        use taiji::sim::estimate::Method;
        use taiji::sim::scenario::Scenario;
        let s = Scenario::default();
        let mut st = Stages::new(&s, 1, Method::Joint);
        let samples = (0..4096u64)
            .map(|t| {
                let cmd = st.commander.step(t);
                let truth = st.plant.step(t, &cmd.torque_cmd_b);
                st.fee.step(&truth)
            })
            .collect();
        Real {
            samples,
            cfg: s.estimator_config(&s.priors()),
        }
    })
}

/// A value for one 8-byte word of a table or a state.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Val {
    Bits(u64),
    Int(u16),
    Special(u8),
    /// The word's own value (as a float) times 2^e.
    Scale(i8),
    Neg,
}

const SPECIALS: [f64; 12] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    5e-324,
    -0.0,
    0.0,
    1e6,
    1e-300,
    -1.0,
];

impl Val {
    fn apply(self, old: u64) -> u64 {
        match self {
            Val::Bits(b) => b,
            Val::Int(i) => u64::from(i),
            Val::Special(k) => SPECIALS[usize::from(k) % SPECIALS.len()].to_bits(),
            Val::Scale(e) => (f64::from_bits(old) * 2f64.powi(i32::from(e))).to_bits(),
            Val::Neg => (-f64::from_bits(old)).to_bits(),
        }
    }
}

#[derive(Arbitrary, Debug)]
enum ConfigSrc {
    /// The table's bytes as they come.
    Raw(Box<[u8; CONFIG_SIZE]>),
    /// The default campaign's table with some words overwritten.
    Base(Vec<(u8, Val)>),
}

impl ConfigSrc {
    fn bytes(&self) -> [u8; CONFIG_SIZE] {
        match self {
            ConfigSrc::Raw(b) => **b,
            ConfigSrc::Base(edits) => {
                let mut b = [0u8; CONFIG_SIZE];
                b.copy_from_slice(bytemuck::bytes_of(&real().cfg));
                for &(w, v) in edits {
                    let at = 8 * (usize::from(w) % CONFIG_WORDS);
                    let old = u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
                    b[at..at + 8].copy_from_slice(&v.apply(old).to_le_bytes());
                }
                b
            }
        }
    }
}

/// A change to one sample.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Perturb {
    /// One of the 16 floats the estimator reads (12 voltages, 4 quaternion components).
    Field(u8, Val),
    Flip(u8, u8),
    Flags(bool, u8),
    StarValid(u8),
    /// The same voltages as the previous sample (a stuck channel).
    Stuck,
}

#[derive(Arbitrary, Debug, Clone, Copy)]
enum TickMode {
    Next,
    Same,
    Back(u8),
    Skip(u16),
    Wild(u64),
}

#[derive(Arbitrary, Debug)]
enum SampleSrc {
    Raw([u8; SAMPLE_SIZE]),
    Real {
        tick: TickMode,
        perturb: Option<Perturb>,
    },
}

/// The scratch a host hands `solve` and `finish`.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Work {
    Good,
    Null,
    Small,
    Misaligned,
    /// The state's own memory.
    OverState,
}

#[derive(Arbitrary, Debug, Clone, Copy)]
enum Edit {
    Xor(u32, u8),
    Word(u32, Val),
    /// One of the state's first 256 words: its table, tick counters and flags.
    Head(u8, Val),
}

#[derive(Arbitrary, Debug)]
enum Op {
    Update {
        sample: SampleSrc,
        null_outs: bool,
    },
    /// `count` real samples on consecutive ticks, every `every`-th one perturbed.
    Burst {
        count: u16,
        every: u8,
        perturb: Perturb,
        solve_when_due: bool,
    },
    Solve(Work),
    Estimate {
        null_out: bool,
    },
    Finish(Work),
    Checkpoint {
        short_by: u8,
        null_buf: bool,
    },
    /// The last checkpoint, edited (its checksum resealed or not), cut short, under the
    /// host's table or another.
    Restore {
        edits: Vec<Edit>,
        reseal: bool,
        cut: Option<u32>,
        other_table: Option<(u8, Val)>,
    },
    RestoreRaw(Vec<u8>),
    Init(ConfigSrc),
    /// A header from another build: refused before anything is read.
    InitWrongAbi(u8),
    /// A bit flipped in the state between calls (an upset), and maybe flipped back.
    Flip {
        word: u32,
        bit: u8,
        back: bool,
    },
    /// Checkpoint, restore into other memory, the same estimate from both.
    Roundtrip,
    /// Calls on memory that is null, misaligned or too small.
    BadMemory(u8),
}

#[derive(Arbitrary, Debug)]
struct Input {
    cfg: ConfigSrc,
    ops: Vec<Op>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Life {
    Uninit,
    Running,
    Finished,
}

/// 8-aligned memory of exactly `bytes` bytes (a multiple of 8), as a host allocates it.
/// What an update does with a word of the state (the library's layout: magic word,
/// estimator, `finished`, final estimate, one seal per part, the scrub's cursor).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Every update checks it (the magic word, a part every update writes, its seal).
    Written,
    /// Updates read it but never write it: checked in turn, within `TAIJI_SCRUB_PARTS`.
    OnlyRead,
    /// A waiting sample's slot (or its seal): an update may write it whole.
    Slot,
    /// Checked when an update reads it, or by a whole check (a Gram matrix, the SRP
    /// filter's words, whose split between poles in use and not depends on the table).
    Other,
}

fn part_kind(word: usize, mem_words: usize) -> Kind {
    use taiji_core::estimate::joint::{Extent, JointEstimator, Writer, N_PARTS};
    let of_part = |i: usize| match JointEstimator::PARTS.get(i) {
        None => Kind::OnlyRead,
        Some(p) if p.extent != Extent::All => Kind::Other,
        Some(p) => match p.writer {
            Writer::Update => Kind::Written,
            Writer::Never | Writer::Start => Kind::OnlyRead,
            Writer::Pend(..) => Kind::Slot,
            Writer::Gram(_) => Kind::Other,
        },
    };
    let est = size_of::<JointEstimator>() / 8;
    let seals = mem_words - 1 - (N_PARTS + 1);
    match word {
        0 => Kind::Written,
        w if w <= est => {
            let at = (w - 1) * 8;
            let i = JointEstimator::PARTS.iter().position(|p| p.start <= at && at < p.end);
            i.map_or(Kind::Other, of_part)
        }
        w if w < seals => Kind::OnlyRead,
        w => of_part(w - seals),
    }
}

fn words(bytes: usize) -> Vec<u64> {
    assert_eq!(bytes % 8, 0);
    vec![0u64; bytes / 8]
}

struct Host {
    mem: Vec<u64>,
    work: Vec<u64>,
    cfg: EstimatorConfig,
    life: Life,
    /// A bit of the state flipped since the library left it: (word, bit).
    flipped: Option<(usize, u32)>,
    /// Updates that returned `TAIJI_OK` over the flip.
    flip_age: u32,
    tick: u64,
    last_sample: SensorSample,
    last_checkpoint: Option<Vec<u8>>,
    final_msg: Option<EstimateMsg>,
    updates: usize,
    solves: usize,
}

fn check_estimate(m: &EstimateMsg, what: &str) {
    if m.status & ST_UNVERIFIED != 0 {
        return;
    }
    let groups: [(&str, &[[f64; 3]; 2]); 6] = [
        ("beta", &m.beta),
        ("beta_sigma", &m.beta_sigma),
        ("k", &m.k),
        ("k_sigma", &m.k_sigma),
        ("r_b", &m.r_b),
        ("r_sigma", &m.r_sigma),
    ];
    for (name, v) in groups {
        assert!(
            v.iter().flatten().all(|x| x.is_finite()),
            "{what}: status {} says valid but {name} = {v:?}",
            m.status
        );
    }
    assert!(
        m.sigma_inflation.is_finite(),
        "{what}: status {} says valid but sigma_inflation = {}",
        m.status,
        m.sigma_inflation
    );
}

fn float_field(s: &mut SensorSample, k: u8) -> &mut f64 {
    let k = usize::from(k % 16);
    if k < 12 {
        &mut s.is[k / 6].volts[(k % 6) / 2][k % 2]
    } else {
        &mut s.star.q_bn[k - 12]
    }
}

impl Host {
    fn p(&mut self) -> *mut u8 {
        self.mem.as_mut_ptr() as *mut u8
    }

    fn work_args(&mut self, w: Work) -> (*mut u8, usize, Option<i32>) {
        let size = taiji_solve_work_size();
        let base = self.work.as_mut_ptr() as *mut u8;
        match w {
            Work::Good => (base, size, None),
            Work::Null => (std::ptr::null_mut(), size, Some(TAIJI_ERR_NULL)),
            Work::Small => (base, size - 8, Some(TAIJI_ERR_SIZE)),
            // SAFETY: inside the scratch buffer; the call must refuse it unread.
            Work::Misaligned => (unsafe { base.add(1) }, size - 1, Some(TAIJI_ERR_ALIGNMENT)),
            Work::OverState => (self.p(), size, Some(TAIJI_ERR_OVERLAP)),
        }
    }

    /// The code a call on the state must return when its other arguments are good
    /// (`running_ok` for a running campaign).
    fn state_code(&self, running_ok: i32) -> i32 {
        match (self.life, self.flipped) {
            (Life::Uninit, _) => TAIJI_ERR_STATE,
            // Any bit flipped, the magic word's too: an upset.
            (_, Some(_)) => TAIJI_ERR_UPSET,
            (Life::Finished, None) => TAIJI_ERR_FINISHED,
            (Life::Running, None) => running_ok,
        }
    }

    fn sample(&mut self, src: &SampleSrc) -> SensorSample {
        match src {
            SampleSrc::Raw(b) => {
                // SAFETY: `b` holds SAMPLE_SIZE bytes; any bytes are a sample.
                unsafe { std::ptr::read_unaligned(b.as_ptr() as *const SensorSample) }
            }
            SampleSrc::Real { tick, perturb } => {
                self.tick = match *tick {
                    TickMode::Next => self.tick.wrapping_add(1),
                    TickMode::Same => self.tick,
                    TickMode::Back(b) => self.tick.saturating_sub(u64::from(b) + 1),
                    TickMode::Skip(s) => self.tick.wrapping_add(u64::from(s) + 2),
                    TickMode::Wild(t) => t,
                };
                let mut s = self.real_at(self.tick);
                if let Some(p) = perturb {
                    self.perturb(&mut s, *p);
                }
                s
            }
        }
    }

    fn real_at(&self, tick: u64) -> SensorSample {
        let r = &real().samples;
        let mut s = r[(tick % r.len() as u64) as usize];
        s.header.tick = tick;
        s.header.seq = tick;
        s
    }

    fn perturb(&self, s: &mut SensorSample, p: Perturb) {
        match p {
            Perturb::Field(k, v) => {
                let f = float_field(s, k);
                *f = f64::from_bits(v.apply(f.to_bits()));
            }
            Perturb::Flip(k, bit) => {
                let f = float_field(s, k);
                *f = f64::from_bits(f.to_bits() ^ (1 << (bit % 64)));
            }
            Perturb::Flags(i, v) => s.is[usize::from(i)].flags = v,
            Perturb::StarValid(v) => s.star.valid = v,
            Perturb::Stuck => {
                for i in 0..2 {
                    s.is[i].volts = self.last_sample.is[i].volts;
                }
            }
        }
    }

    /// One update; whether it said a solve is due.
    fn update(&mut self, s: &SensorSample, null_outs: bool) -> bool {
        if self.updates >= MAX_UPDATES {
            return false;
        }
        self.updates += 1;
        // The sample as a host holds it: exactly its bytes.
        let buf: Box<[u8; SAMPLE_SIZE]> = Box::new(bytemuck::cast(*s));
        let (mut rejected, mut flags) = (u64::MAX, u32::MAX);
        let (r, f) = if null_outs {
            (std::ptr::null_mut(), std::ptr::null_mut())
        } else {
            (&mut rejected as *mut u64, &mut flags as *mut u32)
        };
        let p = self.p();
        // SAFETY: valid pointers (or null) of the sizes the header declares.
        let rc = unsafe { taiji_estimator_update(p, buf.as_ptr() as *const SensorSample, r, f) };
        let want = self.state_code(TAIJI_OK);
        if let (Some((w, _)), true, TAIJI_OK) = (self.flipped, self.life != Life::Uninit, rc) {
            // An update checks the parts it writes, and in turn one of those it only
            // reads: a flip elsewhere stands until a later check, unless the update wrote
            // that word whole (a waiting sample's slot). A whole check (estimate) says
            // which.
            let kind = part_kind(w, self.mem.len());
            assert!(kind != Kind::Written, "update over a flip in word {w}, a part it writes");
            self.flip_age += 1;
            assert!(
                kind != Kind::OnlyRead || self.flip_age < TAIJI_SCRUB_PARTS,
                "a flip in word {w} stood {} updates",
                self.flip_age
            );
            let mut out = EstimateMsg::default();
            // SAFETY: the state and an output of the header's size.
            match unsafe { taiji_estimator_estimate(p, &mut out) } {
                TAIJI_ERR_UPSET => {}
                TAIJI_OK => {
                    assert_eq!(kind, Kind::Slot, "a flip in word {w} vanished");
                    self.flipped = None;
                }
                other => panic!("estimate after an update over a flip: {other}"),
            }
        } else {
            assert_eq!(rc, want, "update: {:?}", self.life);
        }
        if rc == TAIJI_OK && !null_outs {
            assert!(flags == 0 || flags == TAIJI_SOLVE_DUE, "flags {flags}");
            assert!(rejected < 1 << 11, "rejected causes {rejected:#x}");
        }
        self.last_sample = *s;
        rc == TAIJI_OK && flags == TAIJI_SOLVE_DUE
    }

    fn solve(&mut self, w: Work) {
        if self.solves >= MAX_SOLVES {
            return;
        }
        self.solves += 1;
        let (wp, ws, bad) = self.work_args(w);
        let p = self.p();
        // SAFETY: the scratch is the host's (or deliberately wrong: refused unread).
        let rc = unsafe { taiji_estimator_solve(p, wp, ws) };
        match bad {
            Some(code) => assert_eq!(rc, code, "solve with {w:?}"),
            None => match self.state_code(TAIJI_OK) {
                TAIJI_OK => assert!(rc == TAIJI_OK || rc == TAIJI_ERR_SOLVE, "solve: code {rc}"),
                want => assert_eq!(rc, want, "solve: {:?}", self.life),
            },
        }
    }

    fn estimate(&mut self, null_out: bool) -> Option<EstimateMsg> {
        let mut out = Box::new(EstimateMsg::default());
        let o = if null_out {
            std::ptr::null_mut()
        } else {
            &mut *out as *mut EstimateMsg
        };
        let p = self.p();
        // SAFETY: a valid output (or null: refused).
        let rc = unsafe { taiji_estimator_estimate(p, o) };
        let want = match self.state_code(TAIJI_OK) {
            TAIJI_ERR_FINISHED => TAIJI_OK,
            c => c,
        };
        let want = if want == TAIJI_OK && null_out {
            TAIJI_ERR_NULL
        } else {
            want
        };
        assert_eq!(rc, want, "estimate: {:?}", self.life);
        if rc != TAIJI_OK {
            return None;
        }
        check_estimate(&out, "estimate");
        if self.life == Life::Finished {
            let f = self.final_msg.expect("finished");
            assert_eq!(
                bytemuck::bytes_of(&*out),
                bytemuck::bytes_of(&f),
                "estimate after finish is the final estimate"
            );
        }
        Some(*out)
    }

    fn finish(&mut self, w: Work) {
        if self.solves >= MAX_SOLVES {
            return;
        }
        self.solves += 1;
        let (wp, ws, bad) = self.work_args(w);
        let mut out = Box::new(EstimateMsg::default());
        let p = self.p();
        // SAFETY: the scratch and the output are the host's (or refused unread).
        let rc = unsafe { taiji_estimator_finish(p, wp, ws, &mut *out) };
        let want = match (self.state_code(TAIJI_OK), bad) {
            // The scratch is checked on a repeated finish too.
            (TAIJI_ERR_FINISHED | TAIJI_OK, Some(code)) => code,
            (TAIJI_ERR_FINISHED, None) => TAIJI_OK,
            (c, _) => c,
        };
        assert_eq!(rc, want, "finish with {w:?}: {:?}", self.life);
        if rc != TAIJI_OK {
            return;
        }
        assert_ne!(
            out.flags & EST_FINAL,
            0,
            "finish's estimate is flagged final"
        );
        check_estimate(&out, "finish");
        if let Some(f) = self.final_msg {
            assert_eq!(
                bytemuck::bytes_of(&*out),
                bytemuck::bytes_of(&f),
                "finish is idempotent"
            );
        }
        self.final_msg = Some(*out);
        self.life = Life::Finished;
    }

    fn checkpoint(&mut self, short_by: u8, null_buf: bool) {
        let need = taiji_checkpoint_size();
        let len = need - usize::from(short_by % 4) * usize::from((short_by / 4).is_multiple_of(2));
        let mut buf = vec![0u8; len];
        let mut written = usize::MAX;
        let b = if null_buf {
            std::ptr::null_mut()
        } else {
            buf.as_mut_ptr()
        };
        let p = self.p();
        // SAFETY: `len` writable bytes (or null: refused).
        let rc = unsafe { taiji_estimator_checkpoint(p, b, len, &mut written) };
        let want = match self.state_code(TAIJI_OK) {
            TAIJI_OK if null_buf => TAIJI_ERR_NULL,
            TAIJI_OK if len < need => TAIJI_ERR_SIZE,
            c => c,
        };
        assert_eq!(rc, want, "checkpoint of {len} B: {:?}", self.life);
        if rc == TAIJI_OK {
            assert_eq!(written, need);
            self.last_checkpoint = Some(buf);
        }
    }

    /// Restores `bytes` under `cfg` into the state; `intact` when it must succeed.
    fn restore(&mut self, bytes: &[u8], cfg: &EstimatorConfig, intact: bool) {
        // The host's copy: exactly its bytes.
        let buf: Vec<u8> = bytes.to_vec();
        let cfg_box = Box::new(*cfg);
        let p = self.p();
        let size = self.mem.len() * 8;
        // SAFETY: `buf.len()` readable bytes, a readable table, the state's memory.
        let rc = unsafe { taiji_estimator_restore(p, size, buf.as_ptr(), buf.len(), &*cfg_box) };
        assert!(
            [
                TAIJI_OK,
                TAIJI_ERR_SIZE,
                TAIJI_ERR_CHECKPOINT,
                TAIJI_ERR_VERSION,
                TAIJI_ERR_CONFIG
            ]
            .contains(&rc),
            "restore: code {rc}"
        );
        if intact {
            assert_eq!(
                rc, TAIJI_OK,
                "an intact checkpoint under its table restores"
            );
        }
        self.flipped = None;
        self.final_msg = None;
        if rc == TAIJI_OK {
            self.life = Life::Running;
            self.cfg = *cfg;
            // Where the restored campaign goes on.
            let mut m = EstimateMsg::default();
            // SAFETY: a valid output.
            assert_eq!(unsafe { taiji_estimator_estimate(p, &mut m) }, TAIJI_OK);
            check_estimate(&m, "estimate after restore");
        } else {
            self.life = Life::Uninit;
        }
    }

    fn init(&mut self, bytes: &[u8; CONFIG_SIZE]) {
        // The table as the host holds it: exactly its bytes, read unaligned.
        let table: Box<[u8; CONFIG_SIZE]> = Box::new(*bytes);
        let cfg: EstimatorConfig = bytemuck::pod_read_unaligned(&table[..]);
        let p = self.p();
        let size = self.mem.len() * 8;
        // SAFETY: the state's memory and a readable table.
        let rc = unsafe {
            taiji_estimator_init(
                p,
                size,
                table.as_ptr() as *const EstimatorConfig,
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            )
        };
        let want = if cfg.check().is_ok() {
            TAIJI_OK
        } else {
            TAIJI_ERR_CONFIG
        };
        assert_eq!(rc, want, "init");
        self.flipped = None;
        self.final_msg = None;
        self.tick = u64::MAX; // the next real sample is tick 0
        if rc == TAIJI_OK {
            self.life = Life::Running;
            self.cfg = cfg;
        } else {
            self.life = Life::Uninit;
        }
    }

    fn init_wrong_abi(&mut self, k: u8) {
        let mut args = [
            TAIJI_ABI_VERSION as usize,
            CONFIG_SIZE,
            SAMPLE_SIZE,
            ESTIMATE_SIZE,
        ];
        let i = usize::from(k % 4);
        args[i] = args[i].wrapping_add(1 + usize::from(k / 4));
        let cfg = Box::new(real().cfg);
        let p = self.p();
        let size = self.mem.len() * 8;
        // SAFETY: the state's memory and a readable table.
        let rc = unsafe {
            taiji_estimator_init(p, size, &*cfg, args[0] as u32, args[1], args[2], args[3])
        };
        // Refused before anything is read: the state is as it was.
        assert_eq!(rc, TAIJI_ERR_VERSION, "init with another header");
    }

    fn flip(&mut self, word: u32, bit: u8, back: bool) {
        // Any word but the last: which part the next update scrubs, not sealed (any
        // value will do).
        let w = word as usize % (self.mem.len() - 1);
        let b = u32::from(bit % 64);
        self.mem[w] ^= 1 << b;
        match self.flipped {
            Some((fw, fb)) if (fw, fb) == (w, b) => self.flipped = None,
            Some(_) => {
                // Two flips: both are found as long as either stands. Keep the state
                // dead for the model: init or restore revives it.
                self.mem[w] ^= 1 << b;
                return;
            }
            None => {
                self.flipped = Some((w, b));
                self.flip_age = 0;
            }
        }
        if self.flipped.is_some() {
            // The next call must find it (and change nothing).
            let _ = self.estimate(false);
            if back {
                self.mem[w] ^= 1 << b;
                self.flipped = None;
            }
        }
    }

    fn roundtrip(&mut self) {
        if self.life != Life::Running || self.flipped.is_some() {
            return;
        }
        let need = taiji_checkpoint_size();
        let mut buf = vec![0u8; need];
        let mut n = 0usize;
        let p = self.p();
        // SAFETY: `need` writable bytes.
        let rc = unsafe { taiji_estimator_checkpoint(p, buf.as_mut_ptr(), need, &mut n) };
        assert_eq!(rc, TAIJI_OK);
        let mut other = words(taiji_estimator_size());
        let q = other.as_mut_ptr() as *mut u8;
        let cfg = Box::new(self.cfg);
        // SAFETY: the other state's memory, `n` readable bytes, a readable table.
        let rc = unsafe { taiji_estimator_restore(q, other.len() * 8, buf.as_ptr(), n, &*cfg) };
        assert_eq!(rc, TAIJI_OK, "a fresh checkpoint restores");
        let (mut a, mut b) = (EstimateMsg::default(), EstimateMsg::default());
        // SAFETY: valid outputs.
        unsafe {
            assert_eq!(taiji_estimator_estimate(p, &mut a), TAIJI_OK);
            assert_eq!(taiji_estimator_estimate(q, &mut b), TAIJI_OK);
        }
        assert_eq!(
            bytemuck::bytes_of(&a),
            bytemuck::bytes_of(&b),
            "the restored estimator is the same"
        );
        self.last_checkpoint = Some(buf);
    }

    fn bad_memory(&mut self, k: u8) {
        let size = taiji_estimator_size();
        let mut spare = words(size + 8);
        let base = spare.as_mut_ptr() as *mut u8;
        let cfg = Box::new(real().cfg);
        let (mem, len, code) = match k % 3 {
            0 => (std::ptr::null_mut(), size, TAIJI_ERR_NULL),
            // SAFETY: inside `spare`.
            1 => (
                unsafe { base.add(1 + usize::from(k / 3) % 7) },
                size,
                TAIJI_ERR_ALIGNMENT,
            ),
            _ => (base, size - 8 - usize::from(k / 3), TAIJI_ERR_SIZE),
        };
        // SAFETY: refused before the memory is touched (or within `spare`).
        let rc = unsafe {
            taiji_estimator_init(
                mem,
                len,
                &*cfg,
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            )
        };
        assert_eq!(rc, code, "init on bad memory");
        if k % 3 == 2 {
            return; // calls other than init and restore take no size
        }
        let s = Box::new(real().samples[0]);
        let mut m = EstimateMsg::default();
        // SAFETY: as above.
        unsafe {
            assert_eq!(
                taiji_estimator_update(mem, &*s, std::ptr::null_mut(), std::ptr::null_mut()),
                code
            );
            assert_eq!(taiji_estimator_estimate(mem, &mut m), code);
            let w = self.work.as_mut_ptr() as *mut u8;
            assert_eq!(taiji_estimator_solve(mem, w, taiji_solve_work_size()), code);
            assert_eq!(
                taiji_estimator_finish(mem, w, taiji_solve_work_size(), &mut m),
                code
            );
            let mut ck = vec![0u8; taiji_checkpoint_size()];
            assert_eq!(
                taiji_estimator_checkpoint(mem, ck.as_mut_ptr(), ck.len(), std::ptr::null_mut()),
                code
            );
        }
    }
}

/// Word `w` of a checkpoint's bytes set from `v`.
fn set_word(ck: &mut [u8], w: usize, v: Val) {
    let at = 8 * w;
    let old = u64::from_le_bytes(ck[at..at + 8].try_into().unwrap());
    ck[at..at + 8].copy_from_slice(&v.apply(old).to_le_bytes());
}

fn run(input: &Input) {
    let mut h = Host {
        mem: words(taiji_estimator_size()),
        work: words(taiji_solve_work_size()),
        cfg: real().cfg,
        life: Life::Uninit,
        flipped: None,
        tick: u64::MAX,
        last_sample: SensorSample::default(),
        last_checkpoint: None,
        final_msg: None,
        updates: 0,
        flip_age: 0,
        solves: 0,
    };
    // Memory never initialised is no state.
    let _ = h.estimate(false);
    h.init(&input.cfg.bytes());
    for op in input.ops.iter().take(64) {
        match op {
            Op::Update { sample, null_outs } => {
                let s = h.sample(sample);
                let _ = h.update(&s, *null_outs);
            }
            Op::Burst {
                count,
                every,
                perturb,
                solve_when_due,
            } => {
                for k in 0..usize::from(*count % 1024) {
                    if h.updates >= MAX_UPDATES {
                        break;
                    }
                    h.tick = h.tick.wrapping_add(1);
                    let mut s = h.real_at(h.tick);
                    if *every != 0 && k % usize::from(*every) == 0 {
                        h.perturb(&mut s, *perturb);
                    }
                    if h.update(&s, false) && *solve_when_due {
                        h.solve(Work::Good);
                    }
                }
            }
            Op::Solve(w) => h.solve(*w),
            Op::Estimate { null_out } => {
                let _ = h.estimate(*null_out);
            }
            Op::Finish(w) => h.finish(*w),
            Op::Checkpoint { short_by, null_buf } => h.checkpoint(*short_by, *null_buf),
            Op::Restore {
                edits,
                reseal,
                cut,
                other_table,
            } => {
                let Some(mut ck) = h.last_checkpoint.clone() else {
                    continue;
                };
                let n = ck.len();
                for e in edits {
                    match *e {
                        Edit::Xor(at, x) => ck[at as usize % n] ^= x,
                        Edit::Word(at, v) => set_word(&mut ck, at as usize % (n / 8), v),
                        Edit::Head(k, v) => {
                            set_word(&mut ck, snapshot::HEADER / 8 + usize::from(k), v)
                        }
                    }
                }
                if *reseal {
                    let sum = snapshot::fnv1a(&ck[snapshot::HEADER..]);
                    ck[24..32].copy_from_slice(&sum.to_le_bytes());
                }
                if let Some(c) = cut {
                    ck.truncate(*c as usize % n);
                }
                let mut cfg = h.cfg;
                if let Some((w, v)) = other_table {
                    let mut b: [u8; CONFIG_SIZE] = bytemuck::cast(cfg);
                    let at = 8 * (usize::from(*w) % CONFIG_WORDS);
                    let old = u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
                    b[at..at + 8].copy_from_slice(&v.apply(old).to_le_bytes());
                    cfg = bytemuck::cast(b);
                }
                let intact = edits.is_empty() && cut.is_none() && other_table.is_none();
                h.restore(&ck, &cfg, intact);
            }
            Op::RestoreRaw(bytes) => {
                let cfg = h.cfg;
                h.restore(bytes, &cfg, false);
            }
            Op::Init(c) => h.init(&c.bytes()),
            Op::InitWrongAbi(k) => h.init_wrong_abi(*k),
            Op::Flip { word, bit, back } => h.flip(*word, *bit, *back),
            Op::Roundtrip => h.roundtrip(),
            Op::BadMemory(k) => h.bad_memory(*k),
        }
    }
    // The host ends the campaign.
    h.solves = 0;
    h.finish(Work::Good);
    let _ = h.estimate(false);
}

fuzz_target!(|input: Input| {
    run(&input);
});
