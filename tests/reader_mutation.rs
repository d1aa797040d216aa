//! Mutation testing of the table reader: 10,000 files derived from a valid one by
//! random edits (byte flips, header rewrites, truncation, extension, NaN/inf and huge
//! values spliced in). The reader must never panic, must reject every file whose length
//! disagrees with its header, and whatever it accepts must write back bit for bit.

use brdfkit::merl::{Dims, MerlTable};
use proptest::prelude::*;

fn valid_file(dims: Dims, seed: u64) -> Vec<u8> {
    let t = MerlTable::from_fn(dims, |i, j, k| {
        let x = ((i * 31 + j * 17 + k * 7) as u64 ^ seed) % 97;
        if x == 0 {
            None
        } else {
            Some(brdfkit::core::Rgb::splat(x as f64 / 97.0))
        }
    })
    .unwrap();
    t.to_bytes()
}

#[derive(Debug, Clone)]
enum Mutation {
    Flip { at: usize, xor: u8 },
    Header { which: usize, value: i32 },
    Truncate { keep: usize },
    Extend { extra: Vec<u8> },
    Splice { at: usize, value: f64 },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), 1u8..=255).prop_map(|(at, xor)| Mutation::Flip { at, xor }),
        2 => (0usize..3, prop_oneof![Just(0), Just(-1), Just(1), Just(i32::MAX), Just(i32::MIN), any::<i32>(), 1i32..64])
            .prop_map(|(which, value)| Mutation::Header { which, value }),
        1 => any::<usize>().prop_map(|keep| Mutation::Truncate { keep }),
        1 => proptest::collection::vec(any::<u8>(), 1..24).prop_map(|extra| Mutation::Extend { extra }),
        2 => (any::<usize>(), prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(1e300), Just(-0.0), Just(-1.0), any::<f64>()])
            .prop_map(|(at, value)| Mutation::Splice { at, value }),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    match m {
        Mutation::Flip { at, xor } => {
            if !bytes.is_empty() {
                let i = at % bytes.len();
                bytes[i] ^= xor;
            }
        }
        Mutation::Header { which, value } => {
            let o = 4 * which;
            if bytes.len() >= o + 4 {
                bytes[o..o + 4].copy_from_slice(&value.to_le_bytes());
            }
        }
        Mutation::Truncate { keep } => {
            let n = keep % (bytes.len() + 1);
            bytes.truncate(n);
        }
        Mutation::Extend { extra } => bytes.extend_from_slice(extra),
        Mutation::Splice { at, value } => {
            if bytes.len() >= 20 {
                let slots = (bytes.len() - 12) / 8;
                let o = 12 + 8 * (at % slots);
                bytes[o..o + 8].copy_from_slice(&value.to_le_bytes());
            }
        }
    }
}

fn header_len(bytes: &[u8]) -> Option<u128> {
    if bytes.len() < 12 {
        return None;
    }
    let d: Vec<i128> = (0..3)
        .map(|k| i32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap()) as i128)
        .collect();
    if d.iter().any(|&x| x <= 0) {
        return None;
    }
    Some(12 + 24 * (d[0] * d[1] * d[2]) as u128)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, ..ProptestConfig::default() })]
    #[test]
    fn mutated_files_never_panic_and_accepted_ones_round_trip(
        seed in any::<u64>(),
        dims in prop_oneof![Just((2i64, 3i64, 4i64)), Just((4, 4, 8)), Just((1, 1, 1))],
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let dims = Dims::new(dims.0, dims.1, dims.2).unwrap();
        let mut bytes = valid_file(dims, seed);
        for m in &muts {
            apply(&mut bytes, m);
        }
        match MerlTable::from_bytes(&bytes, "mutant.binary") {
            Ok(t) => {
                prop_assert_eq!(header_len(&bytes), Some(bytes.len() as u128), "accepted a file whose length disagrees with its header");
                prop_assert!(t.to_bytes() == bytes, "accepted file does not write back bit for bit");
                prop_assert!(t.raw().iter().all(|v| v.is_finite()), "accepted a non-finite value");
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.contains("mutant.binary"), "error does not name the file: {}", msg);
            }
        }
    }
}
