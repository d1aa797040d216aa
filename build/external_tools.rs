//! The external tools some tests check against: Mitsuba 3 (in a Python), the brdfkit
//! Python package (with pytest), headless Chromium, npm's playwright-core (driving that
//! Chromium), npm's three.js beside it, Blender and the Khronos glTF validator. One
//! file, included with `#[path]` by the build scripts of brdfkit-render,
//! brdfkit-validate, brdfkit-python and fit-brdf and by their tests:
//!
//! - a build script calls [`emit`], which probes the tools and sets the cfgs
//!   `has_mitsuba` / `has_brdfkit_python` / `has_chromium` / `has_gltf_validator` /
//!   `has_browser_driver` / `has_threejs` / `has_blender`; the
//!   tests carry `#[cfg_attr(not(has_mitsuba), ignore = "...")]`, so a check that cannot
//!   run is counted as ignored, with the reason, never as passed;
//! - under `CI` (set to anything but "", "0" or "false") the cfgs are always on: CI must
//!   run the checks, and a missing tool fails them loudly;
//! - a test calls [`require_mitsuba`] / [`require_python_package`] / [`require_chromium`]
//!   / [`require_gltf_validator`] / [`require_browser_driver`] / [`require_threejs`] /
//!   [`require_blender`], which return the tool or panic saying how to install
//!   it (under CI, after a stale probe, or with `--include-ignored`);
//! - the tests are declared with `mitsuba_test!` / `python_package_test!` /
//!   `chromium_test!` / `gltf_validator_test!` / `browser_driver_test!` / `threejs_test!` /
//!   `blender_test!` (`#[test]` plus the `cfg_attr` and its
//!   reason, in one place); the including `mod` needs `#[macro_use]`.
//!
//! The Python is `$BRDFKIT_PYTHON`, else `<workspace>/.venv/bin/python`; Chromium is
//! `$CHROMIUM`, else `chromium` or `chromium-browser` on the `PATH` or in `/usr/bin`; the
//! glTF validator is npm's `gltf-validator` in `$BRDFKIT_GLTF_VALIDATOR`, else in
//! `<workspace>/target/gltf-validator` (where `.ci/run` installs it), run by `node`; the
//! browser driver is npm's `playwright-core` in `$BRDFKIT_BROWSER_TEST`, else in
//! `<workspace>/target/browser-test` (where `.ci/run` installs it), run by `node`;
//! three.js is npm's `three` in that same directory; Blender is `$BLENDER`, else `blender`
//! on the `PATH` or in `/usr/bin`.

// Build scripts use the probes, tests the `require_*` functions and the macros: neither
// uses all.
#![allow(dead_code, unused_macros)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// `#[test]`, ignored with `$reason` unless the build script set `$cfg`.
macro_rules! tool_test {
    ($cfg:ident, $reason:literal, $(#[$m:meta])* fn $name:ident() $body:block) => {
        $(#[$m])*
        #[test]
        #[cfg_attr(not($cfg), ignore = $reason)]
        fn $name() $body
    };
}

/// Declares one `#[test]`-declaring macro per tool: `$name! { fn t() { ... } }` is a test
/// ignored with `$reason` unless the build script set `$cfg` (see [`tool_test`]). `$d`
/// is a literal `$`, so that the macros written here can take their own arguments.
macro_rules! tool_tests {
    ($d:tt $($name:ident: $cfg:ident, $reason:literal;)+) => {
        $(
            macro_rules! $name {
                ($d($d t:tt)*) => {
                    tool_test! { $cfg, $reason, $d($d t)* }
                };
            }
        )+
    };
}

// The tests' macros: `mitsuba_test!` (Mitsuba 3), `python_package_test!` (the brdfkit
// Python package and pytest), `chromium_test!`, `gltf_validator_test!` (the Khronos
// validator), `browser_driver_test!` (Chromium driven by `playwright-core`),
// `threejs_test!` (three.js in that Chromium) and `blender_test!`.
tool_tests! { $
    mitsuba_test: has_mitsuba, "needs Mitsuba 3: python3 -m venv .venv && .venv/bin/pip install -r python/requirements.txt (or set BRDFKIT_PYTHON)";
    python_package_test: has_brdfkit_python, "needs the brdfkit Python package and pytest: python3 -m venv .venv && .venv/bin/pip install -r python/requirements.txt && .venv/bin/pip install ./crates/brdfkit-python (or set BRDFKIT_PYTHON)";
    chromium_test: has_chromium, "needs chromium: apt-get install chromium (or set CHROMIUM)";
    gltf_validator_test: has_gltf_validator, "needs the glTF validator: npm install --prefix target/gltf-validator gltf-validator (or set BRDFKIT_GLTF_VALIDATOR), and node";
    browser_driver_test: has_browser_driver, "needs chromium, node and npm's playwright-core: apt-get install chromium nodejs npm && npm install --prefix target/browser-test playwright-core@1.65.1 (or set BRDFKIT_BROWSER_TEST)";
    threejs_test: has_threejs, "needs chromium, node, npm's playwright-core and three: apt-get install chromium nodejs npm && npm install --prefix target/browser-test playwright-core@1.65.1 three@0.187.0 (or set BRDFKIT_BROWSER_TEST)";
    blender_test: has_blender, "needs blender (Debian's 3.4.1) with numpy: apt-get install --no-install-recommends blender python3-numpy (or set BLENDER)";
}

/// How to get Mitsuba 3 for the cross-checks.
pub const MITSUBA_ENABLE: &str = "python3 -m venv .venv && .venv/bin/pip install -r python/requirements.txt \
     (in the workspace root), or set BRDFKIT_PYTHON to a Python with mitsuba==3.9.1 and drjit==1.5.0";

/// How to get the brdfkit Python package for its pytest suite (`.ci/run` does this).
pub const PYTHON_PACKAGE_ENABLE: &str = "python3 -m venv .venv && .venv/bin/pip install -r python/requirements.txt \
     && .venv/bin/pip install ./crates/brdfkit-python (in the workspace root), or set BRDFKIT_PYTHON";

/// How to get three.js beside the browser driver for the engine check.
pub const THREEJS_ENABLE: &str = "apt-get install chromium nodejs npm, then npm install --prefix \
     target/browser-test playwright-core@1.65.1 three@0.187.0 (in the workspace root), or set \
     BRDFKIT_BROWSER_TEST to a directory holding node_modules/playwright-core and node_modules/three";

/// How to get Blender for the engine check.
pub const BLENDER_ENABLE: &str = "apt-get install --no-install-recommends blender python3-numpy \
     (Debian 12: Blender 3.4.1; its glTF importer needs numpy), or set BLENDER";

/// How to get the browser driver for the interactive panels' check.
pub const BROWSER_DRIVER_ENABLE: &str = "apt-get install chromium nodejs npm, then npm install --prefix \
     target/browser-test playwright-core@1.65.1 (in the workspace root), or set BRDFKIT_BROWSER_TEST \
     to a directory holding node_modules/playwright-core";

/// How to get the glTF validator for the export check.
pub const GLTF_VALIDATOR_ENABLE: &str = "npm install --prefix target/gltf-validator gltf-validator \
     (in the workspace root; needs node), or set BRDFKIT_GLTF_VALIDATOR to a directory holding \
     node_modules/gltf-validator";

/// How to get Chromium for the browser check.
pub const CHROMIUM_ENABLE: &str = "apt-get install chromium (Debian), or set CHROMIUM";

/// A tool a crate's tests need.
#[derive(Clone, Copy)]
pub enum Tool {
    /// Mitsuba 3 and Dr.Jit importable from the Python, `scalar_rgb` available.
    Mitsuba,
    /// The brdfkit Python package and pytest importable from the Python.
    PythonPackage,
    /// A headless Chromium.
    Chromium,
    /// npm's `gltf-validator` and `node`.
    GltfValidator,
    /// npm's `playwright-core`, `node` and a Chromium (it drives the browser; it never
    /// downloads one).
    BrowserDriver,
    /// The browser driver and npm's `three` beside it.
    ThreeJs,
    /// A `blender` executable.
    Blender,
}

/// `CI` set to anything but "", "0" or "false".
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.as_str(), "" | "0" | "false"))
}

/// The workspace root: every crate that includes this file sits at
/// `<workspace>/crates/<name>`.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Python the cross-checks use (it may not exist).
pub fn python() -> PathBuf {
    std::env::var_os("BRDFKIT_PYTHON")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(".venv/bin/python"))
}

/// Whether `py` runs `code` without an error.
fn python_runs(py: &Path, code: &str) -> bool {
    Command::new(py)
        .args(["-c", code])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether `py` imports Mitsuba 3 and Dr.Jit with the `scalar_rgb` variant.
pub fn mitsuba_importable(py: &Path) -> bool {
    python_runs(
        py,
        "import mitsuba, drjit; mitsuba.set_variant('scalar_rgb')",
    )
}

/// Whether `py` imports the brdfkit package and pytest.
pub fn python_package_importable(py: &Path) -> bool {
    python_runs(py, "import brdfkit, pytest")
}

/// The Chromium executable, if there is one.
pub fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM").map(PathBuf::from)
        && p.is_file()
    {
        return Some(p);
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    ["chromium", "chromium-browser"].iter().find_map(|name| {
        std::env::split_paths(&path)
            .chain([PathBuf::from("/usr/bin")])
            .map(|dir| dir.join(name))
            .find(|p| p.is_file())
    })
}

/// The directory holding `node_modules/gltf-validator` (it may not exist).
fn gltf_validator_dir() -> PathBuf {
    std::env::var_os("BRDFKIT_GLTF_VALIDATOR")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target/gltf-validator"))
}

/// The glTF validator's directory (`node` run there loads it), if it and `node` are
/// there.
pub fn gltf_validator() -> Option<PathBuf> {
    let dir = gltf_validator_dir();
    let ok = dir.join("node_modules/gltf-validator").is_dir()
        && Command::new("node")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success());
    ok.then_some(dir)
}

/// The directory holding `node_modules/playwright-core` (it may not exist).
fn browser_driver_dir() -> PathBuf {
    std::env::var_os("BRDFKIT_BROWSER_TEST")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target/browser-test"))
}

/// Whether `node --version` runs.
fn node_runs() -> bool {
    Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The driver's directory (`node` run there loads `playwright-core`) and the Chromium it
/// drives, if both and `node` are there.
pub fn browser_driver() -> Option<(PathBuf, PathBuf)> {
    let dir = browser_driver_dir();
    let ok = dir.join("node_modules/playwright-core").is_dir() && node_runs();
    ok.then_some(dir).zip(chromium())
}

/// The driver's directory (it also holds `node_modules/three`) and the Chromium, if
/// they, three.js and `node` are there.
pub fn threejs() -> Option<(PathBuf, PathBuf)> {
    browser_driver().filter(|(dir, _)| dir.join("node_modules/three/package.json").is_file())
}

/// The Blender executable: `$BLENDER`, else `blender` on the `PATH` or in `/usr/bin`.
pub fn blender() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("BLENDER").map(PathBuf::from)
        && p.is_file()
    {
        return Some(p);
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain([PathBuf::from("/usr/bin")])
        .map(|dir| dir.join("blender"))
        .find(|p| p.is_file())
}

/// What a failing `require_*` adds under CI.
fn ci_note() -> &'static str {
    if under_ci() {
        " (CI is set: the check must run)"
    } else {
        ""
    }
}

/// For tests: the Python if `importable` says it has `what`, or a panic that says how
/// to get it (`enable`).
fn require_python(importable: fn(&Path) -> bool, what: &str, enable: &str) -> PathBuf {
    let py = python();
    let missing = format!("{what} in {}", py.display());
    require(importable(&py).then_some(py), "Python", &missing, enable)
}

/// For tests: the Python with Mitsuba 3, or a panic that says how to get it.
pub fn require_mitsuba() -> PathBuf {
    require_python(mitsuba_importable, "Mitsuba 3", MITSUBA_ENABLE)
}

/// For tests: the Python with the brdfkit package and pytest, or a panic that says how
/// to get them.
pub fn require_python_package() -> PathBuf {
    require_python(
        python_package_importable,
        "brdfkit package and pytest",
        PYTHON_PACKAGE_ENABLE,
    )
}

/// For tests: the tool `found`, or a panic saying that the `check` cannot run for want
/// of `missing`, and how to get it (`enable`).
fn require<T>(found: Option<T>, check: &str, missing: &str, enable: &str) -> T {
    found.unwrap_or_else(|| {
        panic!(
            "the {check} check cannot run: no {missing}{}. Install: {enable}",
            ci_note()
        )
    })
}

/// For tests: the Chromium executable, or a panic that says how to get it.
pub fn require_chromium() -> PathBuf {
    require(chromium(), "browser", "chromium", CHROMIUM_ENABLE)
}

/// For tests: the glTF validator's directory, or a panic that says how to get it.
pub fn require_gltf_validator() -> PathBuf {
    let missing = format!(
        "node_modules/gltf-validator in {} or no node",
        gltf_validator_dir().display()
    );
    require(
        gltf_validator(),
        "glTF validator",
        &missing,
        GLTF_VALIDATOR_ENABLE,
    )
}

/// For tests: the driver's directory and the Chromium, or a panic that says how to get
/// them.
pub fn require_browser_driver() -> (PathBuf, PathBuf) {
    let missing = format!(
        "node_modules/playwright-core in {}, no node or no chromium",
        browser_driver_dir().display()
    );
    require(browser_driver(), "browser", &missing, BROWSER_DRIVER_ENABLE)
}

/// For tests: the driver's directory (with three.js) and the Chromium, or a panic that
/// says how to get them.
pub fn require_threejs() -> (PathBuf, PathBuf) {
    let missing = format!(
        "node_modules/playwright-core and node_modules/three in {}, no node or no chromium",
        browser_driver_dir().display()
    );
    require(threejs(), "three.js", &missing, THREEJS_ENABLE)
}

/// For tests: the Blender executable, or a panic that says how to get it.
pub fn require_blender() -> PathBuf {
    require(blender(), "Blender", "blender", BLENDER_ENABLE)
}

/// For build scripts: the probe is redone when one of `vars` changes, or `path`. Only a
/// path that exists is watched: a missing one would rerun the script on every build and
/// so rebuild the crate and all that depends on it.
fn watch(vars: &[&str], path: &Path) {
    for v in vars {
        println!("cargo::rerun-if-env-changed={v}");
    }
    if path.exists() {
        println!("cargo::rerun-if-changed={}", path.display());
    }
}

/// For build scripts: the Python, with the paths whose change redoes its probe (the
/// executable, and the packages installed into the workspace's `.venv`).
fn watch_python() -> PathBuf {
    let py = python();
    watch(&["BRDFKIT_PYTHON"], &py);
    watch(&[], &workspace().join(".venv/lib"));
    py
}

/// For build scripts: a tool found on the `PATH` (or its standard place), watched where
/// it was found, or `/usr/bin` where it will be installed.
fn watch_found(var: &str, found: Option<PathBuf>) -> bool {
    watch(&[var], found.as_deref().unwrap_or(Path::new("/usr/bin")));
    found.is_some()
}

/// For build scripts: probes `tools` and sets `has_mitsuba` / `has_brdfkit_python` /
/// `has_chromium` / `has_gltf_validator`, always under CI. The probe is redone when the environment variables change, when the tool
/// found changes, or (the Python tools) when packages are installed into the workspace's
/// `.venv`.
/// A tool installed where nothing was watched (a new `.venv`, a new browser) is seen
/// after `cargo clean -p <crate>`; until then `cargo test -- --include-ignored` runs
/// the checks anyway.
pub fn emit(tools: &[Tool]) {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=../../build/external_tools.rs");
    println!("cargo::rerun-if-env-changed=CI");
    let ci = under_ci();
    for tool in tools {
        let (cfg, present) = match tool {
            Tool::Mitsuba => ("has_mitsuba", ci || mitsuba_importable(&watch_python())),
            Tool::PythonPackage => (
                "has_brdfkit_python",
                ci || python_package_importable(&watch_python()),
            ),
            Tool::Chromium => ("has_chromium", watch_found("CHROMIUM", chromium()) || ci),
            Tool::GltfValidator => {
                watch(&["BRDFKIT_GLTF_VALIDATOR"], &gltf_validator_dir());
                ("has_gltf_validator", ci || gltf_validator().is_some())
            }
            Tool::BrowserDriver => {
                watch(&["BRDFKIT_BROWSER_TEST", "CHROMIUM"], &browser_driver_dir());
                ("has_browser_driver", ci || browser_driver().is_some())
            }
            Tool::ThreeJs => {
                let modules = browser_driver_dir().join("node_modules");
                watch(&["BRDFKIT_BROWSER_TEST", "CHROMIUM"], &modules);
                ("has_threejs", ci || threejs().is_some())
            }
            Tool::Blender => ("has_blender", watch_found("BLENDER", blender()) || ci),
        };
        println!("cargo::rustc-check-cfg=cfg({cfg})");
        if present {
            println!("cargo::rustc-cfg={cfg}");
        }
    }
}
