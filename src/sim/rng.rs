//! Seeded random streams: one independent stream per noise source, derived from the
//! scenario seed, so adding a source never shifts another's draws.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The noise sources of the simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub enum Stream {
    Priors = 1,
    ThrusterTorque = 2,
    ThrusterEdges = 3,
    ThrusterForce = 4,
    Srp = 5,
    StarTracker = 6,
    /// Injected faults (`[faults]`): their own stream, so clean noise is unchanged.
    Faults = 7,
    /// The truths' history (`[drift]`'s random walks), from the mission's seed: every
    /// campaign of one mission sees one history.
    Drift = 8,
    /// IS front-end electronics; IS i uses `InertialSensor as u64 + i`.
    InertialSensor = 16,
}

pub type Rng = ChaCha8Rng;

/// The random stream `s` (with sub-index `sub`) of scenario seed `seed`.
pub fn stream_n(seed: u64, s: Stream, sub: u64) -> Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(s as u64 + sub);
    r
}

pub fn stream(seed: u64, s: Stream) -> Rng {
    stream_n(seed, s, 0)
}

/// One standard normal draw.
pub fn gauss(rng: &mut Rng) -> f64 {
    use rand::Rng as _;
    rng.sample(rand_distr::StandardNormal)
}
