//! Reproducible random streams.
//!
//! Every random number in the workbench comes from a named portable generator
//! ([`rand_pcg::Pcg64`]) seeded from a master seed and a few stable integers (cell, trial, pixel…)
//! through a fixed mixing function, so a result never depends on thread count or scheduling.

use rand::SeedableRng;
use rand_pcg::Pcg64;

/// The generator used everywhere.
pub type WorkbenchRng = Pcg64;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
#[inline]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Mixes a master seed with a path of stable identifiers into one 64-bit seed.
pub fn mix(seed: u64, path: &[u64]) -> u64 {
    path.iter()
        .fold(splitmix64(seed), |h, &p| splitmix64(h ^ splitmix64(p)))
}

/// The generator for `(seed, path…)`.
pub fn stream(seed: u64, path: &[u64]) -> WorkbenchRng {
    WorkbenchRng::seed_from_u64(mix(seed, path))
}

/// A stable 64-bit identifier for a string (FNV-1a), for naming cells by label.
pub fn label_id(label: &str) -> u64 {
    super::hash::fnv1a(label.bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    /// Pins the generator's output for a fixed seed: a change of generator, of mixing or of
    /// the rand version that alters streams fails here rather than silently changing results.
    #[test]
    fn value_stability() {
        assert_eq!(mix(2023, &[1, 2]), mix(2023, &[1, 2]));
        assert_ne!(mix(2023, &[1, 2]), mix(2023, &[2, 1]));
        let mut r = stream(7, &[0]);
        let first: u64 = r.random();
        let mut again = stream(7, &[0]);
        assert_eq!(first, again.random::<u64>());
        assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
        // Literal values: a change of mixing, generator or rand version fails here.
        assert_eq!(mix(2023, &[1, 2]), 0x3b0a_ef8b_9074_66dc);
        assert_eq!(stream(7, &[0]).random::<u64>(), 0xbfbf_84b8_606e_eca2);
    }
}
