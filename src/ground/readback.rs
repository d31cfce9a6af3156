//! Housekeeping reports read back into what they were made from, for ground tools that
//! reuse the set's own views (`monitor --ground`): structure 1 into the estimator's
//! `EstimateMsg` (the fields it carries; the rest stay at their defaults) and the set's
//! mode, structure 2 into `Health`. Each walks its structure's field table, so a field
//! added there without a place here is caught by the tests below.

use super::dictionary::read_bits;
use super::health::{Health, HEALTH, HEALTH_LEN, STRUCTURE_HEALTH};
use super::housekeeping::{decode_estimate, ESTIMATE_LEN, STRUCTURE_ESTIMATE};
use crate::sim::msg::EstimateMsg;

fn axis(a: &mut [[f64; 3]; 2], i: usize, bits: u64) {
    if let Some(x) = a.get_mut(i / 3).and_then(|r| r.get_mut(i % 3)) {
        *x = f64::from_bits(bits);
    }
}

/// Structure 1's source data (ID included) as an estimate and the set's mode (as its
/// number); None when the data are not structure 1.
pub fn estimate(data: &[u8]) -> Option<(EstimateMsg, u8)> {
    if data.len() != ESTIMATE_LEN {
        return None;
    }
    let mut e = EstimateMsg::default();
    let mut mode = 0u8;
    decode_estimate(data, |f, i, bits| match f.name {
        "beta" => axis(&mut e.beta, i, bits),
        "beta_sigma" => axis(&mut e.beta_sigma, i, bits),
        "k" => axis(&mut e.k, i, bits),
        "k_sigma" => axis(&mut e.k_sigma, i, bits),
        "r" => axis(&mut e.r_b, i, bits),
        "r_sigma" => axis(&mut e.r_sigma, i, bits),
        "status" => e.status = bits,
        "chi2_per_dof" => {
            if let Some(x) = e.chi2_per_dof.get_mut(i) {
                *x = f64::from_bits(bits);
            }
        }
        "samples_used" => e.n_used = bits,
        "samples_rejected" => e.n_rejected = bits,
        "tick" => e.header.tick = bits,
        "solved_tick" => e.solved_tick = bits,
        "flags" => e.flags = bits,
        "mode" => mode = bits as u8,
        _ => {}
    })
    .ok()?;
    Some((e, mode))
}

fn put<T: Copy>(a: &mut [T], i: usize, v: T) {
    if let Some(x) = a.get_mut(i) {
        *x = v;
    }
}

/// Structure 2's source data (ID included) as the set's health; None when the data
/// are not structure 2.
pub fn health(data: &[u8]) -> Option<Health> {
    if data.len() != HEALTH_LEN || data[..2] != STRUCTURE_HEALTH.to_be_bytes() {
        return None;
    }
    let mut h = Health::default();
    let mut at = 2;
    for f in HEALTH {
        for i in 0..f.elements.count() {
            let bits = read_bits(f.kind, data.get(at..)?);
            at += f.kind.size();
            let x = f64::from_bits(bits);
            match f.name {
                "mode" => h.mode = bits as u8,
                "campaign" => h.campaign = bits as u32,
                "campaign_tick" => h.campaign_tick = bits,
                "n_samples" => h.n_samples = bits,
                "tmtc_restarts" => h.tmtc_restarts = bits as u32,
                "stage_restarts" => h.stage_restarts = bits as u32,
                "restarts" => put(&mut h.restarts, i, bits as u32),
                "heartbeat_age_ms" => put(&mut h.heartbeat_age_ms, i, x),
                "samples_lost" => put(&mut h.samples_lost, i, bits),
                "e2e_latency_us" => put(&mut h.e2e_latency_us, i, x),
                "tc_accepted" => h.tc_accepted = bits as u32,
                "tc_refused" => put(&mut h.tc_refused, i, bits as u32),
                "datagrams" => h.datagrams = bits,
                "tm_sent" => h.tm_sent = bits,
                "tm_send_errors" => h.tm_send_errors = bits as u32,
                _ => {}
            }
        }
    }
    Some(h)
}

/// Is this 3,25 source data of structure 1?
pub fn is_estimate(data: &[u8]) -> bool {
    data.get(..2) == Some(&STRUCTURE_ESTIMATE.to_be_bytes()[..])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::{Mode, N_FAILURES};
    use crate::ground::health::encode_health;
    use crate::ground::housekeeping::{encode_estimate, Source, ESTIMATE};

    #[test]
    fn structure_1_reads_back_into_every_field_it_was_made_from() {
        let mut e = EstimateMsg::default();
        let mut v = 0.5f64;
        for a in [
            &mut e.beta,
            &mut e.beta_sigma,
            &mut e.k,
            &mut e.k_sigma,
            &mut e.r_b,
            &mut e.r_sigma,
        ] {
            for x in a.iter_mut().flatten() {
                v *= -1.37;
                *x = v;
            }
        }
        e.chi2_per_dof = [1.0, 2.0, 3.0, f64::NAN];
        (
            e.status,
            e.n_used,
            e.n_rejected,
            e.header.tick,
            e.solved_tick,
            e.flags,
        ) = (5, 6, 7, 8, 9, 1);
        let src = Source {
            estimate: &e,
            mode: Mode::ShuttingDown,
        };
        let mut d = [0u8; ESTIMATE_LEN];
        encode_estimate(&src, &mut d).unwrap();
        assert!(is_estimate(&d));
        let (back, mode) = estimate(&d).unwrap();
        assert_eq!(mode, Mode::ShuttingDown as u8);
        let again = Source {
            estimate: &back,
            mode: Mode::ShuttingDown,
        };
        for f in ESTIMATE {
            for i in 0..f.elements.count() {
                assert_eq!((f.read)(&again, i), (f.read)(&src, i), "{}", f.name);
            }
        }
        assert!(estimate(&d[..10]).is_none());
        assert!(health(&d).is_none());
    }

    #[test]
    fn structure_2_reads_back_into_every_field_it_was_made_from() {
        let mut h = Health {
            mode: 1,
            campaign: 2,
            campaign_tick: 3,
            n_samples: 4,
            tmtc_restarts: 5,
            stage_restarts: 6,
            tc_accepted: 7,
            datagrams: 8,
            tm_sent: 9,
            tm_send_errors: 10,
            ..Health::default()
        };
        h.restarts = [1, 2, 3, 4, 5];
        h.heartbeat_age_ms = [1.5, 2.5, f64::NAN, 4.5, 5.5];
        h.samples_lost = [6, 7, 8, 9, 10];
        h.e2e_latency_us = [11.0, 12.0, 13.0];
        for (i, r) in h.tc_refused.iter_mut().enumerate() {
            *r = 100 + i as u32;
        }
        let mut d = [0u8; HEALTH_LEN];
        encode_health(&h, &mut d).unwrap();
        let back = health(&d).unwrap();
        for f in HEALTH {
            for i in 0..f.elements.count() {
                assert_eq!((f.read)(&back, i), (f.read)(&h, i), "{}", f.name);
            }
        }
        assert_eq!(back.tc_refused[N_FAILURES - 1], 100 + N_FAILURES as u32 - 1);
        assert!(health(&d[..d.len() - 1]).is_none());
        assert!(estimate(&d).is_none() && !is_estimate(&d));
    }
}
