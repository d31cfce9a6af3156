//! Fault injection (scenario section `[faults]`): what orbit and a bus do to samples —
//! single-event upsets, outliers, stuck channels, star-tracker jumps and dropouts, and
//! duplicated, reordered, missing and garbage-headed messages — so the estimator's
//! integrity can be scored (`report.json` → `faults`).
//!
//! Sample faults draw from their own random stream (`Stream::Faults`), so the clean
//! noise is the same with and without them; bus faults are a pure function of the seed
//! and the tick, so a front-end resending after an estimator restart repeats them.
//! Every injected fault is logged as a [`FaultRecord`] (telemetry `/faults/*`).

use crate::sim::msg::{SensorSample, FLAG_DROPOUT};
use crate::sim::rng::{stream, Rng, Stream};
use crate::sim::scenario::{Scenario, ARCSEC};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::Rng as _;

pub use crate::sim::scenario::faults::{FaultsConfig, MAX_EVENTS};

/// Kinds of injected fault (`FaultRecord::kind`, telemetry `/faults/kind`).
pub const KIND_UPSET: u8 = 0;
pub const KIND_OUTLIER: u8 = 1;
pub const KIND_STUCK: u8 = 2;
pub const KIND_STAR_JUMP: u8 = 3;
pub const KIND_IS_DROPOUT: u8 = 4;
pub const KIND_STAR_DROPOUT: u8 = 5;
pub const KIND_DUPLICATE: u8 = 6;
pub const KIND_REORDER: u8 = 7;
pub const KIND_MISSING: u8 = 8;
pub const KIND_GARBAGE_HEADER: u8 = 9;
pub const KIND_NAMES: [&str; 10] = [
    "upset",
    "outlier",
    "stuck_channel",
    "star_jump",
    "is_dropout",
    "star_dropout",
    "duplicate",
    "reorder",
    "missing",
    "garbage_header",
];

/// Field indices (`FaultRecord::field`): IS i voltage V_{p,c} is `6 i + 2 p + c`, IS i
/// flags `12 + i`, star-tracker quaternion component k `14 + k`, its validity 18,
/// the header 19.
pub const FIELD_IS_FLAGS: u8 = 12;
pub const FIELD_STAR_Q: u8 = 14;
pub const FIELD_STAR_VALID: u8 = 18;
pub const FIELD_HEADER: u8 = 19;

/// One injected fault: which sample, what, and by how much in units of the field's
/// noise (∞ for flags, NaN/Inf values and bus faults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultRecord {
    pub tick: u64,
    pub kind: u8,
    pub field: u8,
    /// Bit flipped (upsets), else 0.
    pub bit: u8,
    /// Samples affected (stuck channels, star jumps), else 1.
    pub samples: u32,
    pub before: f64,
    pub after: f64,
    pub sigmas: f64,
}

#[derive(Debug, Clone, Copy)]
struct Event {
    tick: u64,
    field: u8,
    end: u64,
    value: f64,
    axis: [f64; 3],
}

/// The injector of one campaign.
#[derive(Debug, Clone)]
pub struct Injector {
    cfg: FaultsConfig,
    rng: Rng,
    seed: u64,
    /// Ticks of the campaign: the last two carry no bus faults (the set must see the
    /// last tick to finish).
    n: u64,
    n_is: usize,
    /// 1σ noise of each IS voltage [V] and of a quaternion component [-].
    sigma_volt: [f64; 2],
    sigma_q: f64,
    outliers: heapless::Vec<Event, MAX_EVENTS>,
    stuck: heapless::Vec<Event, MAX_EVENTS>,
    jumps: heapless::Vec<Event, MAX_EVENTS>,
    garbage: heapless::Vec<u64, MAX_EVENTS>,
    /// Remaining star samples to rotate in the current jump, and its rotation.
    jump_left: u32,
    jump_q: UnitQuaternion<f64>,
    /// Value each stuck event holds.
    held: heapless::Vec<f64, MAX_EVENTS>,
}

/// Uniform [0, 1) from a hash of (seed, tick, salt): bus faults as a pure function.
fn hash_unit(seed: u64, tick: u64, salt: u64) -> f64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(tick.wrapping_mul(0xD1B5_4A32_D192_ED03))
        .wrapping_add(salt.wrapping_mul(0x94D0_49BB_1331_11EB));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// What the bus delivers in one tick's turn, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// A message with a garbage header (and this tick's payload).
    Garbage,
    /// This tick's sample.
    This,
    /// The previous tick's sample, held back one turn (reordered).
    Previous,
}

impl Injector {
    pub fn new(s: &Scenario, seed: u64) -> Self {
        let cfg = s.faults.clone();
        let mut rng = stream(seed, Stream::Faults);
        let n = s.n_samples().max(2);
        let n_is = s.inertial_sensor.len();
        let fs = s.sample_rate_hz;
        let fe = &s.front_end;
        let mut sigma_volt = [1.0; 2];
        for (i, is) in s.inertial_sensor.iter().enumerate().take(2) {
            let k = is.k();
            let kmin = k.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
            let bmin = is.beta.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
            let sum = crate::sim::model::noise::white_sigma(fe.linear_noise_rthz, fs) / kmin;
            let diff = crate::sim::model::noise::white_sigma(fe.angular_noise_rthz, fs) / bmin;
            sigma_volt[i] = 0.5 * (sum * sum + diff * diff).sqrt();
        }
        // Events start after the first 10 s (the estimator needs a first sample to
        // stand on; orbit does not care, but a test of detection needs a reference).
        let first = ((10.0 * fs) as u64).min(n / 2);
        let tick = |rng: &mut Rng| rng.gen_range(first..n);
        let field = |rng: &mut Rng| (6 * rng.gen_range(0..n_is) + rng.gen_range(0..6)) as u8;
        let mut outliers = heapless::Vec::new();
        for _ in 0..cfg.outliers {
            let (t, f) = (tick(&mut rng), field(&mut rng));
            let sign = if rng.gen::<bool>() { 1.0 } else { -1.0 };
            let _ = outliers.push(Event {
                tick: t,
                field: f,
                end: t + 1,
                value: sign * cfg.outlier_volts,
                axis: [0.0; 3],
            });
        }
        let mut stuck = heapless::Vec::new();
        let mut held = heapless::Vec::new();
        let len = (cfg.stuck_duration_s * fs).round().max(1.0) as u64;
        for _ in 0..cfg.stuck_channels {
            let (t, f) = (tick(&mut rng), field(&mut rng));
            let _ = stuck.push(Event {
                tick: t,
                field: f,
                end: t + len,
                value: 0.0,
                axis: [0.0; 3],
            });
            let _ = held.push(f64::NAN);
        }
        let mut jumps = heapless::Vec::new();
        for _ in 0..cfg.star_jumps {
            let t = tick(&mut rng);
            let v = Vector3::from_fn(|_, _| crate::sim::rng::gauss(&mut rng)).normalize();
            let _ = jumps.push(Event {
                tick: t,
                field: FIELD_STAR_Q,
                end: t,
                value: cfg.star_jump_rad,
                axis: v.into(),
            });
        }
        jumps.sort_unstable_by_key(|e| e.tick);
        let mut garbage = heapless::Vec::new();
        for _ in 0..cfg.garbage_headers {
            let _ = garbage.push(tick(&mut rng));
        }
        Injector {
            cfg,
            rng,
            seed,
            n,
            n_is,
            sigma_volt,
            sigma_q: 0.5 * s.star_tracker.noise_3sigma_arcsec / 3.0 * ARCSEC,
            outliers,
            stuck,
            jumps,
            garbage,
            jump_left: 0,
            jump_q: UnitQuaternion::identity(),
            held,
        }
    }

    /// This injector's data losses alone: IS and star-tracker dropouts and ticks the
    /// bus never delivers, at the same draws (every random number is still drawn, so
    /// the same ticks are lost), the faults that corrupt data left out. The Cramér–Rao
    /// bound's stream of a campaign with losses (`crlb`).
    pub fn losses_only(mut self) -> Self {
        self.outliers.clear();
        self.stuck.clear();
        self.held.clear();
        self.jumps.clear();
        self.garbage.clear();
        self.cfg.upset_rate = 0.0;
        self.cfg.duplicate_rate = 0.0;
        self.cfg.reorder_rate = 0.0;
        self
    }

    pub fn enabled(&self) -> bool {
        self.cfg.any()
    }

    fn volt_mut(s: &mut SensorSample, field: u8) -> &mut f64 {
        let f = field as usize;
        &mut s.is[f / 6].volts[(f % 6) / 2][f % 2]
    }

    /// Apply this tick's sample faults (call once per tick, in tick order), logging
    /// each into `log`.
    pub fn corrupt(&mut self, s: &mut SensorSample, log: &mut impl FnMut(FaultRecord)) {
        if !self.cfg.any() {
            return;
        }
        let tick = s.header.tick;
        let rec = |kind, field, bit, before: f64, after: f64, sigmas| FaultRecord {
            tick,
            kind,
            field,
            bit,
            samples: 1,
            before,
            after,
            sigmas,
        };
        // Dropouts (one draw per IS and one for the star tracker, every tick, so the
        // stream does not depend on the data).
        for i in 0..2 {
            let u: f64 = self.rng.gen();
            if i < self.n_is && u < self.cfg.is_dropout_rate {
                s.is[i].flags |= FLAG_DROPOUT;
                s.is[i].volts = [[f64::NAN; 2]; 3];
                log(rec(
                    KIND_IS_DROPOUT,
                    FIELD_IS_FLAGS + i as u8,
                    0,
                    0.0,
                    0.0,
                    f64::INFINITY,
                ));
            }
        }
        let u: f64 = self.rng.gen();
        if s.star.valid == 1 && u < self.cfg.star_dropout_rate {
            s.star.valid = 0;
            log(rec(KIND_STAR_DROPOUT, FIELD_STAR_VALID, 0, 1.0, 0.0, 0.0));
        }
        // Stuck channels hold the value they had when they stuck.
        for (e, h) in self.stuck.iter().zip(self.held.iter_mut()) {
            if tick < e.tick || tick >= e.end || s.is[e.field as usize / 6].flags != 0 {
                continue;
            }
            let v = Self::volt_mut(s, e.field);
            if tick == e.tick {
                *h = *v;
                log(FaultRecord {
                    samples: (e.end - e.tick) as u32,
                    ..rec(KIND_STUCK, e.field, 0, *v, *v, 0.0)
                });
            } else {
                *v = *h;
            }
        }
        for e in self.outliers.iter().filter(|e| e.tick == tick) {
            let sig = self.sigma_volt[e.field as usize / 6];
            let v = Self::volt_mut(s, e.field);
            let before = *v;
            *v = e.value;
            log(rec(
                KIND_OUTLIER,
                e.field,
                0,
                before,
                e.value,
                ((e.value - before) / sig).abs(),
            ));
        }
        // Star-tracker jumps rotate the next `star_jump_samples` valid samples.
        for e in self.jumps.iter().filter(|e| e.tick == tick) {
            self.jump_left += self.cfg.star_jump_samples;
            self.jump_q = UnitQuaternion::from_scaled_axis(Vector3::from(e.axis) * e.value);
        }
        if self.jump_left > 0 && s.star.valid == 1 {
            let q = s.star.q_bn;
            let q = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
            let r = (q * self.jump_q).into_inner();
            s.star.q_bn = [r.w, r.i, r.j, r.k];
            if self.jump_left == self.cfg.star_jump_samples {
                log(FaultRecord {
                    samples: self.cfg.star_jump_samples,
                    ..rec(
                        KIND_STAR_JUMP,
                        FIELD_STAR_Q,
                        0,
                        0.0,
                        self.cfg.star_jump_rad,
                        (self.cfg.star_jump_rad / (2.0 * self.sigma_q)).abs(),
                    )
                });
            }
            self.jump_left -= 1;
        }
        // Single-event upset: one bit of one field.
        let u: f64 = self.rng.gen();
        let n_fields = 7 * self.n_is + 5;
        let pick = self.rng.gen_range(0..n_fields);
        let bit64 = self.rng.gen_range(0..64u8);
        if u < self.cfg.upset_rate {
            let (field, bit) = if pick < 6 * self.n_is {
                (pick as u8, bit64)
            } else if pick < 7 * self.n_is {
                (FIELD_IS_FLAGS + (pick - 6 * self.n_is) as u8, bit64 % 8)
            } else if pick < 7 * self.n_is + 4 {
                (FIELD_STAR_Q + (pick - 7 * self.n_is) as u8, bit64)
            } else {
                (FIELD_STAR_VALID, bit64 % 8)
            };
            let (before, after, sigmas) = self.flip(s, field, bit);
            log(rec(KIND_UPSET, field, bit, before, after, sigmas));
        }
    }

    /// Flip `bit` of `field`; returns (before, after, |change| in noise σ).
    fn flip(&self, s: &mut SensorSample, field: u8, bit: u8) -> (f64, f64, f64) {
        let moved = |b: f64, a: f64, sig: f64| {
            if a.is_finite() {
                ((a - b) / sig).abs()
            } else {
                f64::INFINITY
            }
        };
        if field < FIELD_IS_FLAGS {
            let sig = self.sigma_volt[field as usize / 6];
            let v = Self::volt_mut(s, field);
            let b = *v;
            *v = f64::from_bits(b.to_bits() ^ (1u64 << bit));
            (b, *v, moved(b, *v, sig))
        } else if field < FIELD_STAR_Q {
            let f = &mut s.is[(field - FIELD_IS_FLAGS) as usize].flags;
            let b = *f;
            *f ^= 1 << bit;
            (b as f64, *f as f64, f64::INFINITY)
        } else if field < FIELD_STAR_VALID {
            let v = &mut s.star.q_bn[(field - FIELD_STAR_Q) as usize];
            let b = *v;
            *v = f64::from_bits(b.to_bits() ^ (1u64 << bit));
            // Between star-tracker samples the quaternion is not read at all.
            let sig = if s.star.valid == 1 {
                self.sigma_q
            } else {
                f64::INFINITY
            };
            (
                b,
                *v,
                if sig.is_finite() {
                    moved(b, *v, sig)
                } else {
                    0.0
                },
            )
        } else {
            let b = s.star.valid;
            s.star.valid ^= 1 << bit;
            // Losing a sample (1 → 0) is harmless; anything else is a corrupt flag.
            let sig = if s.star.valid == 0 {
                0.0
            } else {
                f64::INFINITY
            };
            (b as f64, s.star.valid as f64, sig)
        }
    }

    /// The bus's deliveries in tick `tick`'s turn (a pure function of seed and tick).
    pub fn deliveries(&self, tick: u64) -> heapless::Vec<Delivery, 4> {
        let mut out = heapless::Vec::new();
        if !self.bus_active(tick) {
            let _ = out.push(Delivery::This);
            if tick > 0 && self.delayed(tick - 1) {
                let _ = out.push(Delivery::Previous);
            }
            return out;
        }
        if self.garbage.contains(&tick) {
            let _ = out.push(Delivery::Garbage);
        }
        if !self.delayed(tick) && !self.missing(tick) {
            let _ = out.push(Delivery::This);
            if hash_unit(self.seed, tick, 3) < self.cfg.duplicate_rate {
                let _ = out.push(Delivery::This);
            }
        }
        if tick > 0 && self.delayed(tick - 1) {
            let _ = out.push(Delivery::Previous);
        }
        out
    }

    /// Bus faults are off for the last ticks (the set must see the last tick to
    /// finish, and a held tick must have a next turn).
    fn bus_active(&self, tick: u64) -> bool {
        self.cfg.bus_any() && tick + 3 < self.n
    }

    /// The turn's deliveries with, for each, the tick whose sample it carries (a
    /// garbage header: the turn's) and whether it is that sample's second copy; what
    /// `FaultScore::observe` takes.
    pub fn annotated_deliveries(&self, tick: u64) -> heapless::Vec<(Delivery, u64, bool), 4> {
        let mut out = heapless::Vec::new();
        let mut copies = 0;
        for d in self.deliveries(tick) {
            let of = if d == Delivery::Previous {
                tick.saturating_sub(1)
            } else {
                tick
            };
            let _ = out.push((d, of, d == Delivery::This && copies > 0));
            copies += u32::from(d == Delivery::This);
        }
        out
    }

    /// Held back to the next turn (odd ticks only, so a held tick never follows one).
    fn delayed(&self, tick: u64) -> bool {
        self.bus_active(tick)
            && tick % 2 == 1
            && hash_unit(self.seed, tick, 1) < self.cfg.reorder_rate
    }

    fn missing(&self, tick: u64) -> bool {
        hash_unit(self.seed, tick, 2) < self.cfg.missing_rate
    }

    /// Bus faults of tick `tick`'s turn, for the log.
    pub fn bus_records(&self, tick: u64, log: &mut impl FnMut(FaultRecord)) {
        let r = |kind| FaultRecord {
            tick,
            kind,
            field: FIELD_HEADER,
            bit: 0,
            samples: 1,
            before: 0.0,
            after: 0.0,
            sigmas: f64::INFINITY,
        };
        if !self.bus_active(tick) {
            return;
        }
        if self.garbage.contains(&tick) {
            log(r(KIND_GARBAGE_HEADER));
        }
        if self.delayed(tick) {
            // With the next tick lost the held sample comes alone in the next turn, after
            // the one before it: late, but in order, nothing for the estimator to
            // reject. Harmless (σ 0), not missed.
            let mut rec = r(KIND_REORDER);
            if self.bus_active(tick + 1) && self.missing(tick + 1) {
                rec.sigmas = 0.0;
            }
            log(rec);
        } else if self.missing(tick) {
            log(r(KIND_MISSING));
        } else if hash_unit(self.seed, tick, 3) < self.cfg.duplicate_rate {
            log(r(KIND_DUPLICATE));
        }
    }

    /// A message with a garbage header (random bytes from the seed and tick) and the
    /// payload of `s`.
    /// The message delivery `d` carries: this tick's sample, the previous tick's
    /// (held back by a reorder; this one's if there is none), or this one with a
    /// garbage header. The live front end, the in-process campaign and replay all
    /// deliver through it.
    pub fn delivered(
        &self,
        d: Delivery,
        this: &SensorSample,
        prev: Option<&SensorSample>,
    ) -> SensorSample {
        match d {
            Delivery::This => *this,
            Delivery::Previous => *prev.unwrap_or(this),
            Delivery::Garbage => self.garbage(this),
        }
    }

    pub fn garbage(&self, s: &SensorSample) -> SensorSample {
        let mut g = *s;
        let word = |salt| (hash_unit(self.seed, s.header.tick, salt) * (1u64 << 53) as f64) as u64;
        g.header.seq = word(10) << 11;
        g.header.tick = (word(11) << 11) | word(12);
        g.header.sim_time_ns = (word(13) << 11) as i64;
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_faults_change_nothing_and_bus_delivers_each_tick_once() {
        let s = Scenario::default();
        let mut inj = Injector::new(&s, 1);
        let mut sample = SensorSample::default();
        sample.is[0].volts = [[1.0, 2.0]; 3];
        let before = sample;
        inj.corrupt(&mut sample, &mut |_| panic!("no fault expected"));
        assert_eq!(sample, before);
        assert_eq!(&inj.deliveries(5)[..], &[Delivery::This]);
    }

    /// Both IS and the star tracker delivering, at `tick`.
    fn valid_sample(tick: u64) -> SensorSample {
        let mut sample = SensorSample::default();
        sample.header.tick = tick;
        sample.is[0].volts = [[1.5, -2.5], [0.25, 3.0], [7.0, -1.0]];
        sample.is[1].volts = sample.is[0].volts;
        sample.star.valid = 1;
        sample.star.q_bn = [1.0, 0.0, 0.0, 0.0];
        sample
    }

    #[test]
    fn losses_only_loses_the_same_ticks_and_corrupts_nothing() {
        // The bound of a campaign with losses must lose the ticks its run loses, also
        // when other faults draw from the same random stream.
        let s = Scenario::from_toml_str(
            "[faults]\nis_dropout_rate = 0.05\nstar_dropout_rate = 0.05\nmissing_rate = 0.02\n\
             upset_rate = 0.3\noutliers = 20\nstuck_channels = 2\nstar_jumps = 3\n\
             duplicate_rate = 0.05\nreorder_rate = 0.05\ngarbage_headers = 5\n",
        )
        .unwrap();
        let mut all = Injector::new(&s, 4);
        let mut losses = Injector::new(&s, 4).losses_only();
        let lost = |r: &FaultRecord| matches!(r.kind, KIND_IS_DROPOUT | KIND_STAR_DROPOUT);
        let (mut n_lost, mut n_missing) = (0, 0);
        for tick in 0..s.n_samples() {
            let sample = valid_sample(tick);
            let (mut a, mut b) = (sample, sample);
            let (mut ra, mut rb) = (Vec::new(), Vec::new());
            all.corrupt(&mut a, &mut |r| ra.push(r));
            losses.corrupt(&mut b, &mut |r| rb.push(r));
            ra.retain(lost);
            assert_eq!(ra, rb, "tick {tick}");
            n_lost += rb.len();
            // Nothing but the losses: every IS that did not drop out is untouched.
            for i in 0..2 {
                if b.is[i].flags & FLAG_DROPOUT == 0 {
                    assert_eq!(b.is[i], sample.is[i], "tick {tick}");
                }
            }
            assert_eq!(b.star.q_bn, sample.star.q_bn);
            // The bus: what is missing in the run is missing here; nothing else.
            let d: Vec<Delivery> = losses.deliveries(tick).to_vec();
            if all.bus_active(tick) && all.missing(tick) {
                assert!(d.is_empty(), "tick {tick}");
                n_missing += 1;
            } else {
                assert_eq!(d, [Delivery::This], "tick {tick}");
            }
        }
        assert!(n_lost > 1000 && n_missing > 100, "{n_lost} {n_missing}");
    }

    /// The process set scores its faults from the recording's log (the supervisor);
    /// that score must be the live one, also for faults in samples the bus lost
    /// (`not_delivered`, not `missed`; found by tools/sanitize comparing the set's
    /// report with `run`'s).
    #[test]
    fn the_score_from_the_log_is_the_live_score_also_for_samples_the_bus_lost() {
        use crate::sim::msg::{CAUSE_IS_FLAGGED, CAUSE_TICK_MISSING, CAUSE_TICK_ORDER};
        let s = Scenario::from_toml_str(
            "seed = 7
duration_s = 600.0
[faults]
is_dropout_rate = 0.05
\
             star_dropout_rate = 0.05
missing_rate = 0.05
upset_rate = 0.01
\
             outliers = 20
stuck_channels = 2
star_jumps = 3
duplicate_rate = 0.05
\
             reorder_rate = 0.05
garbage_headers = 5
",
        )
        .unwrap();
        let mut inj = Injector::new(&s, s.seed);
        let mut live = FaultScore::new(&s);
        for tick in 0..s.n_samples() {
            let mut sample = valid_sample(tick);
            inj.corrupt(&mut sample, &mut |r| live.push(r));
            inj.bus_records(tick, &mut |r| live.push(r));
            for (d, of, second) in inj.annotated_deliveries(tick) {
                // Any rejections will do: the log carries the live detection counts.
                let mask = match (of * 7 + tick) % 5 {
                    0 => 1 << CAUSE_IS_FLAGGED,
                    1 => 1 << CAUSE_TICK_MISSING,
                    2 => 1 << CAUSE_TICK_ORDER,
                    _ => 0,
                };
                live.observe(of, d, second, mask);
            }
        }
        let logged = FaultScore::from_log(&s, live.records.clone(), live.detected.clone());
        let (a, b) = (logged.summary(), live.summary());
        assert_eq!(a, b);
        for kind in ["is_dropout", "star_dropout"] {
            let n = &b["by_kind"][kind]["not_delivered"];
            assert!(n.as_u64().unwrap() > 0, "{kind}: {n}");
        }
    }

    #[test]
    fn an_upset_flips_exactly_one_bit() {
        let s = Scenario::from_toml_str("[faults]\nupset_rate = 0.5\n").unwrap();
        let mut inj = Injector::new(&s, 2);
        let mut n = 0;
        for tick in 0..200 {
            let mut sample = valid_sample(tick);
            let clean = sample;
            let mut recs = Vec::new();
            inj.corrupt(&mut sample, &mut |r| recs.push(r));
            let words = |x: &SensorSample| {
                let mut w: Vec<u64> =
                    x.is.iter()
                        .flat_map(|i| i.volts.iter().flatten().map(|v| v.to_bits()))
                        .collect();
                w.extend(x.is.iter().map(|i| i.flags as u64));
                w.extend(x.star.q_bn.iter().map(|v| v.to_bits()));
                w.push(x.star.valid as u64);
                w
            };
            let flipped: u32 = words(&clean)
                .iter()
                .zip(words(&sample))
                .map(|(a, b)| (a ^ b).count_ones())
                .sum();
            assert_eq!(flipped as usize, recs.len());
            n += recs.len();
        }
        assert!(n > 60 && n < 140, "{n} upsets at rate 0.5 in 200 ticks");
    }

    #[test]
    fn bus_faults_are_a_pure_function_of_the_tick() {
        let s = Scenario::from_toml_str(
            "[faults]\nduplicate_rate = 0.1\nreorder_rate = 0.1\nmissing_rate = 0.1\n",
        )
        .unwrap();
        let (a, b) = (Injector::new(&s, 9), Injector::new(&s, 9));
        let mut this = 0;
        for t in 0..10_000 {
            assert_eq!(a.deliveries(t), b.deliveries(t));
            this += a
                .deliveries(t)
                .iter()
                .filter(|d| **d != Delivery::Garbage)
                .count();
        }
        // Duplicates add, missing ticks remove, reorders keep the count.
        assert!((9_500..10_500).contains(&this), "{this}");
    }

    #[test]
    fn a_reorder_before_a_lost_tick_arrives_in_order_and_is_scored_harmless() {
        let s =
            Scenario::from_toml_str("[faults]\nreorder_rate = 0.3\nmissing_rate = 0.3\n").unwrap();
        let inj = Injector::new(&s, 4);
        let (mut alone, mut reordered) = (0, 0);
        for t in 0..2_000 {
            let mut recs = Vec::new();
            inj.bus_records(t, &mut |r| recs.push(r));
            for r in recs.iter().filter(|r| r.kind == KIND_REORDER) {
                let next = inj.deliveries(t + 1);
                if next.contains(&Delivery::This) {
                    // Sent after the next one: out of order, for the estimator to catch.
                    assert!(r.sigmas.is_infinite());
                    reordered += 1;
                } else {
                    // The next one lost: the held sample comes alone, in order.
                    assert_eq!(&next[..], &[Delivery::Previous]);
                    assert_eq!(r.sigmas, 0.0);
                    alone += 1;
                }
            }
        }
        assert!(alone > 10 && reordered > 10, "{alone} {reordered}");
    }
}

/// Scores detection: which injected faults the estimator rejected. Fed every fault
/// record and, for every message the estimator took, its tick, the delivery and the
/// estimate's `tick_rejections`.
#[derive(Debug, Clone, Default)]
pub struct FaultScore {
    pub records: Vec<FaultRecord>,
    /// Samples of each record the estimator rejected.
    pub detected: Vec<u64>,
    /// Whether the record's sample reached the estimator at all.
    delivered: Vec<bool>,
    by_tick: std::collections::HashMap<u64, Vec<usize>>,
    spans: Vec<(u64, u64, usize)>,
    /// Star-tracker samples per tick (to size a star jump's span) [ticks].
    star_spacing: u64,
}

impl FaultScore {
    pub fn new(s: &Scenario) -> Self {
        FaultScore {
            star_spacing: (s.sample_rate_hz / s.star_tracker.rate_hz).ceil().max(1.0) as u64,
            ..Default::default()
        }
    }

    /// A score from a recorded log and its detection counts (`/faults/*`) of the run
    /// of scenario `s` (its seed applied). What reached the estimator is not in the
    /// log: the run's bus, a pure function of seed and tick, is replayed for it, so a
    /// fault in a sample the bus never delivered counts as not delivered, as in the
    /// live score.
    pub fn from_log(s: &Scenario, records: Vec<FaultRecord>, detected: Vec<u64>) -> Self {
        let mut sc = FaultScore::new(s);
        let n = records.len().min(detected.len());
        for r in records.into_iter().take(n) {
            sc.push(r);
        }
        let bus = Injector::new(s, s.seed);
        for tick in 0..s.n_samples() {
            for (d, of, second) in bus.annotated_deliveries(tick) {
                sc.visit(of, d, second, 0, false);
            }
        }
        for (i, d) in detected.into_iter().take(n).enumerate() {
            sc.detected[i] = d;
            // A lost sample is known (delivered, for the score) once a later tick
            // revealed it: exactly when it was detected.
            if sc.records[i].kind == KIND_MISSING {
                sc.delivered[i] = d > 0;
            }
        }
        sc
    }

    pub fn push(&mut self, r: FaultRecord) {
        let i = self.records.len();
        self.records.push(r);
        self.detected.push(0);
        self.delivered.push(false);
        match r.kind {
            KIND_STUCK => self.spans.push((r.tick, r.tick + r.samples as u64, i)),
            KIND_STAR_JUMP => {
                self.spans
                    .push((r.tick, r.tick + r.samples as u64 * self.star_spacing + 1, i))
            }
            _ => self.by_tick.entry(r.tick).or_default().push(i),
        }
    }

    /// A message the estimator took: the tick whose sample it carried (for a garbage
    /// header, the turn's tick), the delivery, whether it was the turn's second copy,
    /// and the estimate's `tick_rejections`.
    pub fn observe(&mut self, tick: u64, d: Delivery, second: bool, mask: u64) {
        self.visit(tick, d, second, mask, true);
    }

    /// [`observe`](Self::observe); with `count` false it only marks what was delivered.
    fn visit(&mut self, tick: u64, d: Delivery, second: bool, mask: u64, count: bool) {
        use crate::sim::msg::*;
        let order = 1 << CAUSE_TICK_ORDER;
        let bus = |k: u8| -> bool {
            match k {
                KIND_GARBAGE_HEADER => mask & (1 << CAUSE_TICK_JUMP | order) != 0,
                KIND_DUPLICATE => second && mask & order != 0,
                KIND_REORDER => d == Delivery::Previous && mask & order != 0,
                _ => false,
            }
        };
        if count && mask & (1 << CAUSE_TICK_MISSING) != 0 {
            // Missing ticks before this one were noticed when this one came.
            for (_, idx) in self.by_tick.iter().filter(|(t, _)| **t < tick) {
                for &i in idx {
                    if self.records[i].kind == KIND_MISSING {
                        self.detected[i] = 1;
                        self.delivered[i] = true;
                    }
                }
            }
        }
        if let Some(idx) = self.by_tick.get(&tick) {
            for &i in idx {
                let k = self.records[i].kind;
                match k {
                    KIND_GARBAGE_HEADER if d == Delivery::Garbage => {
                        self.delivered[i] = true;
                        self.detected[i] += u64::from(count && bus(k));
                    }
                    KIND_DUPLICATE | KIND_REORDER if d != Delivery::Garbage => {
                        self.delivered[i] = true;
                        self.detected[i] += u64::from(count && bus(k));
                    }
                    KIND_MISSING | KIND_GARBAGE_HEADER | KIND_DUPLICATE | KIND_REORDER => {}
                    _ if d != Delivery::Garbage && !second => {
                        self.delivered[i] = true;
                        self.detected[i] += u64::from(count && mask != 0);
                    }
                    _ => {}
                }
            }
        }
        if d != Delivery::Garbage && !second {
            for &(a, b, i) in &self.spans {
                if tick >= a && tick < b {
                    self.delivered[i] = true;
                    self.detected[i] += u64::from(count && mask != 0);
                }
            }
        }
    }

    /// Was record `i` detected? A stuck stretch's first sample is genuine; a star jump
    /// must have every rotated sample rejected.
    pub fn is_detected(&self, i: usize) -> bool {
        let r = &self.records[i];
        match r.kind {
            KIND_STUCK => self.detected[i] + 1 >= r.samples as u64,
            KIND_STAR_JUMP => self.detected[i] >= r.samples as u64,
            // Losing a star-tracker sample needs no detection.
            KIND_STAR_DROPOUT => true,
            _ => self.detected[i] > 0,
        }
    }

    /// The report's `faults` object: per kind injected, detected, missed (undetected
    /// and larger than 5 noise σ) and undetected harmless ones; and the first misses.
    pub fn summary(&self) -> serde_json::Value {
        let mut kinds = serde_json::Map::new();
        let mut missed_list = Vec::new();
        for (k, name) in KIND_NAMES.iter().enumerate() {
            let idx: Vec<usize> = (0..self.records.len())
                .filter(|&i| self.records[i].kind as usize == k)
                .collect();
            if idx.is_empty() {
                continue;
            }
            let det = idx.iter().filter(|&&i| self.is_detected(i)).count();
            let undelivered = idx.iter().filter(|&&i| !self.delivered[i]).count();
            let missed: Vec<usize> = idx
                .iter()
                .copied()
                .filter(|&i| {
                    !self.is_detected(i)
                        && self.delivered[i]
                        && (self.records[i].sigmas.is_nan() || self.records[i].sigmas > 5.0)
                })
                .collect();
            for &i in missed.iter().take(20) {
                let r = &self.records[i];
                missed_list.push(serde_json::json!({
                    "kind": name, "tick": r.tick, "field": r.field, "bit": r.bit,
                    "before": finite_or_null(r.before), "after": finite_or_null(r.after),
                    "sigmas": finite_or_null(r.sigmas),
                }));
            }
            kinds.insert(
                name.to_string(),
                serde_json::json!({
                    "injected": idx.len(),
                    "detected": det,
                    "missed": missed.len(),
                    "undetected_within_5_sigma": idx.iter().filter(|&&i| {
                        !self.is_detected(i) && self.delivered[i] && self.records[i].sigmas <= 5.0
                    }).count(),
                    "not_delivered": undelivered,
                }),
            );
        }
        serde_json::json!({ "by_kind": kinds, "missed": missed_list })
    }
}

fn finite_or_null(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::json!(v)
    } else {
        serde_json::Value::Null
    }
}
