//! Shards of a job array and the FNV-1a hash they (and the change checks) use.

use std::str::FromStr;

/// FNV-1a, 64 bits (Fowler, Noll, Vo; offset basis 0xcbf29ce484222325, prime
/// 0x100000001b3): h ← (h ⊕ byte) · prime for every byte. Stable across platforms and
/// Rust versions (std's `DefaultHasher` is not), which is all the shard assignment and
/// the change checks need; it is not meant to resist deliberate collisions.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// A hash as the 16 hex digits stored in the per-table JSON.
pub fn hex(h: u64) -> String {
    format!("{h:016x}")
}

/// A shard `I/N`, 1-based: the tables whose file name hashes to `I` among `N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// I, in 1..=N.
    pub index: u64,
    /// N ≥ 1.
    pub count: u64,
}

/// A shard that is not `I/N` with 1 ≤ I ≤ N.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{given}`: {why}")]
pub struct ShardError {
    /// What was given.
    pub given: String,
    /// What is wrong with it.
    pub why: &'static str,
}

impl FromStr for Shard {
    type Err = ShardError;

    /// Parses `I/N` with 1 ≤ I ≤ N.
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let bad = |why| ShardError {
            given: s.to_string(),
            why,
        };
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, e.g. 3/8 (shard 3 of 8, counted from 1)"))?;
        let i: u64 = i.trim().parse().map_err(|_| bad("I is not a number"))?;
        let n: u64 = n.trim().parse().map_err(|_| bad("N is not a number"))?;
        if n == 0 {
            return Err(bad("N must be at least 1"));
        }
        if i == 0 || i > n {
            return Err(bad("I must lie in 1..=N (shards are counted from 1)"));
        }
        Ok(Shard { index: i, count: n })
    }
}

impl Shard {
    /// The shard (1-based) a table of this file name belongs to among `count`.
    pub fn of(name: &str, count: u64) -> u64 {
        fnv1a64(name.as_bytes()) % count + 1
    }

    /// Whether the table of this file name belongs to this shard.
    pub fn contains(&self, name: &str) -> bool {
        Shard::of(name, self.count) == self.index
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a64_matches_the_reference_vectors() {
        // From the FNV reference test suite (Noll): "", "a", "foobar".
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
        assert_eq!(hex(0xab), "00000000000000ab");
    }

    #[test]
    fn shards_parse_and_partition() {
        assert_eq!(
            "2/3".parse::<Shard>().unwrap(),
            Shard { index: 2, count: 3 }
        );
        for bad in ["0/3", "4/3", "1/0", "a/2", "3", "1/2/3", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        // Every name lands in exactly one shard, and the spread is binomial.
        let names: Vec<String> = (0..1000).map(|i| format!("material-{i}.binary")).collect();
        let mut counts = [0usize; 4];
        for n in &names {
            let s = Shard::of(n, 4);
            assert!((1..=4).contains(&s));
            counts[(s - 1) as usize] += 1;
            let hits = (1..=4)
                .filter(|&i| Shard { index: i, count: 4 }.contains(n))
                .count();
            assert_eq!(hits, 1);
        }
        // 250 ± 3σ (σ = √(1000·¼·¾) ≈ 13.7).
        assert!(
            counts.iter().all(|&c| (209..=291).contains(&c)),
            "{counts:?}"
        );
    }
}
