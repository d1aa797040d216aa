//! The Mitsuba 3 cross-check (see `brdfkit_validate::mitsuba` and docs/validation.md).
//!
//! The Python is `$BRDFKIT_PYTHON` or `<workspace>/.venv/bin/python`. Without Mitsuba the
//! tests that need it are ignored, with the reason (probed by build.rs, see
//! build/external_tools.rs); with `CI` set (to anything but "", "0" or "false") a
//! missing Mitsuba fails them.
//!
//! The measured maxima are written to stderr directly (not through `eprintln!`, which
//! the test harness captures), so they show in every `cargo test` run.

#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use brdfkit_validate::mitsuba::{
    Comparison, DRJIT_VERSION, MITSUBA_VERSION, MitsubaError, cases, compare, run_mitsuba,
    script_path, standard_configs,
};
use external_tools::{require_mitsuba, under_ci};
use std::io::Write;

/// Uncaptured output: the harness captures `print!`/`eprint!`, not direct writes.
fn say(s: &str) {
    let mut e = std::io::stderr().lock();
    let _ = writeln!(e, "{s}");
}

mitsuba_test! {
    fn mitsuba_cross_check() {
        let python = require_mitsuba();
        let configs = standard_configs();
        let cases = cases(0x4D49_5453);
        let t = std::time::Instant::now();
        let out = run_mitsuba(&python, &script_path(), &configs, &cases)
            .unwrap_or_else(|e| panic!("the Mitsuba side failed: {e}"));
        let pinned = out.mitsuba == MITSUBA_VERSION && out.drjit == DRJIT_VERSION;
        if !pinned {
            let msg = format!(
                "Mitsuba {} / Dr.Jit {} found, the tolerances were measured with the pins {MITSUBA_VERSION} / {DRJIT_VERSION}",
                out.mitsuba, out.drjit
            );
            assert!(!under_ci(), "{msg}");
            say(&format!("!!! {msg}"));
        }
        say(&format!(
            "Mitsuba {} (Dr.Jit {}, {}) via {}: {} configurations x {} cases in {:.1} s",
            out.mitsuba,
            out.drjit,
            out.variant,
            python.display(),
            configs.len(),
            cases.len(),
            t.elapsed().as_secs_f64()
        ));
        let results: Vec<Comparison> = configs
            .iter()
            .zip(&out.values)
            .map(|(c, v)| compare(c, &cases, v).unwrap_or_else(|e| panic!("{}: {e}", c.name)))
            .collect();
        for r in &results {
            say(&format!("  {r}"));
        }
        // Maxima per family.
        for prefix in ["diffuse", "roughconductor-ggx", "roughconductor-beckmann"] {
            let fam: Vec<&Comparison> = results
                .iter()
                .filter(|r| r.name.starts_with(prefix))
                .collect();
            let max = |f: &dyn Fn(&Comparison) -> f64| fam.iter().map(|r| f(r)).fold(0.0, f64::max);
            let mut line = format!(
                "  max over {prefix}*: rel diff {:.3e}, net of the input ambiguity {:.3e}, input ambiguity {:.3e}, diff/allowance {:.3}",
                max(&|r| r.max_rel_diff),
                max(&|r| r.max_rel_diff_beyond_ambiguity),
                max(&|r| r.max_input_ambiguity),
                max(&|r| r.max_tolerance_ratio)
            );
            if fam.iter().any(|r| r.reference_max_rel_diff.is_some()) {
                line += &format!(
                    "; exact-erf Beckmann vs Mitsuba {:.3e} (measured, not judged)",
                    max(&|r| r.reference_max_rel_diff.unwrap_or(0.0))
                );
            }
            say(&line);
        }
        if let Ok(path) = std::env::var("BRDFKIT_MITSUBA_REPORT") {
            // Atomically: a temporary file beside the destination, then a rename.
            let path = std::path::PathBuf::from(path);
            let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
            let mut tmp = tempfile::NamedTempFile::new_in(dir.unwrap_or(std::path::Path::new(".")))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            tmp.write_all(serde_json::to_string_pretty(&results).unwrap().as_bytes())
                .and_then(|()| tmp.persist(&path).map(|_| ()).map_err(|e| e.error))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        let failed: Vec<String> = results
            .iter()
            .filter(|r| !r.passed)
            .map(|r| r.to_text())
            .collect();
        assert!(
            failed.is_empty(),
            "Mitsuba disagrees:\n{}",
            failed.join("\n")
        );
        // Every configuration compared real values: no configuration may pass vacuously.
        for r in &results {
            let compared = 3 * r.cases - r.both_zero - 3 * r.floor_cases;
            assert!(
                compared >= 3_000,
                "{}: only {compared} channel values compared",
                r.name
            );
        }
    }
}

#[test]
fn a_missing_interpreter_is_reported_as_missing() {
    let cfg = &standard_configs()[..1];
    let c = &cases(1)[..10];
    let e = run_mitsuba(
        std::path::Path::new("/nonexistent/python3"),
        &script_path(),
        cfg,
        c,
    )
    .unwrap_err();
    assert!(matches!(e, MitsubaError::Missing(_)), "{e}");
}

mitsuba_test! {
    fn mitsuba_rejects_a_bad_bsdf_with_a_named_error() {
        let python = require_mitsuba();
        let mut cfg = standard_configs().remove(0);
        cfg.name = "broken".into();
        cfg.mitsuba = serde_json::json!({"type": "no-such-plugin"});
        match run_mitsuba(&python, &script_path(), &[cfg], &cases(1)[..10]) {
            Err(MitsubaError::Failed { stderr, .. }) => {
                assert!(
                    stderr.contains("broken") && stderr.contains("no-such-plugin"),
                    "{stderr}"
                )
            }
            other => panic!("expected a failure, got {other:?}"),
        }
    }
}
