//! The binary format: bit-exact round trips, every malformed-file class, atomic writes.

use brdfkit_merl::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// A file image built by hand (independent of the crate's writer).
fn image(dims: [i32; 3], raw: &[f64]) -> Vec<u8> {
    let mut out = Vec::with_capacity(12 + 8 * raw.len());
    for d in dims {
        out.extend_from_slice(&d.to_le_bytes());
    }
    for x in raw {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

/// Raw values of every kind a file can hold: log-uniform positives, zeros of both
/// signs, negatives (missing), subnormals and extremes.
fn random_raw(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| match rng.random_range(0..10) {
            0 => -1.0,
            1 => -rng.random::<f64>() * 100.0,
            2 => -0.0,
            3 => 0.0,
            4 => f64::from_bits(rng.random_range(1..(1u64 << 52))), // subnormal
            5 => brdfkit_merl::MAX_ABS_RAW * rng.random::<f64>(),   // up to the largest accepted
            _ => 10f64.powf(rng.random_range(-6.0..5.0)),
        })
        .collect()
}

fn write_file(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn read_write_round_trip_is_bit_exact_for_several_dims() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let dir = tempfile::tempdir().unwrap();
    for dims in [[90, 90, 180], [45, 45, 90], [3, 1, 2], [1, 1, 1], [4, 7, 5]] {
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let raw = random_raw(&mut rng, 3 * n);
        let bytes = image(dims, &raw);
        let src = write_file(dir.path(), "src.binary", &bytes);
        let t = MerlTable::read(&src).unwrap();
        assert_eq!(
            t.dims(),
            Dims::new(dims[0] as i64, dims[1] as i64, dims[2] as i64).unwrap()
        );
        let dst = dir.path().join("dst.binary");
        t.write(&dst).unwrap();
        assert_eq!(std::fs::read(&dst).unwrap(), bytes, "dims {dims:?}");
        assert_eq!(t.to_bytes(), bytes);
        assert_eq!(MerlTable::from_bytes(&bytes, "mem").unwrap(), t);
        // Values: raw × scale for valid cells; a cell with any negative channel is missing.
        for x in 0..n {
            let r = [raw[x], raw[n + x], raw[2 * n + x]];
            let valid = r.iter().all(|&v| v >= 0.0);
            assert_eq!(t.is_valid(x), valid);
            match t.get_flat(x) {
                Some(v) => {
                    for c in 0..3 {
                        assert_eq!(v[c].to_bits(), (r[c] * SCALES[c]).to_bits());
                    }
                }
                None => assert!(!valid),
            }
        }
        assert_eq!(
            t.valid_count(),
            t.valid_mask().iter().filter(|v| **v).count()
        );
    }
}

#[test]
fn negative_zero_is_a_valid_zero_and_is_kept() {
    let raw = [-0.0, 0.0, -0.0];
    let bytes = image([1, 1, 1], &raw);
    let t = MerlTable::from_bytes(&bytes, "z").unwrap();
    assert!(t.is_valid(0));
    assert_eq!(t.get_flat(0).unwrap()[1], 0.0);
    assert_eq!(t.to_bytes(), bytes);
}

#[test]
fn in_memory_tables_write_value_over_scale_and_missing_as_minus_one() {
    let d = Dims::new(2, 2, 2).unwrap();
    let t = MerlTable::from_fn(d, |i, j, k| {
        (i + j + k != 3).then(|| brdfkit_core::Rgb::new(0.5, 0.25 * i as f64, 7.0))
    })
    .unwrap();
    let back = MerlTable::from_bytes(&t.to_bytes(), "mem").unwrap();
    let n = d.cells();
    for x in 0..n {
        let (i, j, k) = d.unflatten(x);
        let raw = back.raw_at(x);
        if i + j + k == 3 {
            assert_eq!(raw, [-1.0; 3]);
            assert_eq!(back.get_flat(x), None);
        } else {
            assert_eq!(raw[0], 0.5 / SCALES[0]);
            assert_eq!(raw[1], 0.25 * i as f64 / SCALES[1]);
            assert_eq!(raw[2], 7.0 / SCALES[2]);
        }
    }
    assert_eq!(back, t);
}

fn assert_names(err: &MerlError, name: &str) {
    let msg = err.to_string();
    assert!(msg.contains(name), "message does not name {name}: {msg}");
    assert!(err.path().to_string_lossy().contains(name));
}

/// The dims error of reading `p`, after checking that the error names the file `name`.
fn read_dims_error(p: &Path, name: &str) -> DimsError {
    let e = MerlTable::read(p).unwrap_err();
    assert_names(&e, name);
    match e {
        MerlError::Dims { source, .. } => source,
        e => panic!("expected a dims error, got {e}"),
    }
}

/// The error of reading `bytes` written as the file `name`, after checking that it
/// names the file.
fn read_error(name: &str, bytes: &[u8]) -> MerlError {
    let dir = tempfile::tempdir().unwrap();
    let e = MerlTable::read(write_file(dir.path(), name, bytes)).unwrap_err();
    assert_names(&e, name);
    e
}

/// The (expected, actual) byte counts of a body-size error: [`MerlError::Truncated`]
/// when `short`, else [`MerlError::TrailingBytes`].
fn size_error(e: &MerlError, short: bool) -> (u64, u64) {
    match (e, short) {
        (MerlError::Truncated { size, .. }, true)
        | (MerlError::TrailingBytes { size, .. }, false) => (size.expected, size.actual),
        _ => panic!("expected a body-size error (short: {short}), got {e}"),
    }
}

#[test]
fn too_short_for_the_header() {
    let dir = tempfile::tempdir().unwrap();
    for len in [0usize, 5, 11] {
        let p = write_file(dir.path(), "short.binary", &vec![1u8; len]);
        let e = MerlTable::read(&p).unwrap_err();
        assert!(
            matches!(e, MerlError::TooShort { len: l, .. } if l == len as u64),
            "{e}"
        );
        assert_names(&e, "short.binary");
    }
    let e = MerlTable::from_bytes(&[0u8; 3], "bytes-name").unwrap_err();
    assert!(matches!(e, MerlError::TooShort { .. }));
    assert_names(&e, "bytes-name");
}

#[test]
fn dims_not_positive() {
    let dir = tempfile::tempdir().unwrap();
    for dims in [[90, 0, 180], [-1, 90, 180], [90, 90, i32::MIN]] {
        let p = write_file(dir.path(), "dims.binary", &image(dims, &[0.0; 9]));
        let e = read_dims_error(&p, "dims.binary");
        assert!(matches!(e, DimsError::NotPositive(..)), "{e}");
        assert!(e.to_string().contains("positive"), "{e}");
    }
}

#[test]
fn a_file_that_is_not_a_table_says_so_before_judging_its_dims() {
    let dir = tempfile::tempdir().unwrap();
    // The case: a text file given as a table. Its first 12 bytes read as dims
    // beyond 2^24 (an overflow, before this check).
    let csv = b"wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n";
    let dims_of = |b: &[u8]| -> [i64; 3] {
        std::array::from_fn(|k| i32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap()) as i64)
    };
    let gz = [&[0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3][..], &[0xff; 30][..]].concat();
    let npy = [&b"\x93NUMPY\x01\x00v\x00{'descr'"[..], &[0u8; 40][..]].concat();
    let cases: [(&str, &[u8], &str); 4] = [
        ("pairs.csv", csv, "it starts with text (`wi_x,wi_y,wi`)"),
        (
            "notes.txt",
            "θh θd φd\n1 2 3\n".as_bytes(),
            "it starts with text",
        ),
        ("table.binary.gz", &gz, "gzip"),
        ("mlp_fc1.npy", &npy, "NumPy"),
    ];
    for (name, bytes, what) in cases {
        let p = write_file(dir.path(), name, bytes);
        for e in [
            MerlTable::read(&p).unwrap_err(),
            MerlTable::from_bytes(bytes, &p).unwrap_err(),
        ] {
            match &e {
                MerlError::NotMerl { dims, .. } => assert_eq!(*dims, dims_of(bytes), "{name}"),
                other => panic!("{name}: {other:?}"),
            }
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("{}: not a MERL table: ", p.display()))
                    && msg.contains(what)
                    && msg.contains("not plausible"),
                "{msg}"
            );
            assert!(!msg.contains("too large"), "{msg}");
        }
    }
    // The dims the CSV's bytes spell, which the reader used to report as "too large".
    assert_eq!(dims_of(csv), [0x785f_6977, 0x5f69_772c, 0x6977_2c79]);
}

#[test]
fn a_plausible_header_is_never_taken_for_text_or_another_format() {
    // Every dim in 1..=2^24 has a zero high byte: such a header is judged as a table
    // even when its first bytes spell a signature (dims 559903 = 1f 8b 08 00, gzip's).
    let dir = tempfile::tempdir().unwrap();
    for dims in [[559903, 1, 1], [0x0020_2020, 0x20, 0x20], [1 << 24, 1, 1]] {
        let p = write_file(dir.path(), "odd.binary", &image(dims, &[0.5; 3]));
        let e = MerlTable::read(&p).unwrap_err();
        assert!(matches!(e, MerlError::Truncated { .. }), "{dims:?}: {e}");
    }
    // One dim beyond 2^24 whose bytes are not text: the dims are judged as before.
    let p = write_file(
        dir.path(),
        "big.binary",
        &image([(1 << 24) + 1, 1, 1], &[0.5; 3]),
    );
    let e = MerlTable::read(&p).unwrap_err();
    assert!(matches!(e, MerlError::Truncated { .. }), "{e}");
}

#[test]
fn dims_whose_size_overflows() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(
        dir.path(),
        "huge.binary",
        &image([i32::MAX, i32::MAX, i32::MAX], &[0.0; 3]),
    );
    let e = read_dims_error(&p, "huge.binary");
    assert!(matches!(e, DimsError::Overflow(..)), "{e}");
}

#[test]
fn header_claiming_a_huge_table_is_refused_before_allocating() {
    // 2^20 x 2^10 x 2^5 cells = 824 GB of data claimed by a 36-byte file: the length
    // check against the metadata refuses it without trying to allocate.
    let e = read_error("liar.binary", &image([1 << 20, 1 << 10, 1 << 5], &[1.0; 3]));
    assert_eq!(size_error(&e, true), (12 + 24 * (1u64 << 35), 36));
}

#[test]
fn data_shorter_than_the_dims_require() {
    let mut bytes = image([2, 3, 4], &[1.0; 72]);
    bytes.truncate(bytes.len() - 5);
    let e = read_error("trunc.binary", &bytes);
    assert_eq!(size_error(&e, true), (588, 583));
    let msg = e.to_string();
    assert!(msg.contains("588") && msg.contains("583"), "{msg}");
}

#[test]
fn trailing_bytes() {
    let mut bytes = image([2, 3, 4], &[1.0; 72]);
    bytes.push(0);
    let e = read_error("trail.binary", &bytes);
    assert_eq!(size_error(&e, false), (588, 589));
    assert!(e.to_string().contains("1 trailing bytes"), "{e}");
    let e = MerlTable::from_bytes(&bytes, "trail-bytes").unwrap_err();
    assert!(matches!(e, MerlError::TrailingBytes { .. }));
}

#[test]
fn nan_and_infinite_values_name_channel_and_cell() {
    let dir = tempfile::tempdir().unwrap();
    let d = Dims::new(3, 4, 5).unwrap();
    let n = d.cells();
    for (channel, bad) in [
        (Channel::Red, f64::NAN),
        (Channel::Green, f64::INFINITY),
        (Channel::Blue, f64::NEG_INFINITY),
    ] {
        let mut raw = vec![1.0; 3 * n];
        let cell = d.index(2, 1, 3);
        raw[channel.index() * n + cell] = bad;
        // A later bad value must not be the one reported.
        raw[3 * n - 1] = f64::NAN;
        let p = write_file(dir.path(), "nan.binary", &image([3, 4, 5], &raw));
        let e = MerlTable::read(&p).unwrap_err();
        match &e {
            MerlError::NonFinite { bad, index, .. } => {
                let at = (bad.channel, bad.i, bad.j, bad.k, *index);
                assert_eq!(at, (channel, 2, 1, 3, cell));
            }
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains(&channel.to_string()), "{e}");
        assert_names(&e, "nan.binary");
    }
}

#[test]
fn values_beyond_1e30_are_corrupt_data_not_measurements() {
    let dir = tempfile::tempdir().unwrap();
    let d = Dims::new(3, 4, 5).unwrap();
    let n = d.cells();
    for bad in [1.0000001e30, -1e31, 1e300, f64::MAX] {
        let mut raw = vec![1.0; 3 * n];
        let cell = d.index(1, 2, 3);
        raw[2 * n + cell] = bad;
        let p = write_file(dir.path(), "huge.binary", &image([3, 4, 5], &raw));
        let e = MerlTable::read(&p).unwrap_err();
        match &e {
            MerlError::TooLarge { bad: b, index, .. } => {
                assert_eq!((b.channel, *index, b.value), (Channel::Blue, cell, bad));
            }
            other => panic!("{bad}: {other}"),
        }
        assert_names(&e, "huge.binary");
        assert!(e.to_string().contains("1e30"), "{e}");
        // The in-memory constructor refuses it too.
        assert!(matches!(
            MerlTable::from_raw(d, raw.clone()),
            Err(brdfkit_merl::TableError::TooLarge(_))
        ));
    }
    // 1e30 itself, and a missing marker, are fine.
    let mut raw = vec![1.0; 3 * n];
    raw[0] = 1e30;
    raw[1] = -1.0;
    assert!(MerlTable::from_bytes(&image([3, 4, 5], &raw), "edge").is_ok());
}

#[test]
fn non_finite_value_in_a_large_table_is_found_past_the_first_chunk() {
    let d = Dims::new(10, 90, 180).unwrap(); // 162,000 cells: several chunks per plane
    let n = d.cells();
    let mut raw = vec![2.0; 3 * n];
    let cell = d.index(9, 89, 170);
    raw[n + cell] = f64::NAN;
    let e = MerlTable::from_bytes(&image([10, 90, 180], &raw), "big").unwrap_err();
    assert!(
        matches!(
            e,
            MerlError::NonFinite {
                bad: BadValue {
                    channel: Channel::Green,
                    i: 9,
                    j: 89,
                    k: 170,
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
    // Several bad values in different parallel tasks: the first in file order (the red
    // plane comes first, whatever the cell) is reported, from a file too.
    raw[2 * n + 5] = f64::INFINITY;
    raw[d.index(7, 3, 1)] = f64::NEG_INFINITY;
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "big.binary", &image([10, 90, 180], &raw));
    let e = MerlTable::read(&p).unwrap_err();
    assert!(
        matches!(
            e,
            MerlError::NonFinite {
                bad: BadValue {
                    channel: Channel::Red,
                    i: 7,
                    j: 3,
                    k: 1,
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn io_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such.binary");
    let e = MerlTable::read(&missing).unwrap_err();
    assert!(
        matches!(
            e,
            MerlError::Io {
                action: "opening",
                ..
            }
        ),
        "{e}"
    );
    assert_names(&e, "no-such.binary");
    // A directory given as a table.
    let sub = dir.path().join("a-directory.binary");
    std::fs::create_dir(&sub).unwrap();
    let e = MerlTable::read(&sub).unwrap_err();
    assert!(matches!(e, MerlError::IsDirectory { .. }), "{e}");
    assert_names(&e, "a-directory.binary");
}

/// The atomic writer's temporary files left in `dir`.
fn temp_leftovers(dir: &Path) -> Vec<String> {
    brdfkit_core::atomic::leftovers(dir).unwrap()
}

fn small_table() -> MerlTable {
    MerlTable::from_fn(Dims::new(2, 2, 2).unwrap(), |i, _, _| {
        Some(brdfkit_core::Rgb::splat(i as f64))
    })
    .unwrap()
}

#[test]
fn write_into_a_nonexistent_directory_fails_typed() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nope").join("t.binary");
    let e = small_table().write(&p).unwrap_err();
    assert!(matches!(e, MerlError::Io { .. }), "{e}");
    assert_names(&e, "t.binary");
    assert!(!p.exists());
    assert!(temp_leftovers(dir.path()).is_empty());
}

#[test]
fn write_into_a_read_only_directory_fails_and_keeps_the_old_file() {
    // /proc refuses new files even to root.
    let e = small_table()
        .write("/proc/brdfkit-test.binary")
        .unwrap_err();
    assert!(matches!(e, MerlError::Io { .. }), "{e}");
    assert_names(&e, "brdfkit-test.binary");

    // A directory with mode 0555 holding an old file: refused to ordinary users
    // (root bypasses the mode bits, so there the probe write succeeds and only the
    // /proc case above applies).
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "old.binary", b"old contents");
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o555)).unwrap();
    let probe = dir.path().join("probe");
    let writable = std::fs::write(&probe, b"x").is_ok();
    if !writable {
        let e = small_table().write(&p).unwrap_err();
        assert!(matches!(e, MerlError::Io { .. }), "{e}");
        assert_names(&e, "old.binary");
        assert_eq!(std::fs::read(&p).unwrap(), b"old contents");
        assert!(temp_leftovers(dir.path()).is_empty());
    } else {
        eprintln!("running as root: mode 0555 does not stop writes; /proc case checked");
        std::fs::remove_file(&probe).unwrap();
    }
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn failed_rename_leaves_the_destination_and_no_temp_file() {
    // The destination is a non-empty directory: the temporary file is written, the
    // rename fails, the temporary file must be gone and the destination untouched.
    let dir = tempfile::tempdir().unwrap();
    let dest = dir.path().join("occupied.binary");
    std::fs::create_dir(&dest).unwrap();
    std::fs::write(dest.join("inside"), b"keep").unwrap();
    let e = small_table().write(&dest).unwrap_err();
    assert!(matches!(e, MerlError::Io { .. }), "{e}");
    assert_names(&e, "occupied.binary");
    assert_eq!(std::fs::read(dest.join("inside")).unwrap(), b"keep");
    assert!(
        temp_leftovers(dir.path()).is_empty(),
        "{:?}",
        temp_leftovers(dir.path())
    );
}

#[test]
fn write_replaces_an_old_file_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_file(dir.path(), "t.binary", b"old contents");
    let t = small_table();
    t.write(&p).unwrap();
    assert_eq!(MerlTable::read(&p).unwrap(), t);
    assert!(temp_leftovers(dir.path()).is_empty());
}

/// Sends `bytes` through a named pipe and reads the table from it.
fn read_through_fifo(bytes: Vec<u8>) -> Result<MerlTable, MerlError> {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.binary");
    let ok = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(ok.success());
    let f2 = fifo.clone();
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        let mut w = std::fs::OpenOptions::new().write(true).open(&f2).unwrap();
        // The reader may stop early (bad header): a broken pipe is fine.
        let _ = w.write_all(&bytes);
    });
    let r = MerlTable::read(&fifo);
    writer.join().unwrap();
    r
}

#[test]
fn streams_without_a_length_are_read_and_checked() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let raw = random_raw(&mut rng, 3 * 4 * 5 * 6);
    let bytes = image([4, 5, 6], &raw);
    let t = read_through_fifo(bytes.clone()).unwrap();
    assert_eq!(t.to_bytes(), bytes);
    let mut long = bytes.clone();
    long.extend_from_slice(&[0u8; 100]);
    let e = read_through_fifo(long).unwrap_err();
    assert!(e.to_string().contains("100 trailing bytes"), "{e}");
    assert_names(&e, "pipe.binary");
    let e = read_through_fifo(bytes[..bytes.len() - 8].to_vec()).unwrap_err();
    assert!(matches!(e, MerlError::Truncated { .. }), "{e}");
    let e = read_through_fifo(bytes[..7].to_vec()).unwrap_err();
    assert!(matches!(e, MerlError::TooShort { len: 7, .. }), "{e}");
    // A character device with nothing in it.
    let e = MerlTable::read("/dev/null").unwrap_err();
    assert!(matches!(e, MerlError::TooShort { len: 0, .. }), "{e}");
    assert_names(&e, "/dev/null");
}
