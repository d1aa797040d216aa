//! Progress on stderr, drawn in one place (`src/progress.rs`) from the library's events:
//! `--quiet` silences it, and without it the lines come in the order of the work.

#[macro_use]
mod common;

use common::{stderr, synth_spec};

/// A small red plastic and the quick report settings of `tests/report.rs`.
fn report_args(t: &std::path::Path, out: &std::path::Path) -> Vec<String> {
    let mut a: Vec<String> = ["report", &t.display().to_string()]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.extend(
        [
            "--models",
            "lambert",
            "--starts",
            "1",
            "--render-size",
            "16",
        ]
        .into_iter()
        .chain(["--env-spp", "2", "--out", &out.display().to_string()])
        .map(String::from),
    );
    a
}

#[test]
fn quiet_verbs_write_nothing_to_stderr_on_success() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "small", &common::red_plastic());
    let o = fit_brdf!(
        "fit",
        &t,
        "--model",
        "lambert,ward",
        "--starts",
        "2",
        "--quiet"
    );
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    assert!(!o.stdout.is_empty(), "results still on stdout");
    let mut c = common::bin();
    c.args(report_args(&t, &d.path().join("rep")))
        .arg("--quiet");
    let o = c.output().unwrap();
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    assert!(!o.stdout.is_empty(), "results still on stdout");
}

#[test]
fn report_progress_lines_follow_the_work() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "small", &common::red_plastic());
    let mut c = common::bin();
    c.args(report_args(&t, &d.path().join("rep")));
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    // The verb's announcement, the family before and after its fit, then the
    // report's sections, first to last.
    let want = [
        "fitting 1 model(s) to ",
        "[1/1] fitting lambert ...",
        "      cbrt loss ",
        "report: fit quality: losses, bands, percentiles",
        "report: θh slices and residual maps",
        "report: albedo curves",
        "report: charts and page",
    ];
    let mut at = 0;
    for w in want {
        let k = lines[at..]
            .iter()
            .position(|l| l.starts_with(w))
            .unwrap_or_else(|| panic!("no line {w:?} after line {at}:\n{err}"));
        at += k + 1;
    }
}
