//! Files written by brdfkit's RGL writer (brdfkit_rgl::write) in Mitsuba 3: its
//! `measured` plugin loads them (`scalar_rgb`) and evaluates them as brdfkit's reader
//! does, close to the source on the seven vendored proxies (data-measured/); its χ²
//! test (`mitsuba.chi2`) passes on their sampling; and a render of a written table is
//! within 2 % relative RMS of the same table rendered through brdfkit's `brdfkit_merl`
//! plugin. Needs Mitsuba 3 (build/external_tools.rs; with `CI` set a missing Mitsuba
//! fails); the render also needs the brdfkit Python package.

#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

mod write_support;

use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_rgl::RglBsdf;
use brdfkit_rgl::write::{WriteOptions, write};
use std::path::Path;
use std::process::Command;
use write_support::{anisotropic_sources, median_p90, pairs, proxies, proxy, rel};

fn script(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(name)
}

/// Mitsuba's `eval` (scalar_rgb, tests/mitsuba_eval.py) of `file` at `ps`.
fn mitsuba_eval(py: &Path, file: &Path, ps: &[(Vec3, Vec3)]) -> Vec<Rgb> {
    let dir = file.parent().unwrap();
    let flat: Vec<u8> = ps
        .iter()
        .flat_map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .flat_map(f64::to_le_bytes)
        .collect();
    std::fs::write(dir.join("pairs.bin"), flat).unwrap();
    let st = Command::new(py)
        .arg(script("mitsuba_eval.py"))
        .args(["scalar_rgb", file.to_str().unwrap(), "pairs.bin", "out.bin"])
        .current_dir(dir)
        .status()
        .unwrap();
    assert!(st.success(), "mitsuba_eval.py failed");
    std::fs::read(dir.join("out.bin"))
        .unwrap()
        .chunks_exact(24)
        .map(
            |c| Rgb([0, 1, 2].map(|k| f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().unwrap()))),
        )
        .collect()
}

/// brdfkit's reader against Mitsuba on one file: (fraction within 1e-4 rel + 1e-6,
/// values beyond 1 % + 1e-5 abs), the criteria of tests/mitsuba.rs; the reader's f_r
/// times cos θo against Mitsuba's f · cos θo.
fn reader_vs_mitsuba(bsdf: &RglBsdf, ps: &[(Vec3, Vec3)], mi: &[Rgb]) -> (f64, usize) {
    let (mut within, mut beyond, mut n) = (0, 0, 0);
    for ((wi, wo), m) in ps.iter().zip(mi) {
        let ours = bsdf.eval(wi, wo);
        for c in 0..3 {
            let (a, b) = (ours.0[c] * wo.z, m.0[c]);
            n += 1;
            within += usize::from((a - b).abs() <= 1e-4 * b.abs() + 1e-6);
            beyond += usize::from((a - b).abs() > 1e-2 * b.abs() + 1e-5);
        }
    }
    (within as f64 / n as f64, beyond)
}

/// Median and p90 relative error of Mitsuba's eval ÷ cos θo (f · cos θo by its
/// `BSDF::eval` contract) against the source.
fn mitsuba_vs_source(ps: &[(Vec3, Vec3)], mi: &[Rgb], src: &dyn Brdf) -> (f64, f64) {
    let errs: Vec<f64> = ps
        .iter()
        .zip(mi)
        .filter_map(|((wi, wo), m)| rel(&m.map(|c| c / wo.z), &src.eval(wi, wo)))
        .collect();
    median_p90(errs)
}

mitsuba_test! {
    /// 100,000 random pairs above 1° on two written files (32² and 64²): brdfkit's
    /// reader equals Mitsuba's `measured` (≥ 99.9 % within 1e-4 relative + 1e-6, none
    /// beyond 1 % + 1e-5 absolute, as tests/mitsuba.rs on hand-built files).
    fn mitsuba_reads_written_files_as_brdfkit_does() {
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let ps = pairs(100_000, 1.0, 11);
        for (name, grid) in [("gold-paint", 32), ("pink-fabric", 64)] {
            let file = dir.path().join(format!("{name}_rgb.bsdf"));
            write(&proxy(name), &WriteOptions { grid, ..WriteOptions::default() }, &file).unwrap();
            let mi = mitsuba_eval(&py, &file, &ps);
            let (within, beyond) = reader_vs_mitsuba(&RglBsdf::read(&file).unwrap(), &ps, &mi);
            eprintln!("{name} {grid}x{grid}: {:.4} % within 1e-4, {beyond} beyond 1 %", 100.0 * within);
            assert!(within >= 0.999 && beyond == 0, "{name}: {within} within, {beyond} beyond");
        }
    }
}

mitsuba_test! {
    /// Mitsuba's `eval` of each proxy's file (8 θi slices, 32²) against the proxy, 20,000
    /// random pairs above 1°: Mitsuba returns f · cos θo (its `BSDF::eval` contract), so
    /// it is divided by cos θo. Prints the median and p90 relative error (docs/rgl.md);
    /// the bounds are those of tests/write.rs.
    fn mitsuba_eval_of_written_files_matches_the_source() {
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let ps = pairs(20_000, 1.0, 13);
        for (name, stem) in proxies() {
            let src = brdfkit_nbrdf::Nbrdf::load(&stem).unwrap();
            let file = dir.path().join(format!("{name}_rgb.bsdf"));
            write(&src, &WriteOptions::default(), &file).unwrap();
            let mi = mitsuba_eval(&py, &file, &ps);
            let (med, p90) = mitsuba_vs_source(&ps, &mi, &src);
            eprintln!("{name}: Mitsuba vs source: median {:.2} %, p90 {:.2} %", 100.0 * med, 100.0 * p90);
            let (max_med, max_p90) = if name == "chrome-steel" { (0.30, 3.0) } else { (0.05, 0.40) };
            assert!(med < max_med && p90 < max_p90, "{name}: median {med}, p90 {p90}");
        }
    }
}

mitsuba_test! {
    /// Mitsuba's χ² test of the `measured` plugin's sampling (`mitsuba.chi2`, 10⁶
    /// samples, 101 × 202 bins, significance 1 %) at three incident elevations, on the
    /// files of a glossy and a diffuse proxy.
    fn chi2_passes_on_written_files() {
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        for name in ["gold-paint", "pink-fabric"] {
            let file = dir.path().join(format!("{name}_rgb.bsdf"));
            write(&proxy(name), &WriteOptions::default(), &file).unwrap();
            let out = Command::new(&py)
                .arg(script("write_mitsuba.py"))
                .args(["chi2", file.to_str().unwrap(), "10", "45", "75"])
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            eprintln!("{name}:\n{text}{}", String::from_utf8_lossy(&out.stderr));
            assert!(out.status.success(), "write_mitsuba.py chi2 failed");
            assert_eq!(text.lines().count(), 3);
            assert!(text.lines().all(|l| l.contains("\"passed\": true")), "{name}: {text}");
        }
    }
}

mitsuba_test! {
    /// The anisotropic files (write_support: a GGX Cook-Torrance with αx ≠ αy, 4-fold;
    /// the lobe turned by 30°, 2-fold; that plus a term without symmetry, no fold),
    /// written with the default options: Mitsuba's `measured` (`scalar_rgb`) loads each
    /// and equals brdfkit's reader at 100,000 random pairs above 1° (≥ 99.9 % within
    /// 1e-4 relative + 1e-6, none beyond 1 % + 1e-5), and Mitsuba's eval ÷ cos θo
    /// against the source (median and p90 relative error, printed for docs/rgl.md;
    /// bounds those of tests/write.rs's anisotropic read-back, ~1.5× the figures).
    fn mitsuba_reads_written_anisotropic_files_as_brdfkit_does() {
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let ps = pairs(100_000, 1.0, 17);
        for (name, src, _) in anisotropic_sources() {
            let file = dir.path().join(format!("{name}_rgb.bsdf"));
            write(src.as_ref(), &WriteOptions::default(), &file).unwrap();
            let mi = mitsuba_eval(&py, &file, &ps);
            let (within, beyond) = reader_vs_mitsuba(&RglBsdf::read(&file).unwrap(), &ps, &mi);
            let (med, p90) = mitsuba_vs_source(&ps, &mi, src.as_ref());
            eprintln!(
                "{name}: reader vs Mitsuba {:.4} % within 1e-4, {beyond} beyond 1 %; Mitsuba vs source median {:.2} %, p90 {:.2} %",
                100.0 * within,
                100.0 * med,
                100.0 * p90
            );
            assert!(within >= 0.999 && beyond == 0, "{name}: {within} within, {beyond} beyond");
            assert!(med < 0.06 && p90 < 0.33, "{name}: median {med}, p90 {p90}");
        }
    }
}

mitsuba_test! {
    /// Mitsuba's χ² test of the `measured` plugin's sampling (10⁶ samples, 101 × 202
    /// bins, significance 1 %) on the three written anisotropic files at five incident
    /// directions of several elevations and azimuths (φi 40°, −150°, 100°, −60°, 200°:
    /// every quadrant, so every branch of the folds).
    fn chi2_passes_on_written_anisotropic_files() {
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let dirs = ["10@40", "45@-150", "45@100", "70@-60", "75@200"];
        for (name, src, _) in anisotropic_sources() {
            let file = dir.path().join(format!("{name}_rgb.bsdf"));
            write(src.as_ref(), &WriteOptions::default(), &file).unwrap();
            let out = Command::new(&py)
                .arg(script("write_mitsuba.py"))
                .arg("chi2")
                .arg(&file)
                .args(dirs)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            eprintln!("{name}:\n{text}{}", String::from_utf8_lossy(&out.stderr));
            assert!(out.status.success(), "write_mitsuba.py chi2 failed");
            assert_eq!(text.lines().count(), dirs.len());
            assert!(text.lines().all(|l| l.contains("\"passed\": true")), "{name}: {text}");
        }
    }
}

/// A MERL table as a BRDF: the interpolated lookup, missing cells 0 (what
/// `fit-brdf export TABLE --to rgl` writes from, `Representation::as_brdf`).
struct TableSource(brdfkit_merl::MerlTable);

impl Brdf for TableSource {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.0
            .lookup(brdfkit_merl::Lookup::Interpolated, wi, wo)
            .unwrap_or(Rgb::ZERO)
    }
}

python_package_test! {
    /// The gold-paint proxy tabulated as a 90 × 90 × 180 MERL table, written as a
    /// `.bsdf` (8 θi slices, 32²) and rendered by Mitsuba 3 (`llvm_ad_rgb`, 256², a
    /// sphere under a point light, then under a constant environment) through
    /// `measured`, against the same table through brdfkit's `brdfkit_merl` (linear
    /// lookup): relative RMS over 8 × 8-pixel block means on the sphere ≤ 2 %.
    ///
    /// 16 spp (point light: only the pixel footprint is random) and 64 spp
    /// (environment); the block means divide the per-pixel noise by 8, and the noise
    /// floor (two seeds of the same file) is asserted to stay well below the 2 %.
    fn render_matches_brdfkit_merl() {
        let py = external_tools::require_python_package();
        external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let table = dir.path().join("gold.binary");
        let file = dir.path().join("gold_rgb.bsdf");
        let (t, _) = proxy("gold-paint").to_table(brdfkit_merl::Dims::MERL).unwrap();
        t.write(&table).unwrap();
        write(&TableSource(t), &WriteOptions::default(), &file).unwrap();
        let out = Command::new(&py)
            .arg(script("write_mitsuba.py"))
            .args(["render", table.to_str().unwrap(), file.to_str().unwrap(), "16", "64"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        eprintln!("{text}{}", String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "write_mitsuba.py render failed");
        let v: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        for light in ["point", "env"] {
            let rms = v[light]["rel_rms"].as_f64().unwrap();
            let floor = v[light]["noise_floor"].as_f64().unwrap();
            assert!(floor < 0.012, "{light}: noise floor {floor}");
            assert!(rms <= 0.02, "{light}: relative RMS {rms}");
        }
    }
}
