//! `fit-brdf view`: the page for a table, models and an NBRDF, overlaid; bad input is
//! exit 2 naming the file, with nothing written. (The page in a browser:
//! report_browser.rs.)

#[macro_use]
mod common;

use common::{bin, plastic_and_lambert, stderr, write_file};
use std::path::Path;

fn nbrdf() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured/merl/blue-rubber")
}

#[test]
fn view_writes_one_self_contained_page_with_every_source() {
    let d = tempfile::tempdir().unwrap();
    let (table, lam) = plastic_and_lambert(d.path());
    let out = d.path().join("v");
    fit_brdf_ok!(
        "view",
        &table,
        &lam,
        nbrdf(),
        "--title",
        "three sources",
        "--out",
        &out
    );
    assert_eq!(common::names(&out), ["index.html"]);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    common::assert_mentions(
        &html,
        &[
            "<title>three sources</title>",
            "id=\"view-data\"",
            "panel-incidence",
            "panel-slice",
            "panel-sphere",
            "panel-albedo",
            "\"kind\":\"table\"",
            "\"kind\":\"model\"",
            "\"kind\":\"nbrdf\"",
        ],
    );
    // Nothing fetched from anywhere: no external script, style or image.
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
    assert!(!html.contains("type=\"module\""));
    // Three sources of 45 × 45 × 90 cells, packed: well under a megabyte each.
    assert!(html.len() < 3_000_000, "{} bytes", html.len());
}

#[test]
fn bad_sources_are_exit_2_naming_the_file_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let (table, lam) = plastic_and_lambert(d.path());
    let aniso = write_file(
        d.path(),
        "aniso.json",
        r#"{"model": "ward", "params": {"rho_d": [0.1, 0.1, 0.1], "rho_s": [0.1, 0.1, 0.1], "alpha_x": 0.1, "alpha_y": 0.3}}"#,
    );
    let junk = write_file(d.path(), "junk.json", "{ not json");
    let missing = d.path().join("missing.binary");
    for (sources, expect) in [
        (vec![table.clone(), missing.clone()], "missing.binary"),
        (vec![table.clone(), junk.clone()], "junk.json"),
        (vec![table.clone(), aniso.clone()], "aniso.json"),
        (vec![d.path().join("nothing-here")], "nothing-here"),
        (vec![lam.clone(), lam.clone()], "given twice"),
    ] {
        let out = d.path().join("out");
        let o = bin()
            .arg("view")
            .args(&sources)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{sources:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{sources:?}: {}", stderr(&o));
        assert!(!out.exists(), "{sources:?}: output written");
    }
}
