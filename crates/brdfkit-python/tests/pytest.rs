//! Runs the Python tests of the `brdfkit` package (`tests/test_*.py`) with pytest, after
//! computing what they compare against with the Rust API: lookups, evaluations, a fit,
//! a check, resampled tables, an RGL-EPFL `.bsdf` and its values, and a
//! `brdfkit-render` image, written into a temporary
//! directory (`BRDFKIT_REFS`). The Python side must give the same values to the bit.
//!
//! The Python is `$BRDFKIT_PYTHON` or `<workspace>/.venv/bin/python`, with the package
//! installed (`.venv/bin/pip install ./crates/brdfkit-python`, as `.ci/run` does).
//! Without it the test is ignored, with the reason (probed by build.rs, see
//! build/external_tools.rs); with `CI` set (to anything but "", "0" or "false") a
//! missing Python or package fails it. The package is not rebuilt here: after changing
//! the Rust side, reinstall it.

use brdfkit_core::Model;
use brdfkit_fit::families::{FitSettings, Structure, comparison_text, families, fit_each};
use brdfkit_fit::{FitData, Loss};
use brdfkit_merl::{Dims, Lookup, MerlTable};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use brdfkit_rgl::{RglBsdf, Tensor, TensorData, tensor};
#[path = "../../brdfkit-rgl/tests/common/felt.rs"]
mod felt;

#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

/// The grid of the test table: small, so that the debug-build fit here is quick.
const DIMS: (i64, i64, i64) = (24, 24, 48);

/// Pairs of the lookup and evaluation comparisons.
const PAIRS: usize = 20_000;

/// Seed and starts of the reference fit (the Python test fits with the same).
const FIT_STARTS: usize = 2;

/// Uncaptured output: the harness captures `print!`/`eprint!`, not direct writes.
fn say(s: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{s}");
}

/// SplitMix64 (Steele, Lea & Flood, OOPSLA 2014): a seeded stream with no dependency.
struct SplitMix(u64);

impl SplitMix {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniform direction on the sphere, z ≥ −0.2 (some pairs below the horizon).
    fn direction(&mut self) -> [f64; 3] {
        let z = -0.2 + 1.2 * self.unit();
        let phi = std::f64::consts::TAU * self.unit();
        let r = (1.0 - z * z).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

/// Little-endian float64 values, read in Python with `np.fromfile(path, "<f8")`.
fn write_f64(path: &Path, v: impl IntoIterator<Item = f64>) {
    let bytes: Vec<u8> = v.into_iter().flat_map(f64::to_le_bytes).collect();
    std::fs::write(path, bytes).expect("write a reference file");
}

fn write_json(path: &Path, v: &serde_json::Value) {
    std::fs::write(path, serde_json::to_string(v).expect("JSON")).expect("write a reference");
}

/// The model of the evaluation, check and resampling comparisons.
fn test_model() -> serde_json::Value {
    serde_json::json!({"model": "cook-torrance", "params": {
        "rho_d": [0.3, 0.2, 0.1], "rho_s": 0.7, "alpha": 0.2, "distribution": "ggx",
        "fresnel": {"schlick": {"f0": 0.04}}}})
}

/// The scene of the render comparison: a lone sphere with the test table under a
/// uniform sky (the Python test builds the same scene in Mitsuba).
fn scene_toml(table: &Path, seed: u64) -> String {
    format!(
        r#"effects = ["environment"]
film = {{ width = 96, height = 96, spp = 64, filter = "box", seed = {seed}, show_environment = false }}
camera = {{ position = [0.0, 0.0, 4.0], look_at = [0.0, 0.0, 0.0], up = [0.0, 1.0, 0.0], fov = 32.0 }}
sphere = {{ center = [0.0, 0.0, 0.0], radius = 1.0, material = {{ table = {table:?}, lookup = "nearest" }} }}
environment = {{ constant = [1.0, 1.0, 1.0] }}
"#
    )
}

/// Writes every reference the Python tests compare against into `dir`.
fn write_references(dir: &Path) {
    let dims = Dims::new(DIMS.0, DIMS.1, DIMS.2).expect("dims");
    let nbrdf_path = external_tools::workspace().join("data-measured/merl/gold-paint");
    let nbrdf = brdfkit_nbrdf::Nbrdf::load(&nbrdf_path).expect("the gold-paint NBRDF");
    let (table, _) = nbrdf.to_table(dims).expect("tabulate");
    let table_path = dir.join("gold.binary");
    table.write(&table_path).expect("write the table");

    let mut rng = SplitMix(0x5059_5445_5354);
    let (wi, wo): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (0..PAIRS)
        .map(|_| (rng.direction(), rng.direction()))
        .unzip();
    write_f64(&dir.join("wi.f64"), wi.iter().flatten().copied());
    write_f64(&dir.join("wo.f64"), wo.iter().flatten().copied());
    for (mode, name) in [
        (Lookup::Nearest, "nearest"),
        (Lookup::Interpolated, "linear"),
    ] {
        let mut out = vec![[0.0; 3]; PAIRS];
        table
            .lookup_split(mode, &wi, &wo, &mut out)
            .expect("lookup");
        write_f64(
            &dir.join(format!("lookup_{name}.f64")),
            out.into_iter().flatten(),
        );
    }

    let model_json = test_model();
    write_json(&dir.join("model.json"), &model_json);
    let model = brdfkit_models::from_json(&model_json).expect("the test model");
    let mut rgb = vec![brdfkit_core::Rgb([0.0; 3]); PAIRS];
    brdfkit_models::raw::eval_dirs(&*model, &wi, &wo, &mut rgb).expect("eval");
    write_f64(&dir.join("eval.f64"), rgb.iter().flat_map(|c| c.0));
    let report = brdfkit_validate::check_model(&*model);
    write_json(
        &dir.join("check.json"),
        &serde_json::to_value(&report).expect("JSON"),
    );
    let small = Dims::new(10, 10, 20).expect("dims");
    MerlTable::from_brdf(model.as_ref() as &dyn Model, small)
        .expect("resample the model")
        .write(dir.join("model_10_10_20.binary"))
        .expect("write");

    write_fit(&table, dir);
    write_rgl(&wi, &wo, dir);

    for seed in [1, 2] {
        let text = scene_toml(&table_path, seed);
        let scene = brdfkit_render::Scene::from_toml_str(&text, dir.join("scene.toml"))
            .expect("the render scene");
        let out = brdfkit_render::render(&scene).expect("render");
        let px = out.radiance.iter().flat_map(|c| c.0);
        write_f64(&dir.join(format!("render_seed{seed}.f64")), px);
    }
}

/// A small isotropic RGB `.bsdf` (8 θi slices, 16² values with negatives, smooth
/// `ndf`/`sigma`/`vndf`), its values at the pairs by `eval_flat` (what `fit-brdf eval
/// --bsdf` runs), its `info_json` and its 10 × 10 × 20 resampling.
fn write_rgl(wi: &[[f64; 3]], wo: &[[f64; 3]], dir: &Path) {
    let fields = felt::fields();
    let path = dir.join("felt.bsdf");
    tensor::write(&fields, &path).expect("write the .bsdf");
    let b = RglBsdf::read(&path).expect("read the .bsdf");
    let flat: Vec<f64> = wi
        .iter()
        .zip(wo)
        .flat_map(|(i, o)| [*i, *o])
        .flatten()
        .collect();
    let mut out = vec![0.0; wi.len() * 3];
    b.eval_flat(&flat, &mut out);
    write_f64(&dir.join("rgl_eval.f64"), out);
    write_json(
        &dir.join("rgl_info.json"),
        &b.info_json(&b.asymmetry(200_000, 5.0, 1)),
    );
    let (t, _) = b
        .to_table(Dims::new(10, 10, 20).expect("dims"))
        .expect("resample");
    t.write(dir.join("rgl_10_10_20.binary")).expect("write");
}

/// The reference fit: `fit-brdf fit`'s defaults (the Python `fit`'s) but two starts.
fn write_fit(table: &MerlTable, dir: &Path) {
    let fams = families("cook-torrance", &Structure::default()).expect("family");
    let cfg = FitSettings {
        starts: FIT_STARTS,
        ..FitSettings::default()
    }
    .config()
    .expect("settings");
    let data = FitData::from_table(table).expect("cells");
    let o = fit_each(&data, &fams, &cfg, &()).expect("fit");
    write_json(&dir.join("fit.json"), &o[0].to_json());
    // The files `fit-brdf fit --out` and `--record` write, and the table it prints.
    let text = |s: Result<String, serde_json::Error>| s.expect("JSON");
    std::fs::write(dir.join("fit_params.json"), text(o[0].params_file())).expect("write");
    std::fs::write(dir.join("fit_record.json"), text(o[0].record_file())).expect("write");
    let table_text = comparison_text(&o, Loss::Cbrt);
    std::fs::write(dir.join("fit_table.txt"), table_text).expect("write");
}

python_package_test! {
    fn python_package_tests() {
        let root = external_tools::workspace();
        let python = external_tools::require_python_package();
        // BRDFKIT_REFS_DIR keeps the references (to rerun pytest by hand against them).
        let refs = tempfile::tempdir().expect("a temporary directory");
        let refs = std::env::var_os("BRDFKIT_REFS_DIR").map_or(refs.path().to_path_buf(), |d| {
            std::fs::create_dir_all(&d).expect("create BRDFKIT_REFS_DIR");
            PathBuf::from(d)
        });
        let t = std::time::Instant::now();
        write_references(&refs);
        say(&format!(
            "brdfkit-python: references computed in {:.1} s",
            t.elapsed().as_secs_f64()
        ));
        let mut cmd = Command::new(&python);
        cmd.args(["-m", "pytest", "-q", "-rs", "crates/brdfkit-python/tests"])
            .current_dir(&root)
            .env("BRDFKIT_REFS", &refs);
        // Mitsuba's LLVM backend needs LLVM 19 (docs/python.md).
        let llvm = Path::new("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1");
        if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() && llvm.exists() {
            cmd.env("DRJIT_LIBLLVM_PATH", llvm);
        }
        let status = cmd.status().expect("run pytest");
        assert!(status.success(), "pytest failed: {status}");
    }
}
