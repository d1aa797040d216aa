//! RGL-EPFL `.bsdf` files through the binary: recognised by their first bytes whatever
//! their name, `info`, `eval --bsdf` and `resample --bsdf` agree with the library, and a
//! broken file is exit 2 naming the file and the field.

#[macro_use]
mod common;

use brdfkit::core::Brdf;
use brdfkit::merl::{Dims, MerlTable, cell_directions};
use brdfkit::rgl::{RglBsdf, Tensor, TensorData, tensor};
use common::npy::npy_bytes;
use common::{assert_bad_input, assert_bad_input_writes_nothing, lambert_file, stderr, write_file};
use std::path::{Path, PathBuf};

#[path = "../../brdfkit-rgl/tests/common/felt.rs"]
mod felt;

/// The test felt with 22 of its 2048 `valid` bits set.
fn fields() -> Vec<Tensor> {
    let mut valid = vec![0u8; 8 * 16 * 16 / 8];
    valid[0] = 0xff;
    valid[9] = 0b1010_1010;
    valid[100] = 0xff;
    valid[255] = 0b0000_0011;
    let mut f = felt::fields();
    f.push(Tensor::new("valid", &[256], TensorData::U8(valid)));
    f
}

/// The file, under a name that says nothing of its kind.
fn file(dir: &Path) -> PathBuf {
    let p = dir.join("material.binary");
    tensor::write(&fields(), &p).unwrap();
    p
}

const PAIRS: [[f64; 6]; 4] = [
    [0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
    [0.6, 0.0, 0.8, -0.6, 0.0, 0.8],
    [0.8, 0.0, 0.6, 0.0, 0.8, 0.6],
    [0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
];

/// The library's values at `PAIRS`: `eval_flat`, the f32 batch path the CLI runs
/// (within 1e-4 of the f64 `Brdf::eval` and of Mitsuba: brdfkit-rgl's tests/batch.rs and
/// tests/mitsuba.rs).
fn library(p: &Path) -> Vec<f64> {
    let b = RglBsdf::read(p).unwrap();
    let mut out = vec![0.0; 3 * PAIRS.len()];
    b.eval_flat(&PAIRS.concat(), &mut out);
    out
}

#[test]
fn info_recognises_the_file_by_its_bytes_and_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let o = fit_brdf_ok!("info", &p);
    let text = String::from_utf8(o.stdout).unwrap();
    common::assert_mentions(
        &text,
        &[
            "test felt",
            "RGB, isotropic",
            "8 θi slices",
            "measured:       22 of 2048",
            "asymmetry:",
        ],
    );
    let o = fit_brdf!("info", &p, "--json");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let b = RglBsdf::read(&p).unwrap();
    let s = b.summary();
    assert_eq!(v["negative_values"], s.negative);
    assert!(s.negative > 0);
    assert_eq!(v["measured_points"], 22);
    let asym = b.asymmetry(200_000, 5.0, 1);
    assert_eq!(v["asymmetry"]["median"].as_f64().unwrap(), asym.median);
    assert!(asym.median > 0.0);
}

#[test]
fn eval_bsdf_gives_the_library_values_in_csv_and_npy() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let want = library(&p);
    assert_eq!(&want[9..], &[0.0; 3], "below the horizon");
    // .npy in and out.
    let body: Vec<u8> = PAIRS
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let dirs = write_file(dir.path(), "pairs.npy", npy_bytes("<f8", "(4, 6)", &body));
    let out = dir.path().join("v.npy");
    fit_brdf_ok!("eval", "--bsdf", &p, "--dirs", &dirs, "--out", &out);
    let b = std::fs::read(&out).unwrap();
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    let got: Vec<f64> = b[10 + hl..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(got, want);
    // CSV in and out.
    let mut csv = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n");
    for r in PAIRS {
        csv += &(r.map(|x| x.to_string()).join(",") + "\n");
    }
    std::fs::write(dir.path().join("pairs.csv"), csv).unwrap();
    let o = fit_brdf_ok!("eval", "--bsdf", &p, "--dirs", dir.path().join("pairs.csv"));
    let text = String::from_utf8(o.stdout).unwrap();
    let vals: Vec<f64> = text
        .lines()
        .skip(1)
        .flat_map(|l| {
            l.split(',')
                .map(|x| x.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .collect();
    for (a, b) in vals.iter().zip(&want) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
    }
}

#[test]
fn resample_bsdf_writes_the_two_order_mean_and_says_what_it_clamped() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let out = dir.path().join("t.binary");
    let o = fit_brdf_ok!(
        "resample", "--bsdf", &p, "--dims", "12,12,24", "--out", &out
    );
    let dims = Dims::new(12, 12, 24).unwrap();
    let (lib_table, stats) = RglBsdf::read(&p).unwrap().to_table(dims).unwrap();
    assert!(stats.clamped_values > 0);
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "{} negative channel values stored as 0",
            stats.clamped_values
        )),
        "{err}"
    );
    common::assert_mentions(&err, &["not reciprocal", "median"]);
    let t = MerlTable::read(&out).unwrap();
    assert_eq!(t.valid_count(), lib_table.valid_count());
    common::assert_mentions(&err, &["held by one order"]);
    // One cell by hand: the weighted mean of both orders (cos²/(cos² + c²) of the
    // direction each divides by), clamped at 0.
    let b = RglBsdf::read(&p).unwrap();
    let (_, wi, wo, _) = cell_directions(dims, 6, 5, 7);
    let w = |x: f64| x * x / (x * x + brdfkit::rgl::ORDER_ERROR_COS.powi(2));
    let (wa, wb) = (w(wo.z), w(wi.z));
    let m = b.eval(&wi, &wo).zip(b.eval(&wo, &wi), |x, y| {
        ((wa * x + wb * y) / (wa + wb)).max(0.0)
    });
    let cell = t.get(6, 5, 7).unwrap();
    // The f64 path by hand; `resample` runs the f32 batch path: the bound.
    for c in 0..3 {
        assert!(
            (cell.0[c] - m.0[c]).abs() <= 1e-4 * m.0[c].abs() + 1e-6,
            "{cell:?} vs {m:?}"
        );
    }
}

#[test]
fn table_verbs_take_a_bsdf_through_the_same_rule() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let o = fit_brdf!("check", &p);
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        stderr(&o)
    );
    common::assert_mentions(&stderr(&o), &["resampled to a 90x90x180 MERL table"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("table checks"));
}

#[test]
fn a_broken_bsdf_is_exit_2_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(file(dir.path())).unwrap();
    let cut = write_file(dir.path(), "cut.bsdf", &good[..good.len() - 100]);
    let o = fit_brdf!("info", &cut);
    assert_bad_input(&o, &["cut.bsdf", "`valid`", "past the end"]);
    let o = fit_brdf!(
        "resample",
        "--bsdf",
        &cut,
        "--dims",
        "4,4,8",
        "--out",
        dir.path().join("x.binary")
    );
    assert_bad_input_writes_nothing(&o, &["cut.bsdf", "`valid`"], &dir.path().join("x.binary"));
    let mut f = fields();
    f.retain(|t| t.name != "ndf");
    let missing = dir.path().join("missing.bsdf");
    tensor::write(&f, &missing).unwrap();
    let o = fit_brdf!("eval", "--bsdf", &missing, "--dirs", &missing);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = fit_brdf!("fit", &missing);
    assert_bad_input(&o, &["missing.bsdf", "`ndf` is missing"]);
}

/// `compare` takes a `.bsdf` by its bytes (this one is named `.binary`) on either side:
/// against its own resampling it is the same cells (losses 0), and against a model it
/// is tabulated on the model's grid.
#[test]
fn compare_takes_a_bsdf_by_its_bytes_against_a_table_and_a_model() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let table = dir.path().join("resampled.binary");
    fit_brdf_ok!(
        "resample", "--bsdf", &p, "--dims", "12,12,24", "-q", "--out", &table
    );
    let o = fit_brdf_ok!("compare", &table, &p, "--json");
    let c: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(c["b"]["kind"], "rgl-bsdf", "{c}");
    assert_eq!(c["losses"]["l2"]["overall"].as_f64(), Some(0.0), "{c}");
    assert_eq!(c["largest"][0]["relative"].as_f64(), Some(0.0), "{c}");
    assert!(
        c["b_on_grid"].as_str().unwrap().contains("both orders"),
        "{c}"
    );
    let lam = lambert_file(dir.path(), "lam.json", "[0.4, 0.3, 0.2]");
    let o = fit_brdf_ok!("compare", &p, &lam, "--dims", "12,12,24");
    let text = String::from_utf8_lossy(&o.stdout);
    common::assert_mentions(&text, &["(RGL-EPFL .bsdf)"]);
    // A broken one is exit 2 naming the file and the field.
    let good = std::fs::read(&p).unwrap();
    let cut = dir.path().join("cut.json"); // the name says model; the bytes decide
    std::fs::write(&cut, &good[..good.len() - 100]).unwrap();
    let o = fit_brdf!("compare", &table, &cut);
    assert_bad_input(&o, &["cut.json", "`valid`"]);
}

#[test]
fn view_shows_a_bsdf_beside_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(dir.path());
    let (table, _) = common::plastic_and_lambert(dir.path());
    let out = dir.path().join("v");
    fit_brdf_ok!("view", &p, &table, "--out", &out);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("\"kind\":\"rgl-bsdf\""));
    assert!(html.contains("\"kind\":\"table\""));
}

/// A scene's `table` that is a `.bsdf` renders it as it is; `lookup` (a MERL table's
/// option) is refused naming the key, and a broken file names the file and the field.
#[test]
fn render_takes_a_bsdf_scene_material() {
    let dir = tempfile::tempdir().unwrap();
    file(dir.path());
    let scene = |extra: &str| {
        format!(
            "effects = [\"direct\"]\n[film]\nwidth = 16\nheight = 12\nfilter = \"center\"\n\
             [camera]\nposition = [0.0, 0.6, 4.5]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = 35.0\n\
             [sphere]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
             [material]\ntable = \"material.binary\"\n{extra}\
             [[light]]\ntype = \"point\"\nposition = [3.0, 3.0, 3.0]\nintensity = [30.0, 30.0, 30.0]\n"
        )
    };
    let s = write_file(dir.path(), "s.toml", scene(""));
    let png = dir.path().join("s.png");
    fit_brdf_ok!("render", &s, "--out", &png, "--json");
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
    std::fs::write(&s, scene("lookup = \"nearest\"\n")).unwrap();
    let o = fit_brdf!("render", &s, "--out", &png);
    assert_bad_input(&o, &["s.toml", "material.lookup", ".bsdf"]);
    let good = std::fs::read(dir.path().join("material.binary")).unwrap();
    std::fs::write(
        dir.path().join("material.binary"),
        &good[..good.len() - 100],
    )
    .unwrap();
    std::fs::write(&s, scene("")).unwrap();
    let o = fit_brdf!("render", &s, "--out", &png);
    assert_bad_input(
        &o,
        &["s.toml", "material.table", "material.binary", "`valid`"],
    );
}
