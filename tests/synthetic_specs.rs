//! Every spec shipped in data-synthetic/ parses, names a registered model, and
//! synthesises a table whose valid cells hold the model's value at the cell angles
//! (exactly, or within the noise the spec asks for).

use brdfkit::core::from_half_diff;
use brdfkit::merl::Dims;
use brdfkit::synth::SynthSpec;
use std::path::PathBuf;

fn specs() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data-synthetic");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn at_least_the_promised_materials_are_shipped() {
    let names: Vec<String> = specs()
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    assert!(names.len() >= 10, "{names:?}");
    for must in [
        "demo-plastic",
        "near-mirror-silver",
        "lafortune-two-lobes",
        "ward-duer",
    ] {
        assert!(
            names.iter().any(|n| n == must),
            "{must} missing from {names:?}"
        );
    }
}

#[test]
fn every_spec_synthesises_its_model() {
    for path in specs() {
        let mut spec = SynthSpec::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(spec.dims, Dims::MERL, "{}", path.display());
        // A coarse grid keeps the test fast; the mapping is the same at any dims.
        spec.dims = Dims::new(18, 18, 36).unwrap();
        let t = spec.synthesize().unwrap();
        let d = t.dims();
        let sigma = spec.noise.map_or(0.0, |n| n.sigma);
        let mut valid = 0usize;
        for idx in 0..d.cells() {
            let (i, j, k) = d.unflatten(idx);
            let (wi, wo) = from_half_diff(&d.cell_angles(i, j, k));
            let Some(v) = t.get_flat(idx) else {
                continue;
            };
            valid += 1;
            assert!(
                wi.z > 0.0 && wo.z > 0.0,
                "{}: cell {idx} valid below the horizon",
                path.display()
            );
            let truth = spec.truth(&wi, &wo);
            for c in 0..3 {
                if sigma == 0.0 {
                    // Written through the file's scale and back: a few ulps.
                    assert!(
                        (v[c] - truth[c]).abs() <= 1e-14 * truth[c].abs(),
                        "{}: cell {idx} channel {c}: {} vs {}",
                        path.display(),
                        v[c],
                        truth[c]
                    );
                } else {
                    let r = (v[c] / truth[c]).ln().abs();
                    assert!(
                        truth[c] == 0.0 || r <= 6.0 * sigma,
                        "{}: noise {r}",
                        path.display()
                    );
                }
            }
        }
        assert!(
            valid > d.cells() / 3,
            "{}: only {valid} valid cells",
            path.display()
        );
    }
}
