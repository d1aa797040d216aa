//! Bad input: every failure is a typed error naming the file. Files are made in a
//! temporary directory: copies of a real proxy with one part replaced.

mod common;

use brdfkit_nbrdf::{Nbrdf, NbrdfError, NpyError, PARTS};
use npyz::{AutoSerialize, Order, WriteOptions, WriterBuilder};
use std::path::{Path, PathBuf};

/// The six files of gold-paint copied as `<dir>/m_*.npy`; returns `<dir>/m`.
fn copy_of_gold_paint(dir: &Path) -> PathBuf {
    let src = Nbrdf::files(&common::material("merl", "gold-paint")).unwrap();
    let dst = Nbrdf::files(&dir.join("m")).unwrap();
    for (s, d) in src.iter().zip(&dst) {
        std::fs::copy(s, d).unwrap();
    }
    dir.join("m")
}

/// Path of part `part` of the material at `stem`.
fn part(stem: &Path, part: &str) -> PathBuf {
    let i = PARTS.iter().position(|p| *p == part).unwrap();
    Nbrdf::files(stem).unwrap()[i].clone()
}

fn write<T: AutoSerialize + Copy>(path: &Path, shape: &[u64], data: &[T], order: Order) {
    let mut buf = Vec::new();
    let mut w = WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .order(order)
        .writer(&mut buf)
        .begin_nd()
        .unwrap();
    w.extend(data.iter().copied()).unwrap();
    w.finish().unwrap();
    std::fs::write(path, buf).unwrap();
}

/// The error of loading `stem`, checking that its message starts with `file`.
fn load_err(stem: &Path, file: &Path) -> NbrdfError {
    let e = Nbrdf::load(stem).expect_err("load must fail");
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!("{}: ", file.display())),
        "message does not start with the file: {msg}"
    );
    e
}

#[test]
fn the_copy_loads() {
    let d = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d.path());
    let net = Nbrdf::load(&m).unwrap();
    assert_eq!(net.name(), "m");
    assert_eq!(net.widths(), (21, 21));
    // A path naming one of the six files is taken as their stem.
    assert_eq!(Nbrdf::load(&part(&m, "b2")).unwrap(), net);
}

#[test]
fn missing_file() {
    let d = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d.path());
    let f = part(&m, "fc2");
    std::fs::remove_file(&f).unwrap();
    let e = load_err(&m, &f);
    assert!(
        matches!(&e, NbrdfError::Missing { path } if *path == f),
        "{e:?}"
    );
    assert!(e.to_string().contains("missing"), "{e}");
    // The whole material missing: the first file is named.
    let e = load_err(&d.path().join("nothing"), &d.path().join("nothing_fc1.npy"));
    assert!(matches!(e, NbrdfError::Missing { .. }), "{e:?}");
}

#[test]
fn no_stem() {
    for p in ["", "/", "data/.."] {
        let e = Nbrdf::load(Path::new(p)).expect_err(p);
        assert!(matches!(e, NbrdfError::NoStem { .. }), "{p}: {e:?}");
    }
}

#[test]
fn wrong_shapes() {
    let d = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d.path());
    let cases: [(&str, &[u64], &str); 6] = [
        ("fc1", &[5, 21], "expected (6, n)"),
        ("fc1", &[6 * 21], "expected (6, n)"),
        ("b1", &[20], "expected (21,)"),
        ("fc2", &[20, 21], "expected (21, n)"),
        ("fc3", &[21, 4], "expected (21, 3)"),
        ("b3", &[3, 1], "expected (3,)"),
    ];
    for (p, shape, want) in cases {
        let f = part(&m, p);
        let saved = std::fs::read(&f).unwrap();
        let n: u64 = shape.iter().product();
        write(&f, shape, &vec![0.5f32; n as usize], Order::C);
        let e = load_err(&m, &f);
        assert!(matches!(e, NbrdfError::Shape { .. }), "{p}: {e:?}");
        assert!(e.to_string().contains(want), "{p}: {e}");
        std::fs::write(&f, saved).unwrap();
    }
    // fc2 with another output width is consistent only if b2 and fc3 follow it.
    let f = part(&m, "fc2");
    write(&f, &[21, 20], &[0.1f32; 21 * 20], Order::C);
    let e = load_err(&m, &part(&m, "b2"));
    assert!(e.to_string().contains("(21,), expected (20,)"), "{e}");
}

#[test]
fn wrong_dtypes() {
    let d = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d.path());
    let f = part(&m, "fc3");
    write(&f, &[21, 3], &[0.5f64; 63], Order::C);
    let e = load_err(&m, &f);
    assert!(
        matches!(&e, NbrdfError::Npy(NpyError::Dtype { found, .. }) if found == "'<f8'" || found == "<f8"),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("<f8") && e.to_string().contains("float32"),
        "{e}"
    );
    let f = part(&m, "b2");
    write(&f, &[21], &[1i32; 21], Order::C);
    let e = load_err(&m, &f);
    assert!(e.to_string().contains("<i4"), "{e}");
}

#[test]
fn non_finite_weights() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let d = tempfile::tempdir().unwrap();
        let m = copy_of_gold_paint(d.path());
        let f = part(&m, "fc2");
        let mut w = vec![0.25f32; 21 * 21];
        w[3 * 21 + 4] = bad;
        write(&f, &[21, 21], &w, Order::C);
        let e = load_err(&m, &f);
        assert!(
            matches!(&e, NbrdfError::NonFinite { index, .. } if index == &[3, 4]),
            "{e:?}"
        );
        assert!(e.to_string().contains("at [3, 4]"), "{e}");
        // A bias too.
        let f = part(&m, "b3");
        write(&f, &[3], &[0.0f32, 0.0, bad], Order::C);
        std::fs::copy(
            part(&common::material("merl", "gold-paint"), "fc2"),
            part(&m, "fc2"),
        )
        .unwrap();
        let e = load_err(&m, &f);
        assert!(
            matches!(&e, NbrdfError::NonFinite { index, .. } if index == &[2]),
            "{e:?}"
        );
    }
}

#[test]
fn not_npy_and_truncated() {
    let d = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d.path());
    let f = part(&m, "b1");
    std::fs::write(&f, b"not a numpy file at all").unwrap();
    let e = load_err(&m, &f);
    assert!(
        matches!(e, NbrdfError::Npy(NpyError::Format { .. })),
        "{e:?}"
    );
    let d2 = tempfile::tempdir().unwrap();
    let m = copy_of_gold_paint(d2.path());
    // The header promises 21 x 21 floats; half the data is there.
    let f = part(&m, "fc2");
    let full = std::fs::read(&f).unwrap();
    std::fs::write(&f, &full[..full.len() - 21 * 21 * 2]).unwrap();
    let e = load_err(&m, &f);
    assert!(
        matches!(e, NbrdfError::Npy(NpyError::Format { .. })),
        "{e:?}"
    );
}

/// A small network of other widths (4 and 5 hidden units), Fortran-order kernels and
/// a (1, n) bias: accepted, and evaluated as the formula says (computed here
/// independently, in the textbook row-vector form).
#[test]
fn other_widths_and_layouts() {
    let d = tempfile::tempdir().unwrap();
    let stem = d.path().join("small");
    let (h1, h2) = (4usize, 5usize);
    let val = |k: usize, s: f32| (k as f32 * 0.37 + s).sin() * 0.5;
    let fc1: Vec<f32> = (0..6 * h1).map(|k| val(k, 0.1)).collect();
    let b1: Vec<f32> = (0..h1).map(|k| val(k, 0.2) * 0.1).collect();
    let fc2: Vec<f32> = (0..h1 * h2).map(|k| val(k, 0.3)).collect();
    let b2: Vec<f32> = (0..h2).map(|k| val(k, 0.4) * 0.1).collect();
    let fc3: Vec<f32> = (0..h2 * 3).map(|k| val(k, 0.5)).collect();
    let b3: Vec<f32> = vec![-0.1, 0.05, 0.2];
    let p = |n: &str| part(&stem, n);
    // Kernels in Fortran order: the data is the transpose's row-major order.
    let fortran = |m: &[f32], rows: usize, cols: usize| -> Vec<f32> {
        let mut t = vec![0.0; m.len()];
        for r in 0..rows {
            for c in 0..cols {
                t[c * rows + r] = m[r * cols + c];
            }
        }
        t
    };
    write(
        &p("fc1"),
        &[6, h1 as u64],
        &fortran(&fc1, 6, h1),
        Order::Fortran,
    );
    write(&p("b1"), &[1, h1 as u64], &b1, Order::C);
    write(&p("fc2"), &[h1 as u64, h2 as u64], &fc2, Order::C);
    write(&p("b2"), &[h2 as u64], &b2, Order::C);
    write(
        &p("fc3"),
        &[h2 as u64, 3],
        &fortran(&fc3, h2, 3),
        Order::Fortran,
    );
    write(&p("b3"), &[3], &b3, Order::C);
    let net = Nbrdf::load(&stem).unwrap();
    assert_eq!(net.widths(), (h1, h2));
    let layer = |x: &[f64], w: &[f32], b: &[f32], relu: bool| -> Vec<f64> {
        let n = b.len();
        (0..n)
            .map(|o| {
                let s: f64 = f64::from(b[o])
                    + x.iter()
                        .enumerate()
                        .map(|(i, xi)| xi * f64::from(w[i * n + o]))
                        .sum::<f64>();
                if relu { s.max(0.0) } else { s }
            })
            .collect()
    };
    for (th, td, pd) in [(0.1, 0.2, 0.3), (1.2, 0.4, 2.9), (0.0, 1.5, 0.0)] {
        let x = [
            f64::sin(th),
            0.0,
            f64::cos(th),
            f64::sin(td) * f64::cos(pd),
            f64::sin(td) * f64::sin(pd),
            f64::cos(td),
        ];
        let a1 = layer(&x, &fc1, &b1, true);
        let a2 = layer(&a1, &fc2, &b2, true);
        let y = layer(&a2, &fc3, &b3, false);
        let v = net.raw(th, td, pd);
        for (c, yc) in y.iter().enumerate() {
            let want = yc.exp() - 1.0;
            assert!(
                (v.0[c] - want).abs() <= 1e-14 * (1.0 + want.abs()),
                "{c}: {} vs {want}",
                v.0[c]
            );
        }
    }
}

#[test]
fn embedded_bytes_give_the_same_network_as_the_files() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured/merl");
    let read = |p: &str| std::fs::read(dir.join(format!("pink-fabric_{p}.npy"))).unwrap();
    let parts = brdfkit_nbrdf::PARTS.map(read);
    let from_bytes =
        brdfkit_nbrdf::Nbrdf::from_npy_bytes("pink-fabric", parts.each_ref().map(|v| &v[..]))
            .unwrap();
    let from_files = brdfkit_nbrdf::Nbrdf::load(&dir.join("pink-fabric")).unwrap();
    for t in [[0.1, 0.2, 0.3], [1.0, 0.5, 2.0], [0.01, 1.4, 0.0]] {
        assert_eq!(
            from_bytes.raw(t[0], t[1], t[2]),
            from_files.raw(t[0], t[1], t[2])
        );
    }
    assert_eq!(from_bytes.name(), "pink-fabric");
    // A damaged embedded part is named as such.
    let mut bad = parts.clone();
    bad[2].truncate(20);
    let e = brdfkit_nbrdf::Nbrdf::from_npy_bytes("pink-fabric", bad.each_ref().map(|v| &v[..]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("(embedded) pink-fabric_fc2.npy"), "{e}");
}
