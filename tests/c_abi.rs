//! The C ABI (`src/capi.rs`) driven as a C host would, including as a careless or
//! hostile one: null pointers, misaligned or too-small state, uninitialised memory, a
//! wrong table, garbage samples, torn checkpoints. Every call returns a code; none may
//! panic (a panic here fails the test; in the C library it would abort the host).

use taiji::sim::capi::*;
use taiji::sim::estimate::EstimatorConfig;
use taiji::sim::msg::{EstimateMsg, SensorSample};
use taiji::sim::scenario::Scenario;

const CONFIG_SIZE: usize = std::mem::size_of::<EstimatorConfig>();
const SAMPLE_SIZE: usize = std::mem::size_of::<SensorSample>();
const ESTIMATE_SIZE: usize = std::mem::size_of::<EstimateMsg>();

fn config() -> EstimatorConfig {
    let s = Scenario::default();
    s.estimator_config(&s.priors())
}

/// 8-byte aligned memory for the state, with room to misalign it.
fn memory() -> Vec<u64> {
    vec![0u64; taiji_estimator_size() / 8 + 2]
}

/// `taiji_estimator_solve` with fresh scratch of the documented size.
unsafe fn solve(p: *mut u8) -> i32 {
    let mut w = vec![0u64; taiji_solve_work_size().div_ceil(8)];
    unsafe { taiji_estimator_solve(p, w.as_mut_ptr() as *mut u8, w.len() * 8) }
}

/// `taiji_estimator_finish` with fresh scratch of the documented size.
unsafe fn finish(p: *mut u8, out: *mut EstimateMsg) -> i32 {
    let mut w = vec![0u64; taiji_solve_work_size().div_ceil(8)];
    unsafe { taiji_estimator_finish(p, w.as_mut_ptr() as *mut u8, w.len() * 8, out) }
}

fn init(mem: &mut [u64]) -> *mut u8 {
    let p = mem.as_mut_ptr() as *mut u8;
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    let rc = unsafe {
        taiji_estimator_init(
            p,
            mem.len() * 8,
            &config(),
            TAIJI_ABI_VERSION,
            CONFIG_SIZE,
            SAMPLE_SIZE,
            ESTIMATE_SIZE,
        )
    };
    assert_eq!(rc, TAIJI_OK);
    p
}

/// Deterministic garbage (xorshift).
struct Garbage(u64);
impl Garbage {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn fill(&mut self, bytes: &mut [u8]) {
        for b in bytes {
            *b = self.next() as u8;
        }
    }
}

fn garbage_sample(g: &mut Garbage) -> SensorSample {
    let mut raw = [0u8; std::mem::size_of::<SensorSample>()];
    g.fill(&mut raw);
    // SAFETY: the source holds at least size_of::<T>() bytes; any bytes are a valid T (plain numbers).
    unsafe { std::ptr::read_unaligned(raw.as_ptr() as *const SensorSample) }
}

#[test]
fn size_and_alignment_are_queried_not_assumed() {
    assert!(taiji_estimator_size() >= std::mem::size_of::<u64>());
    assert!(taiji_estimator_align().is_power_of_two());
    // The state (estimator with its waiting Gram updates, magic word, final estimate,
    // seal) stays within 72 KB; the checkpoint is the estimator's part with its header.
    assert!(
        taiji_estimator_size() <= 72 * 1024,
        "{}",
        taiji_estimator_size()
    );
    assert!(taiji_checkpoint_size() < taiji_estimator_size());
    assert_eq!(taiji_abi_version(), TAIJI_ABI_VERSION);
    assert_eq!(taiji_layout_version(), taiji::sim::msg::LAYOUT_VERSION);
    // This build seals the state (the EDAC build, feature `edac`, would say 0).
    assert_eq!(taiji_upset_check(), 1);
}

#[test]
fn null_pointers_get_an_error_code() {
    let mut mem = memory();
    let p = mem.as_mut_ptr() as *mut u8;
    let null = std::ptr::null_mut();
    let s = SensorSample::default();
    let mut out = EstimateMsg::default();
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    unsafe {
        assert_eq!(
            taiji_estimator_init(
                null,
                1 << 20,
                &config(),
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE
            ),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_init(
                p,
                mem.len() * 8,
                std::ptr::null(),
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE
            ),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_update(null, &s, null as _, null as _),
            TAIJI_ERR_NULL
        );
        assert_eq!(solve(null), TAIJI_ERR_NULL);
        assert_eq!(taiji_estimator_estimate(null, &mut out), TAIJI_ERR_NULL);
        assert_eq!(finish(null, &mut out), TAIJI_ERR_NULL);
        assert_eq!(
            taiji_estimator_checkpoint(null, null, 0, null as _),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_restore(null, 1 << 20, null, 0, &config()),
            TAIJI_ERR_NULL
        );
        let p = init(&mut mem);
        assert_eq!(
            taiji_estimator_update(p, std::ptr::null(), null as _, null as _),
            TAIJI_ERR_NULL
        );
        assert_eq!(
            taiji_estimator_estimate(p, std::ptr::null_mut()),
            TAIJI_ERR_NULL
        );
        assert_eq!(finish(p, std::ptr::null_mut()), TAIJI_ERR_NULL);
        assert_eq!(
            taiji_estimator_checkpoint(p, null, 1 << 20, null as _),
            TAIJI_ERR_NULL
        );
        // The optional out-parameters of update may be null.
        assert_eq!(
            taiji_estimator_update(p, &s, null as _, null as _),
            TAIJI_OK
        );
    }
}

#[test]
fn misaligned_or_small_state_memory_is_refused() {
    let mut mem = memory();
    let base = mem.as_mut_ptr() as *mut u8;
    for off in 1..8 {
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        let rc = unsafe {
            taiji_estimator_init(
                base.add(off),
                mem.len() * 8 - 8,
                &config(),
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            )
        };
        assert_eq!(rc, TAIJI_ERR_ALIGNMENT, "offset {off}");
    }
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    let rc = unsafe {
        taiji_estimator_init(
            base,
            taiji_estimator_size() - 1,
            &config(),
            TAIJI_ABI_VERSION,
            CONFIG_SIZE,
            SAMPLE_SIZE,
            ESTIMATE_SIZE,
        )
    };
    assert_eq!(rc, TAIJI_ERR_SIZE);
}

#[test]
fn memory_that_was_never_initialised_is_refused() {
    let mut g = Garbage(7);
    for _ in 0..20 {
        let mut mem = memory();
        let bytes =
            // SAFETY: the slice covers exactly the u64 buffer it is made from, which outlives it.
            unsafe { std::slice::from_raw_parts_mut(mem.as_mut_ptr() as *mut u8, mem.len() * 8) };
        g.fill(bytes);
        let p = mem.as_mut_ptr() as *mut u8;
        let mut out = EstimateMsg::default();
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        unsafe {
            assert_eq!(solve(p), TAIJI_ERR_STATE);
            assert_eq!(taiji_estimator_estimate(p, &mut out), TAIJI_ERR_STATE);
        }
    }
}

#[test]
fn a_wrong_table_is_refused_and_leaves_no_estimator() {
    let mut mem = memory();
    let p = mem.as_mut_ptr() as *mut u8;
    let bad: [fn(&mut EstimatorConfig); 12] = [
        |c| c.fs = f64::NAN,
        |c| c.fs = 0.0,
        |c| c.n_is = 0,
        |c| c.n_is = 3,
        |c| c.sigma_star_rad = -1.0,
        |c| c.sigma_angular = f64::INFINITY,
        |c| c.solve_every = 0,
        |c| c.max_gap_ticks = 0,
        |c| c.beta_prior[0][1] = 0.0,
        |c| c.com_prior_m[1][2] = f64::NAN,
        |c| c.geometry_m[0][0] = 0.0,
        |c| c.srp_asd_at_3mhz = 0.0,
    ];
    for (k, f) in bad.iter().enumerate() {
        let mut c = config();
        f(&mut c);
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        let rc = unsafe {
            taiji_estimator_init(
                p,
                mem.len() * 8,
                &c,
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            )
        };
        assert_eq!(rc, TAIJI_ERR_CONFIG, "case {k}");
        assert_eq!(
            // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
            unsafe { solve(p) },
            TAIJI_ERR_STATE,
            "case {k}"
        );
    }
    let mut g = Garbage(99);
    for _ in 0..1000 {
        let mut raw = [0u8; std::mem::size_of::<EstimatorConfig>()];
        g.fill(&mut raw);
        // SAFETY: the source holds at least size_of::<T>() bytes; any bytes are a valid T (plain numbers).
        let c: EstimatorConfig = unsafe { std::ptr::read_unaligned(raw.as_ptr() as *const _) };
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        let rc = unsafe {
            taiji_estimator_init(
                p,
                mem.len() * 8,
                &c,
                TAIJI_ABI_VERSION,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            )
        };
        assert!(rc == TAIJI_ERR_CONFIG || rc == TAIJI_OK);
    }
}

#[test]
fn garbage_samples_give_codes_and_a_finite_or_flagged_estimate() {
    let mut g = Garbage(12345);
    let mut mem = memory();
    let p = init(&mut mem);
    let (mut rejected, mut flags) = (0u64, 0u32);
    for k in 0..20_000u64 {
        let mut s = garbage_sample(&mut g);
        if k % 3 == 0 {
            s.header.tick = k; // plausible ticks now and then, so more of it gets in
        }
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        let rc = unsafe { taiji_estimator_update(p, &s, &mut rejected, &mut flags) };
        assert_eq!(rc, TAIJI_OK);
        if flags & TAIJI_SOLVE_DUE != 0 {
            // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
            let rc = unsafe { solve(p) };
            assert!(rc == TAIJI_OK || rc == TAIJI_ERR_SOLVE);
        }
    }
    let mut out = EstimateMsg::default();
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    assert_eq!(unsafe { finish(p, &mut out) }, TAIJI_OK);
    let finite = out
        .beta
        .iter()
        .flatten()
        .chain(out.r_b.iter().flatten())
        .all(|v| v.is_finite());
    assert!(finite || out.status & taiji::sim::msg::ST_UNVERIFIED != 0);
}

#[test]
fn a_checkpoint_restores_the_same_estimator_and_a_torn_one_is_refused() {
    let mut g = Garbage(5);
    let mut mem = memory();
    let p = init(&mut mem);
    let s0 = SensorSample::default();
    for k in 0..50u64 {
        let mut s = s0;
        s.header.tick = k;
        s.star.valid = 1;
        s.star.q_bn = [1.0, 0.0, 0.0, 0.0];
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        unsafe { taiji_estimator_update(p, &s, std::ptr::null_mut(), std::ptr::null_mut()) };
    }
    let mut buf = vec![0u8; taiji_checkpoint_size() + 3];
    let mut n = 0usize;
    // Unaligned buffer on purpose.
    let rc =
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        unsafe { taiji_estimator_checkpoint(p, buf.as_mut_ptr().add(3), buf.len() - 3, &mut n) };
    assert_eq!(rc, TAIJI_OK);
    assert_eq!(n, taiji_checkpoint_size());
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    let small = unsafe { taiji_estimator_checkpoint(p, buf.as_mut_ptr(), n - 1, &mut n) };
    assert_eq!(small, TAIJI_ERR_SIZE);
    let ck = buf[3..3 + n].to_vec();
    let mut mem2 = memory();
    let q = mem2.as_mut_ptr() as *mut u8;
    assert_eq!(
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        unsafe { taiji_estimator_restore(q, mem2.len() * 8, ck.as_ptr(), n, &config()) },
        TAIJI_OK
    );
    let (mut a, mut b) = (EstimateMsg::default(), EstimateMsg::default());
    // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
    unsafe {
        taiji_estimator_estimate(p, &mut a);
        taiji_estimator_estimate(q, &mut b);
    }
    assert_eq!(a, b);
    // An intact checkpoint of a state of another size (another build's layout: the
    // state grew or shrank) is another version, not a corrupted one.
    for delta in [-8i64, 8] {
        let state_len = (n - 32) as i64 + delta;
        let mut other = ck[..32].to_vec();
        other.extend((0..state_len).map(|k| (k * 7 % 251) as u8));
        other[16..24].copy_from_slice(&(state_len as u64).to_le_bytes());
        let sum = taiji::sim::estimate::snapshot::fnv1a(&other[32..]);
        other[24..32].copy_from_slice(&sum.to_le_bytes());
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed.
        let rc = unsafe {
            taiji_estimator_restore(q, mem2.len() * 8, other.as_ptr(), other.len(), &config())
        };
        assert_eq!(rc, TAIJI_ERR_VERSION, "a state {delta:+} B");
    }
    // One of the same size whose state means something else (an older build's: 0 in
    // the version word's high half, its angular Gram on ΔV1 and ΔV2) is too.
    let mut older = ck.clone();
    older[8..16].copy_from_slice(&(taiji::sim::msg::LAYOUT_VERSION as u64).to_le_bytes());
    // SAFETY: as above.
    let rc = unsafe {
        taiji_estimator_restore(q, mem2.len() * 8, older.as_ptr(), older.len(), &config())
    };
    assert_eq!(
        rc, TAIJI_ERR_VERSION,
        "a checkpoint of an older state version"
    );
    // Every torn or flipped checkpoint is refused, and the memory is left unusable.
    for k in 0..200 {
        let mut bad = ck.clone();
        let i = (g.next() as usize) % bad.len();
        bad[i] ^= 1 << (g.next() % 8);
        let len = if k % 10 == 0 { i } else { bad.len() };
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        let rc =
            unsafe { taiji_estimator_restore(q, mem2.len() * 8, bad.as_ptr(), len, &config()) };
        assert!(
            [TAIJI_ERR_CHECKPOINT, TAIJI_ERR_VERSION, TAIJI_ERR_SIZE].contains(&rc),
            "byte {i}: code {rc}"
        );
        // SAFETY: the ABI checks every pointer it is given; these are valid for the sizes passed (or deliberately wrong, which is what is tested).
        assert_eq!(unsafe { solve(q) }, TAIJI_ERR_STATE);
    }
}

/// A sample of tick `k` with a valid star tracker and quiet IS.
fn quiet(k: u64) -> SensorSample {
    let mut s = SensorSample::default();
    s.header.tick = k;
    s.star.valid = 1;
    s.star.q_bn = [1.0, 0.0, 0.0, 0.0];
    s
}

#[test]
fn a_host_built_against_another_header_is_refused_at_init() {
    let mut mem = memory();
    let p = mem.as_mut_ptr() as *mut u8;
    let n = mem.len() * 8;
    for (what, abi) in [
        (
            "an older interface",
            [
                TAIJI_ABI_VERSION as usize - 1,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            ],
        ),
        (
            "another table",
            [
                TAIJI_ABI_VERSION as usize,
                CONFIG_SIZE - 8,
                SAMPLE_SIZE,
                ESTIMATE_SIZE,
            ],
        ),
        (
            "another sample",
            [
                TAIJI_ABI_VERSION as usize,
                CONFIG_SIZE,
                SAMPLE_SIZE + 8,
                ESTIMATE_SIZE,
            ],
        ),
        (
            "another estimate",
            [
                TAIJI_ABI_VERSION as usize,
                CONFIG_SIZE,
                SAMPLE_SIZE,
                ESTIMATE_SIZE - 8,
            ],
        ),
    ] {
        // SAFETY: valid memory and table; only the header's description is wrong.
        let rc =
            unsafe { taiji_estimator_init(p, n, &config(), abi[0] as u32, abi[1], abi[2], abi[3]) };
        assert_eq!(rc, TAIJI_ERR_VERSION, "{what}");
        // SAFETY: as above.
        assert_eq!(unsafe { solve(p) }, TAIJI_ERR_STATE, "{what}");
    }
}

#[test]
fn finish_is_terminal_and_idempotent() {
    let mut mem = memory();
    let p = init(&mut mem);
    for k in 0..700 {
        // SAFETY: an initialised state and a valid sample.
        let rc = unsafe {
            taiji_estimator_update(p, &quiet(k), std::ptr::null_mut(), std::ptr::null_mut())
        };
        assert_eq!(rc, TAIJI_OK);
    }
    let (mut a, mut b, mut c) = (
        EstimateMsg::default(),
        EstimateMsg::default(),
        EstimateMsg::default(),
    );
    // SAFETY: an initialised state and valid outputs.
    unsafe {
        assert_eq!(finish(p, &mut a), TAIJI_OK);
        assert_eq!(finish(p, &mut b), TAIJI_OK);
        assert_eq!(taiji_estimator_estimate(p, &mut c), TAIJI_OK);
        // The scratch is checked on every call, a repeated one too (the header: null
        // is refused).
        assert_eq!(
            taiji_estimator_finish(p, std::ptr::null_mut(), taiji_solve_work_size(), &mut c),
            TAIJI_ERR_NULL
        );
    }
    assert_eq!(a, b, "a second finish changed the estimate");
    assert_eq!(a, c);
    assert_ne!(a.flags & taiji::sim::msg::EST_FINAL, 0);
    let mut buf = vec![0u8; taiji_checkpoint_size()];
    // SAFETY: as above.
    unsafe {
        assert_eq!(
            taiji_estimator_update(p, &quiet(700), std::ptr::null_mut(), std::ptr::null_mut()),
            TAIJI_ERR_FINISHED
        );
        assert_eq!(solve(p), TAIJI_ERR_FINISHED);
        assert_eq!(
            taiji_estimator_checkpoint(p, buf.as_mut_ptr(), buf.len(), std::ptr::null_mut()),
            TAIJI_ERR_FINISHED
        );
    }
}

#[test]
fn restore_is_checked_against_the_hosts_table() {
    let mut mem = memory();
    let p = init(&mut mem);
    for k in 0..100 {
        // SAFETY: an initialised state and a valid sample.
        unsafe { taiji_estimator_update(p, &quiet(k), std::ptr::null_mut(), std::ptr::null_mut()) };
    }
    let mut buf = vec![0u8; taiji_checkpoint_size()];
    let mut n = 0;
    // SAFETY: as above, and a buffer of the checkpoint's size.
    assert_eq!(
        unsafe { taiji_estimator_checkpoint(p, buf.as_mut_ptr(), buf.len(), &mut n) },
        TAIJI_OK
    );
    let mut other = config();
    other.beta_prior[1][2] *= 1.01;
    let mut mem2 = memory();
    let q = mem2.as_mut_ptr() as *mut u8;
    // SAFETY: valid memory, checkpoint and tables.
    unsafe {
        assert_eq!(
            taiji_estimator_restore(q, mem2.len() * 8, buf.as_ptr(), n, &other),
            TAIJI_ERR_CONFIG
        );
        assert_eq!(solve(q), TAIJI_ERR_STATE);
        assert_eq!(
            taiji_estimator_restore(q, mem2.len() * 8, buf.as_ptr(), n, &config()),
            TAIJI_OK
        );
        assert_eq!(
            taiji_estimator_restore(q, mem2.len() * 8, buf.as_ptr(), n, std::ptr::null()),
            TAIJI_ERR_NULL
        );
    }
}

#[test]
fn the_magic_word_over_zeros_is_no_state() {
    let mut mem = memory();
    mem[0] = u64::from_le_bytes(*b"TAIJIEST");
    let p = mem.as_mut_ptr() as *mut u8;
    let mut out = EstimateMsg::default();
    // SAFETY: valid memory that holds no initialised estimator.
    unsafe {
        assert_eq!(taiji_estimator_estimate(p, &mut out), TAIJI_ERR_STATE);
        assert_eq!(finish(p, &mut out), TAIJI_ERR_STATE);
        assert_eq!(
            taiji_estimator_update(p, &quiet(0), std::ptr::null_mut(), std::ptr::null_mut()),
            TAIJI_ERR_STATE
        );
    }
}

#[test]
fn a_bit_flipped_between_calls_is_found_before_the_state_is_used() {
    let mut mem = memory();
    let p = init(&mut mem);
    for k in 0..50 {
        // SAFETY: an initialised state and a valid sample.
        unsafe { taiji_estimator_update(p, &quiet(k), std::ptr::null_mut(), std::ptr::null_mut()) };
    }
    let words = taiji_estimator_size() / 8;
    let mut out = EstimateMsg::default();
    for (w, b) in [
        (1usize, 0u32),
        (words / 2, 62),
        (words - 3, 7),
        (words - 2, 33),
    ] {
        mem[w] ^= 1 << b;
        // SAFETY: an initialised state and valid outputs.
        unsafe {
            assert_eq!(
                taiji_estimator_estimate(p, &mut out),
                TAIJI_ERR_UPSET,
                "word {w} bit {b}"
            );
            // An update checks what it writes and, in turn, one of the parts it only
            // reads (the table is one, word 1): it finds a flip there within a round of
            // them; elsewhere it finds it or leaves it standing for the next whole check.
            let found = (0..u64::from(TAIJI_SCRUB_PARTS)).position(|k| {
                taiji_estimator_update(
                    p,
                    &quiet(50 + k),
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                ) == TAIJI_ERR_UPSET
            });
            // Word 1 is the table's (read only), words - 3 the seal of the part every update
            // writes last (the waiting counts), words - 2 the final estimate's (read only).
            match w {
                _ if w == words - 3 => assert_eq!(found, Some(0), "word {w} bit {b}"),
                _ if w == 1 || w == words - 2 => {
                    assert!(found.is_some(), "word {w} bit {b}: no update found it")
                }
                _ => {}
            }
            assert_eq!(solve(p), TAIJI_ERR_UPSET);
            assert_eq!(finish(p, &mut out), TAIJI_ERR_UPSET);
        }
        mem[w] ^= 1 << b;
        // SAFETY: as above.
        assert_eq!(
            unsafe { taiji_estimator_estimate(p, &mut out) },
            TAIJI_OK,
            "word {w} bit {b} flipped back"
        );
    }
    // The last word says which part the next update checks besides its own (the
    // scrub), modulo their number: any value will do, and a flip there is no upset.
    mem[words - 1] ^= 1 << 45;
    // SAFETY: as above.
    unsafe {
        assert_eq!(taiji_estimator_estimate(p, &mut out), TAIJI_OK);
        assert_eq!(
            taiji_estimator_update(p, &quiet(200), std::ptr::null_mut(), std::ptr::null_mut()),
            TAIJI_OK
        );
    }
    // The magic word (the state's first 8 bytes) is outside the seal: a flip there is
    // an upset too, not memory that never held a state.
    for b in 0..64 {
        mem[0] ^= 1 << b;
        // SAFETY: as above.
        unsafe {
            assert_eq!(
                taiji_estimator_estimate(p, &mut out),
                TAIJI_ERR_UPSET,
                "magic bit {b}"
            );
            assert_eq!(finish(p, &mut out), TAIJI_ERR_UPSET, "magic bit {b}");
        }
        mem[0] ^= 1 << b;
    }
    // Two bits of the magic and one of the state: still an upset; a zeroed magic word
    // (what a failed init leaves) is no state.
    mem[0] ^= 0b101 << 9;
    mem[words / 3] ^= 1 << 40;
    // SAFETY: as above.
    assert_eq!(
        unsafe { taiji_estimator_estimate(p, &mut out) },
        TAIJI_ERR_UPSET
    );
    mem[0] = 0;
    // SAFETY: as above.
    assert_eq!(
        unsafe { taiji_estimator_estimate(p, &mut out) },
        TAIJI_ERR_STATE
    );
}

/// The solve's scratch is the caller's: refused when null, too small or misaligned,
/// and its contents do not matter (a campaign solved with 0xFF-filled scratch gives the
/// bits of one solved with zeroed scratch).
/// `estimate` counts its message and updates the seal for the sequence number's word
/// alone: the state stays sealed through any number of them between updates.
#[test]
fn estimates_count_themselves_and_leave_the_state_sealed() {
    let mut mem = memory();
    let p = init(&mut mem);
    let mut last = None;
    for k in 0..200u64 {
        let mut flags = 0u32;
        // SAFETY: an initialised state, a valid sample and an output.
        let rc = unsafe { taiji_estimator_update(p, &quiet(k), std::ptr::null_mut(), &mut flags) };
        assert_eq!(rc, TAIJI_OK, "update after {k} estimates");
        for _ in 0..(k % 3) {
            let mut m = EstimateMsg::default();
            // SAFETY: as above.
            assert_eq!(unsafe { taiji_estimator_estimate(p, &mut m) }, TAIJI_OK);
            if let Some(seq) = last {
                assert_eq!(m.header.seq, seq + 1);
            }
            last = Some(m.header.seq);
        }
    }
}

#[test]
fn the_solve_work_memory_is_checked_and_its_contents_do_not_matter() {
    let c = taiji::analysis::upset::Campaign::new(200.0, 3);
    let n = taiji_solve_work_size();
    assert!(n > 64 * 1024, "the Jacobian alone is 55 kB");
    let mut out = [EstimateMsg::default(); 2];
    for (fill, out) in [0u64, u64::MAX].into_iter().zip(out.iter_mut()) {
        let mut mem = memory();
        let p = init(&mut mem);
        let mut w = vec![fill; n / 8 + 2];
        let wp = w.as_mut_ptr() as *mut u8;
        let mut flags = 0u32;
        // SAFETY: valid state, samples and scratch, and deliberately wrong scratch,
        // which the ABI checks before use.
        unsafe {
            assert_eq!(
                taiji_estimator_solve(p, std::ptr::null_mut(), n),
                TAIJI_ERR_NULL
            );
            assert_eq!(taiji_estimator_solve(p, wp, n - 1), TAIJI_ERR_SIZE);
            assert_eq!(taiji_estimator_solve(p, wp.add(1), n), TAIJI_ERR_ALIGNMENT);
            // The state itself as scratch would overwrite it: refused, the state intact.
            let size = taiji_estimator_size();
            assert_eq!(taiji_estimator_solve(p, p, size.max(n)), TAIJI_ERR_OVERLAP);
            assert_eq!(
                taiji_estimator_solve(p, p.add(size - 8), n),
                TAIJI_ERR_OVERLAP
            );
            for s in &c.samples {
                let rc = taiji_estimator_update(p, s, std::ptr::null_mut(), &mut flags);
                assert_eq!(rc, TAIJI_OK);
                if flags & TAIJI_SOLVE_DUE != 0 {
                    assert_eq!(taiji_estimator_solve(p, wp, n), TAIJI_OK);
                    w.iter_mut().for_each(|x| *x = fill);
                }
            }
            assert_eq!(
                taiji_estimator_finish(p, std::ptr::null_mut(), n, out),
                TAIJI_ERR_NULL
            );
            assert_eq!(taiji_estimator_finish(p, wp, n, out), TAIJI_OK);
        }
        assert!(out.n_used > 1000, "the campaign was taken");
    }
    assert_eq!(
        bytemuck::bytes_of(&out[0]),
        bytemuck::bytes_of(&out[1]),
        "the scratch's contents leaked into the result"
    );
}
