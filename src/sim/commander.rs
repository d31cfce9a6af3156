//! Maneuver commander: publishes the square-wave torques of the maneuver's timeline
//! (`maneuver::Timeline`: sequential or simultaneous axes, whole periods, pauses).
//!
//! With the cosine phase (+A for T/4, −A for T/2, +A for T/4) rate and angle return
//! to zero at the end of every period and the attitude stays within ±A T²/(16 I).

use crate::sim::msg::{Header, TorqueCommand};
use crate::sim::scenario::maneuver::Timeline;
use crate::sim::scenario::Scenario;

#[derive(Debug, Clone)]
pub struct Commander {
    timeline: Timeline,
    seq: u64,
}

impl Commander {
    /// The commander of a validated scenario (whose maneuver fits its window; one
    /// that does not commands no torque).
    pub fn new(s: &Scenario) -> Self {
        let timeline = Timeline::new(s).unwrap_or_else(|_| Timeline::quiet(s.sample_rate_hz));
        Commander { timeline, seq: 0 }
    }

    /// Commanded body torque [N m] for the interval starting at `tick`.
    pub fn torque(&self, tick: u64) -> [f64; 3] {
        self.timeline.torque(tick)
    }

    /// The stage step: the command message for `tick`.
    pub fn step(&mut self, tick: u64) -> TorqueCommand {
        let m = TorqueCommand {
            header: Header::at(self.seq, tick, self.timeline.fs),
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
        let per_axis = (3.0 * s.sample_rate_hz / s.maneuver.frequency_hz) as u64;
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
