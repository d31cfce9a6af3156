//! Maneuver commander: square-wave torques, one axis after the other.
//!
//! Each axis is rocked for a whole number of periods with a cosine-phased square wave
//! (+A for T/4, −A for T/2, +A for T/4), so rate and angle return to zero at the end of
//! every period and the attitude stays within ±A T²/(16 I).

use crate::msg::{Header, TorqueCommand};
use crate::scenario::Scenario;

#[derive(Debug, Clone, Copy)]
pub struct Commander {
    fs: f64,
    ticks_per_period: f64,
    ticks_per_axis: u64,
    amplitude_nm: [f64; 3],
    order: [usize; 3],
    seq: u64,
}

impl Commander {
    pub fn new(s: &Scenario) -> Self {
        let ticks_per_period = s.sample_rate_hz / s.maneuver.frequency_hz;
        Commander {
            fs: s.sample_rate_hz,
            ticks_per_period,
            ticks_per_axis: (s.periods_per_axis() as f64 * ticks_per_period).round() as u64,
            amplitude_nm: s.maneuver.torque_amplitude_nm,
            order: s.axis_order(),
            seq: 0,
        }
    }

    /// Commanded body torque [N m] for the interval starting at `tick`.
    pub fn torque(&self, tick: u64) -> [f64; 3] {
        let mut out = [0.0; 3];
        let seg = tick / self.ticks_per_axis.max(1);
        if seg < 3 {
            let local = (tick - seg * self.ticks_per_axis) as f64;
            let phase = (local / self.ticks_per_period).fract();
            let axis = self.order[seg as usize];
            let sign = if (0.25..0.75).contains(&phase) {
                -1.0
            } else {
                1.0
            };
            out[axis] = sign * self.amplitude_nm[axis];
        }
        out
    }

    /// The stage step: the command message for `tick`.
    pub fn step(&mut self, tick: u64) -> TorqueCommand {
        let m = TorqueCommand {
            header: Header::at(self.seq, tick, self.fs),
            torque_cmd_b: self.torque(tick),
        };
        self.seq += 1;
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_axis_gets_whole_zero_mean_periods_in_turn() {
        let s = Scenario::default();
        let c = Commander::new(&s);
        let per_axis =
            (s.periods_per_axis() as f64 * s.sample_rate_hz / s.maneuver.frequency_hz) as u64;
        for (k, axis) in [0usize, 1, 2].into_iter().enumerate() {
            let sum: f64 = (k as u64 * per_axis..(k as u64 + 1) * per_axis)
                .map(|t| c.torque(t)[axis])
                .sum();
            assert!(sum.abs() < 1e-12, "axis {axis} torque mean not zero: {sum}");
            let others: f64 = (k as u64 * per_axis..(k as u64 + 1) * per_axis)
                .map(|t| {
                    (0..3)
                        .filter(|&a| a != axis)
                        .map(|a| c.torque(t)[a].abs())
                        .sum::<f64>()
                })
                .sum();
            assert_eq!(others, 0.0);
        }
        assert_eq!(c.torque(3 * per_axis), [0.0; 3]);
    }
}
