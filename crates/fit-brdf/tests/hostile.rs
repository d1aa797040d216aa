//! The malformed-input matrix of the reliability issue, through the library and through
//! the CLI: every bad table, spec, scene and model file gives a typed error whose
//! message names the file and the problem, exit code 2, and no panic; a header's claim
//! never makes the reader allocate beyond the file's size.

#[macro_use]
mod common;

use brdfkit::merl::{MerlError, MerlTable};
use common::{assert_bad_input, bin, lambert_file, temp_file, write_file};
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};

fn header(a: i32, b: i32, c: i32) -> Vec<u8> {
    [a.to_le_bytes(), b.to_le_bytes(), c.to_le_bytes()].concat()
}

fn table_bytes(dims: [i32; 3], fill: f64) -> Vec<u8> {
    let n = (dims[0] * dims[1] * dims[2]) as usize;
    let mut v = header(dims[0], dims[1], dims[2]);
    for _ in 0..3 * n {
        v.extend_from_slice(&fill.to_le_bytes());
    }
    v
}

fn with_value(dims: [i32; 3], at: usize, x: f64) -> Vec<u8> {
    let mut v = table_bytes(dims, 0.5);
    v[12 + 8 * at..20 + 8 * at].copy_from_slice(&x.to_le_bytes());
    v
}

/// Runs `fit-brdf info` on a file and checks the contract: exit 2, `error: ` first, the
/// file named, `what` in the message, no panic.
fn cli_rejects(path: &Path, what: &str) {
    let o = fit_brdf!("info", path);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{}: {err}", path.display());
    assert!(err.starts_with("error: "), "{err}");
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(err.contains(name.as_ref()), "{err} does not name {name}");
    assert!(err.contains(what), "{err} does not say `{what}`");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn malformed_tables_are_typed_errors_in_the_library_and_exit_2_in_the_cli() {
    let d = tempfile::tempdir().unwrap();
    let d2 = [2, 3, 4];
    let full = table_bytes(d2, 0.5);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty.binary", vec![], "header"),
        // A CSV of direction pairs given as a table: said before its "dims" are judged.
        (
            "pairs.csv",
            b"wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n".to_vec(),
            "not a MERL table: it starts with text",
        ),
        ("eleven.binary", vec![0u8; 11], "header"),
        ("negative-dims.binary", header(-90, 90, 180), "dims"),
        ("zero-dims.binary", header(90, 0, 180), "dims"),
        // 65536 · 65536 · 2 overflows i32 but not usize: caught by the length check.
        ("i32-overflow.binary", header(65536, 65536, 2), "bytes"),
        // i32::MAX³ · 24 bytes overflows u64/usize.
        (
            "usize-overflow.binary",
            header(i32::MAX, i32::MAX, i32::MAX),
            "dims",
        ),
        (
            "byte-short.binary",
            full[..full.len() - 1].to_vec(),
            "bytes",
        ),
        (
            "double-short.binary",
            full[..full.len() - 8].to_vec(),
            "bytes",
        ),
        (
            "trailing.binary",
            [full.clone(), vec![0u8; 3]].concat(),
            "trailing",
        ),
        ("nan.binary", with_value(d2, 5, f64::NAN), "non-finite"),
        (
            "inf.binary",
            with_value(d2, 30, f64::INFINITY),
            "non-finite",
        ),
        ("huge.binary", with_value(d2, 7, 1e31), "1e30"),
    ];
    for (name, bytes, what) in &cases {
        let p = d.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let e = MerlTable::read(&p).expect_err(name);
        assert_eq!(e.path(), p.as_path(), "{name}: the error carries the path");
        assert!(e.to_string().contains(what), "{name}: {e}");
        match (*name, &e) {
            ("nan.binary" | "inf.binary", MerlError::NonFinite { .. }) => {}
            ("huge.binary", MerlError::TooLarge { .. }) => {}
            ("trailing.binary", MerlError::TrailingBytes { .. }) => {}
            ("pairs.csv", MerlError::NotMerl { .. }) => {}
            ("empty.binary" | "eleven.binary", MerlError::TooShort { .. }) => {}
            (
                "negative-dims.binary" | "zero-dims.binary" | "usize-overflow.binary",
                MerlError::Dims { .. },
            ) => {}
            (
                "i32-overflow.binary" | "byte-short.binary" | "double-short.binary",
                MerlError::Truncated { .. },
            ) => {}
            (n, other) => panic!("{n}: unexpected error variant {other:?}"),
        }
        cli_rejects(&p, what);
    }
    // A directory, a path that does not exist.
    let o = fit_brdf!("info", d.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("directory"));
    cli_rejects(&d.path().join("absent.binary"), "absent.binary");
}

#[test]
fn an_unreadable_file_is_bad_input_not_a_panic() {
    // Root opens any file whatever its mode; open(2) of a Unix socket fails for
    // everyone (ENXIO), which is the "cannot open" case.
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("socket.binary");
    let _listener = std::os::unix::net::UnixListener::bind(&p).unwrap();
    let e = MerlTable::read(&p).unwrap_err();
    assert!(matches!(e, MerlError::Io { .. }), "{e:?}");
    let o = fit_brdf!("info", &p);
    assert_bad_input(&o, &["socket.binary"]);
}

#[test]
fn a_header_claiming_gigabytes_does_not_allocate_them() {
    // 1000³ cells claim 24 GB; the file is 36 bytes. Under a 1 GB address-space limit a
    // reader that allocated on the header's word would abort (exit 134), not exit 2.
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("liar.binary");
    let mut bytes = header(1000, 1000, 1000);
    bytes.extend_from_slice(&[0u8; 24]);
    std::fs::write(&p, bytes).unwrap();
    let exe = assert_cmd::cargo::cargo_bin("fit-brdf");
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1000000 && exec \"$0\" info \"$1\"")
        .arg(&exe)
        .arg(&p)
        .output()
        .unwrap();
    assert_bad_input(&o, &["liar.binary", "bytes"]);
}

#[test]
fn a_non_utf8_path_is_handled() {
    let d = tempfile::tempdir().unwrap();
    let name = std::ffi::OsStr::from_bytes(b"caf\xe9-\xff.binary");
    let p: PathBuf = d.path().join(name);
    std::fs::write(&p, vec![0u8; 5]).unwrap();
    let o = fit_brdf!("info", &p);
    assert_bad_input(&o, &["caf", ".binary"]);
    // A good table under such a name reads fine.
    let good = d
        .path()
        .join(std::ffi::OsStr::from_bytes(b"ok-\xff.binary"));
    std::fs::write(&good, table_bytes([2, 2, 2], 0.25)).unwrap();
    bin().arg("info").arg(&good).assert().success();
}

/// `fit-brdf <verb> FILE --out OUT` on FILE holding `text`: refused as by [`rejects`],
/// and nothing written at OUT.
fn rejects_writing(verb: &str, file: &Path, text: impl AsRef<[u8]>, out: &Path, what: &str) {
    std::fs::write(file, text).unwrap();
    let args = [
        verb.as_ref(),
        file.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    rejects(&args, file, what);
    assert!(
        !out.exists(),
        "{}: no output from a bad input",
        file.display()
    );
}

/// `fit-brdf <cmd> FILE ...` on a bad file: exit 2, the file named, `what` said.
fn rejects(args: &[&std::ffi::OsStr], file: &Path, what: &str) {
    let o = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    let name = file.file_name().unwrap().to_string_lossy();
    assert!(
        err.contains(name.as_ref()) && err.contains(what),
        "{args:?}: `{what}` not in {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_specs_are_rejected() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("t.binary");
    let cases = [
        (
            "types.toml",
            "name = 5\n[material]\nmodel = \"lambert\"\n",
            "invalid type",
        ),
        (
            "unknown.toml",
            "name = \"x\"\nsize = 3\n[material]\nmodel = \"lambert\"\n",
            "unknown field `size`",
        ),
        ("missing.toml", "name = \"x\"\n", "missing field `material`"),
        (
            "rough.toml",
            "name = \"x\"\n[material]\nmodel = \"cook-torrance\"\nparams = { alpha = -0.1 }\n",
            "alpha",
        ),
        (
            "rho.toml",
            "name = \"x\"\n[material]\nmodel = \"plausible-phong\"\nparams = { rho_d = 1.5 }\n",
            "rho_d",
        ),
        ("syntax.toml", "name = \"x\n", "TOML"),
    ];
    for (file, text, what) in cases {
        rejects_writing("synth", &d.path().join(file), text, &out, what);
    }
}

#[test]
fn bad_model_descriptions_are_rejected() {
    let (d, dirs) = temp_file("dirs.csv", "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n");
    let cases = [
        (
            "types.json",
            r#"{"model": "lambert", "params": {"rho_d": "grey"}}"#,
            "rho_d",
        ),
        (
            "unknown.json",
            r#"{"model": "lambert", "params": {"albedo": 0.5}}"#,
            "albedo",
        ),
        (
            "missing.json",
            r#"{"params": {"rho_d": 0.5}}"#,
            "missing field `model`",
        ),
        (
            "rough.json",
            r#"{"model": "cook-torrance", "params": {"alpha": -1}}"#,
            "alpha",
        ),
        (
            "rho.json",
            r#"{"model": "lambert", "params": {"rho_d": [0.2, 1.2, 0.2]}}"#,
            "rho_d",
        ),
        (
            "lobes.json",
            r#"{"model": "lafortune", "params": {"lobes": [{"cxy": -1, "n": -3}]}}"#,
            "n",
        ),
        (
            "fresnel.json",
            r#"{"model": "cook-torrance", "params": {"fresnel": {"glass": {}}}}"#,
            "glass",
        ),
        ("syntax.json", r#"{"model": "lambert""#, "JSON"),
    ];
    for (file, text, what) in cases {
        let p = d.path().join(file);
        std::fs::write(&p, text).unwrap();
        rejects(
            &[
                "eval".as_ref(),
                "--model".as_ref(),
                p.as_os_str(),
                "--dirs".as_ref(),
                dirs.as_os_str(),
            ],
            &p,
            what,
        );
        rejects(&["check".as_ref(), p.as_os_str()], &p, what);
    }
}

#[test]
fn bad_scenes_are_rejected() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("img.png");
    let good = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/sphere-point.toml"),
    )
    .unwrap();
    let cases = [
        (
            "unknown.toml",
            format!("{good}\nsparkle = true\n"),
            "sparkle",
        ),
        (
            "types.toml",
            good.replacen("effects = [", "effects = 3\nxeffects = [", 1),
            "effects",
        ),
        (
            "missing.toml",
            "effects = [\"direct\"]\n".to_string(),
            "missing",
        ),
        ("syntax.toml", "effects = [\n".to_string(), "TOML"),
    ];
    for (file, text, what) in cases {
        rejects_writing("render", &d.path().join(file), text, &out, what);
    }
}

/// Every text input (a spec, a scene, a model description, a directions CSV, a samples
/// CSV) is read one way (`brdfkit_core::text`): bytes that are not UTF-8 are refused,
/// naming the file, what it was read as and the offset of the first bad byte.
#[test]
fn text_inputs_that_are_not_utf8_name_the_file_and_the_byte() {
    let d = tempfile::tempdir().unwrap();
    let latin1 = |name: &str, start: &str| {
        let p = d.path().join(name);
        std::fs::write(&p, [start.as_bytes(), b"caf\xe9\n"].concat()).unwrap();
        p
    };
    let at = |what: &str, offset: usize| {
        format!("{what} is not valid UTF-8 text (the first invalid byte is at offset {offset})")
    };
    let out = d.path().join("out");
    let spec = latin1("spec.toml", "name = ");
    rejects_writing(
        "synth",
        &spec,
        std::fs::read(&spec).unwrap(),
        &out,
        &at("the spec", 10),
    );
    let scene = latin1("scene.toml", "");
    rejects_writing(
        "render",
        &scene,
        std::fs::read(&scene).unwrap(),
        &d.path().join("img.png"),
        &at("the scene file", 3),
    );
    let dirs = write_file(
        d.path(),
        "dirs.csv",
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n",
    );
    let model = latin1("model.json", "{");
    let eval = [
        "eval".as_ref(),
        "--model".as_ref(),
        model.as_os_str(),
        "--dirs".as_ref(),
        dirs.as_os_str(),
    ];
    rejects(&eval, &model, &at("the model description", 4));
    rejects(
        &["check".as_ref(), model.as_os_str()],
        &model,
        &at("the model description", 4),
    );
    let csv = latin1("pairs.csv", "wi_x,");
    let lambert = lambert_file(d.path(), "l.json", "0.5");
    let eval = [
        "eval".as_ref(),
        "--model".as_ref(),
        lambert.as_os_str(),
        "--dirs".as_ref(),
        csv.as_os_str(),
    ];
    rejects(&eval, &csv, &at("the directions file", 8));
    let samples = latin1("samples.csv", "wi_x,");
    rejects(
        &["fit".as_ref(), "--samples".as_ref(), samples.as_os_str()],
        &samples,
        &at("the samples file", 8),
    );
}
