//! Random streams. Every random draw in rfslam comes from an explicit [`Rng`] seeded from
//! a documented seed derivation, never from a thread-local generator.

use rand::SeedableRng;

/// The one random generator type of rfslam.
pub type Rng = rand_xoshiro::Xoshiro256PlusPlus;

/// SplitMix64 finaliser: a bijective 64-bit mixer.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Derives a seed from a sequence of parts (seed, run, purpose...), order-sensitive.
pub fn derive_seed(parts: &[u64]) -> u64 {
    parts.iter().fold(0x9e37_79b9_7f4a_7c15u64, |h, &p| mix(h ^ mix(p.wrapping_add(0x632b_e59b_d9b4_e019))))
}

/// A stable 64-bit hash of a label (FNV-1a), for use as a seed part.
pub fn label_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// An independent stream for `parts`.
pub fn stream(parts: &[u64]) -> Rng {
    Rng::seed_from_u64(derive_seed(parts))
}

/// Purposes of the streams derived from a run seed.
pub mod purpose {
    /// The data of a run (odometry noise, detections, clutter, measurement noise).
    pub const SCENARIO: u64 = 1;
    /// A filter's own draws (proposal sampling, resampling).
    pub const FILTER: u64 = 2;
    /// The procedural world (landmarks, route), fixed by the scenario's world seed.
    pub const WORLD: u64 = 3;
}
