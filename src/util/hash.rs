//! FNV-1a, 64 bits (Fowler, Noll and Vo; offset basis 0xcbf29ce484222325, prime 0x100000001b3):
//! the one stable hash of the workbench. Plans, shards, hosts and labels are named by it, so it
//! must give the same value on every build and platform, which std's `DefaultHasher` does not
//! promise. It is an identifier, not a security measure.

const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
const PRIME: u64 = 0x0100_0000_01b3;

/// `h ← (h ⊕ b) · p` over `bytes`, from the offset basis.
pub fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes
        .into_iter()
        .fold(OFFSET_BASIS, |h, b| (h ^ u64::from(b)).wrapping_mul(PRIME))
}

/// [`fnv1a`] of `bytes` as 16 lower-case hex digits: how plan hashes are written in logs,
/// manifests and shard records.
pub fn fnv1a_hex(bytes: impl IntoIterator<Item = u8>) -> String {
    format!("{:016x}", fnv1a(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published FNV-1a 64 test vectors (the empty string, "a", "foobar").
    #[test]
    fn matches_the_published_test_vectors() {
        assert_eq!(fnv1a(*b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(*b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(*b"foobar"), 0x8594_4171_f739_67e8);
        assert_eq!(fnv1a_hex(*b"a"), "af63dc4c8601ec8c");
    }
}
