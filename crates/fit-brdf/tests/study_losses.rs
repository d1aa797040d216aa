//! `fit-brdf study --parts losses` end to end on two vendored proxies, a coarse grid,
//! one start and small renders: every output is written, and bad options are exit 2
//! with nothing written.

mod common;

use common::{assert_bad_input, bin, stderr};
use std::path::{Path, PathBuf};

fn data_measured() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured")
}

fn args(doc: &Path) -> Vec<String> {
    let root = data_measured();
    [
        "study",
        "--parts",
        "losses",
        "--proxies",
        root.to_str().unwrap(),
        "--categories",
        root.join("categories.csv").to_str().unwrap(),
        "--loss-materials",
        "blue-rubber,bindercover",
        "--loss-dims",
        "16,16,32",
        "--loss-render",
        "24,2",
        "--loss-starts",
        "1",
        "--losses-doc",
        doc.to_str().unwrap(),
        "--quiet",
    ]
    .map(String::from)
    .to_vec()
}

#[test]
fn the_losses_part_writes_its_page_scores_and_sheet() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("losses.md");
    let o = bin().args(args(&doc)).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("losses");
    let csv = std::fs::read_to_string(out.join("scores.csv")).unwrap();
    // 2 materials × 4 losses × 2 lightings, one model.
    assert_eq!(csv.lines().count(), 1 + 16, "{csv}");
    // Columns by name (the header is sorted).
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let row = rows
        .iter()
        .find(|r| {
            r[col("material")] == "bindercover"
                && r[col("loss")] == "log"
                && r[col("lighting")] == "environment"
        })
        .expect("bindercover, log, environment");
    assert_eq!(row[col("category")], "plastic");
    let de: f64 = row[col("delta_e_mean")].parse().unwrap();
    assert!(de.is_finite() && de >= 0.0, "{de}");
    assert!(image::open(out.join("sheet.png")).is_ok());
    let page = std::fs::read_to_string(&doc).unwrap();
    common::assert_mentions(&page, &["2 proxies (1 merl, 1 nielsen)"]);
    common::assert_mentions(&page, &["| blue-rubber | merl | other | point |"]);
}

#[test]
fn bad_losses_options_are_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("losses.md");
    for (flag, bad, needle) in [
        ("--loss-materials", "no-such-proxy", "`no-such-proxy`"),
        ("--loss-render", "0,16", "--loss-render"),
        ("--loss-render", "128", "--loss-render"),
        ("--loss-dims", "16,16", "--dims"),
        ("--loss-starts", "0", "--loss-starts"),
    ] {
        let mut a = args(&doc);
        let i = a.iter().position(|x| x == flag).unwrap();
        a[i + 1] = bad.into();
        let o = bin().args(&a).output().unwrap();
        assert_bad_input(&o, &[needle]);
        assert!(
            !doc.exists() && !dir.path().join("losses").exists(),
            "{flag} {bad}"
        );
    }
}
