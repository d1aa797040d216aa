//! Bad scene files: each gives a typed error that names the scene file, the key and the
//! problem (and the referenced file when one is at fault). Never a panic.

use brdfkit_render::{Scene, SceneError};
use std::path::Path;

const GOOD: &str = r#"effects = ["direct"]
[film]
width = 8
height = 6
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
[sphere]
center = [0, 0, 0]
radius = 1
[material]
model = { model = "lambert", params = { rho_d = 0.5 } }
[[light]]
type = "point"
position = [2, 2, 2]
intensity = 10
"#;

/// Writes `text` as bad.toml in a temp dir (with `files` beside it) and reads it.
/// Reads `text` as a scene file beside `files`, which must be rejected with an error
/// that starts with the scene's path and holds each of `words`.
fn rejected(text: &str, files: &[(&str, &[u8])], words: &[&str]) -> SceneError {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text).unwrap();
    let e = Scene::read(&path).expect_err("the scene must be rejected");
    let msg = e.to_string();
    assert!(
        msg.starts_with(&path.display().to_string()),
        "no scene path in: {msg}"
    );
    assert_eq!(e.scene_path(), path.as_path());
    for w in words {
        assert!(msg.contains(w), "`{w}` not in: {msg}");
    }
    e
}

fn edit(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from}");
    GOOD.replacen(from, to, 1)
}

fn assert_invalid(text: &str, key: &str, words: &str) {
    let e = rejected(text, &[], &[words]);
    assert!(
        matches!(&e, SceneError::Invalid { key: k, .. } if k == key),
        "expected Invalid at `{key}`, got: {e}"
    );
}

/// [`assert_invalid`] of the good scene with `from` replaced by `to`.
fn invalid_after(from: &str, to: &str, key: &str, words: &str) {
    assert_invalid(&edit(from, to), key, words);
}

/// [`assert_syntax`] of the good scene with `from` replaced by `to`.
fn syntax_after(from: &str, to: &str, words: &[&str]) {
    assert_syntax(&edit(from, to), words);
}

fn assert_syntax(text: &str, words: &[&str]) {
    let e = rejected(text, &[], words);
    assert!(
        matches!(e, SceneError::Syntax { .. }),
        "expected Syntax, got: {e}"
    );
}

#[test]
fn the_good_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("good.toml");
    std::fs::write(&p, GOOD).unwrap();
    Scene::read(&p).unwrap();
}

#[test]
fn a_missing_scene_file_is_a_read_error() {
    let e = Scene::read("/nonexistent/dir/scene.toml").unwrap_err();
    assert!(matches!(e, SceneError::Read(_)));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/dir/scene.toml: cannot read")
    );
}

#[test]
fn unknown_keys_are_rejected_with_their_name() {
    assert_syntax(
        &format!("samples = 3\n{GOOD}"),
        &["unknown field `samples`"],
    );
    // The same key after [[light]] belongs to the light.
    assert_invalid(
        &format!("{GOOD}samples = 3\n"),
        "light[0]",
        "unknown field `samples`",
    );
    syntax_after(
        "fov = 40",
        "fov = 40\nfovv = 3",
        &["unknown field `fovv`", "fov"],
    );
    syntax_after(
        "radius = 1",
        "radius = 1\ncolour = 3",
        &["unknown field `colour`"],
    );
    syntax_after(
        "rho_d = 0.5 } }",
        "rho_d = 0.5 } }\nlookups = \"nearest\"",
        &["unknown field `lookups`"],
    );
    syntax_after(
        "effects = [\"direct\"]",
        "effects = [\"direct\", \"gi\"]",
        &["unknown variant `gi`"],
    );
    invalid_after(
        "intensity = 10",
        "intensity = 10\nradius = 2",
        "light[0]",
        "unknown field `radius`",
    );
    invalid_after(
        "type = \"point\"",
        "type = \"spot\"",
        "light[0].type",
        "unknown light type `spot`",
    );
    invalid_after(
        "type = \"point\"\n",
        "",
        "light[0].type",
        "missing field `type`",
    );
}

#[test]
fn wrong_types_are_rejected() {
    syntax_after("width = 8", "width = \"big\"", &["width", "invalid type"]);
    syntax_after("fov = 40", "fov = [40]", &["fov", "invalid type"]);
    syntax_after("center = [0, 0, 0]", "center = [0, 0]", &["center"]);
    syntax_after(
        "effects = [\"direct\"]",
        "effects = \"direct\"",
        &["effects"],
    );
    invalid_after(
        "intensity = 10",
        "intensity = [1, 2]",
        "light[0]",
        "3 numbers",
    );
    invalid_after(
        "intensity = 10",
        "intensity = \"bright\"",
        "light[0]",
        "a number or an [r, g, b]",
    );
    invalid_after(
        "type = \"point\"",
        "type = 3",
        "light[0].type",
        "must be a string",
    );
    invalid_after(
        "model = { model = \"lambert\", params = { rho_d = 0.5 } }",
        "model = 3",
        "material.model",
        "must be a path to a model JSON file or an inline table",
    );
}

#[test]
fn missing_fields_are_rejected() {
    syntax_after("fov = 40\n", "", &["missing field `fov`"]);
    syntax_after("width = 8\n", "", &["missing field `width`"]);
    syntax_after("radius = 1\n", "", &["missing field `radius`"]);
    invalid_after(
        "intensity = 10\n",
        "",
        "light[0]",
        "missing field `intensity`",
    );
    let no_material = edit(
        "[material]\nmodel = { model = \"lambert\", params = { rho_d = 0.5 } }\n",
        "",
    );
    assert_invalid(&no_material, "sphere.material", "no material");
    let no_object = edit("[sphere]\ncenter = [0, 0, 0]\nradius = 1\n", "");
    assert_invalid(&no_object, "sphere", "no object");
}

#[test]
fn out_of_domain_values_are_rejected_with_the_value() {
    invalid_after("fov = 40", "fov = 200", "camera.fov", "got 200");
    invalid_after("fov = 40", "fov = 0", "camera.fov", "(0, 180)");
    invalid_after("width = 8", "width = 0", "film.width", "got 0");
    invalid_after("height = 6", "height = 100000", "film.height", "got 100000");
    invalid_after("width = 8", "width = 8\nspp = 0", "film.spp", "got 0");
    invalid_after(
        "width = 8",
        "width = 8\nexposure = inf",
        "film.exposure",
        "finite",
    );
    invalid_after("radius = 1", "radius = -1", "sphere.radius", "got -1");
    invalid_after(
        "intensity = 10",
        "intensity = -1",
        "light[0].intensity",
        "non-negative",
    );
    invalid_after(
        "intensity = 10",
        "intensity = [1, nan, 1]",
        "light[0].intensity",
        "finite",
    );
    invalid_after(
        "position = [0, 0, 4]",
        "position = [0, 0, 0.5]",
        "camera.position",
        "inside the sphere",
    );
    invalid_after(
        "position = [2, 2, 2]",
        "position = [0, 0.5, 0]",
        "light[0].position",
        "inside the sphere",
    );
    invalid_after(
        "look_at = [0, 0, 0]",
        "look_at = [0, 0, 4]",
        "camera.look_at",
        "equals",
    );
    invalid_after(
        "fov = 40",
        "fov = 40\nup = [0, 0, 1]",
        "camera.up",
        "parallel",
    );
    invalid_after(
        "fov = 40",
        "fov = 40\nup = [0, 0, 0]",
        "camera.up",
        "non-zero",
    );
    invalid_after(
        "effects = [\"direct\"]",
        "effects = [\"direct\", \"direct\"]",
        "effects",
        "listed twice",
    );
    let env = edit(
        "effects = [\"direct\"]",
        "effects = [\"direct\", \"environment\"]",
    );
    assert_invalid(
        &format!("{env}[environment]\nconstant = -1\n"),
        "environment.constant",
        "non-negative",
    );
    assert_invalid(
        &format!("{env}[environment]\nconstant = 1\nscale = -2\n"),
        "environment.scale",
        "got -2",
    );
    assert_invalid(
        &format!("{env}[environment]\n"),
        "environment",
        "needs `constant`",
    );
    assert_invalid(
        &format!("{env}[environment]\nconstant = 1\nfile = \"a.exr\"\n"),
        "environment",
        "not both",
    );
    // A model parameter outside its domain: the model crate's error, with the key.
    let e = rejected(
        &edit("rho_d = 0.5", "rho_d = 2"),
        &[],
        &["rho_d", "outside its domain"],
    );
    assert!(
        matches!(&e, SceneError::Model { key, .. } if key == "material.model"),
        "{e}"
    );
    let lambertian = edit("model = \"lambert\"", "model = \"lambertian\"");
    let e = rejected(&lambertian, &[], &["unknown model `lambertian`"]);
    assert!(matches!(e, SceneError::Model { .. }), "{e}");
}

#[test]
fn contradictory_material_keys_are_rejected() {
    let both = edit("rho_d = 0.5 } }", "rho_d = 0.5 } }\ntable = \"x.binary\"");
    assert_invalid(&both, "material", "not both");
    let lookup = edit("rho_d = 0.5 } }", "rho_d = 0.5 } }\nlookup = \"nearest\"");
    assert_invalid(&lookup, "material.lookup", "applies to a `table` only");
    syntax_after(
        "model = { model = \"lambert\", params = { rho_d = 0.5 } }",
        "table = \"x.binary\"\nlookup = \"cubic\"",
        &["unknown variant `cubic`"],
    );
}

#[test]
fn missing_and_broken_referenced_files_name_the_file() {
    let by_path = |p: &str| {
        edit(
            "model = { model = \"lambert\", params = { rho_d = 0.5 } }",
            &format!("model = \"{p}\""),
        )
    };
    let e = rejected(&by_path("nope.json"), &[], &["nope.json", "cannot read"]);
    assert!(
        matches!(&e, SceneError::File { key, .. } if key == "material.model"),
        "{e}"
    );

    let broken: &[u8] = b"{\"model\": ";
    let e = rejected(
        &by_path("m.json"),
        &[("m.json", broken)],
        &["m.json", "not valid JSON"],
    );
    assert!(matches!(e, SceneError::ModelJson { .. }), "{e}");

    let unknown_key: &[u8] = br#"{"model":"lambert","params":{"rho":0.5}}"#;
    let e = rejected(
        &by_path("m.json"),
        &[("m.json", unknown_key)],
        &["m.json", "rho"],
    );
    assert!(
        matches!(&e, SceneError::Model { file: Some(f), .. } if f.ends_with("m.json")),
        "{e}"
    );

    let table = edit(
        "model = { model = \"lambert\", params = { rho_d = 0.5 } }",
        "table = \"nope.binary\"",
    );
    let e = rejected(&table, &[], &["nope.binary"]);
    assert!(matches!(e, SceneError::Table { .. }), "{e}");
    let e = rejected(
        &table.replace("nope.binary", "short.binary"),
        &[("short.binary", b"12345")],
        &["short.binary", "shorter than the 12-byte header"],
    );
    assert!(matches!(e, SceneError::Table { .. }), "{e}");

    let env = edit(
        "effects = [\"direct\"]",
        "effects = [\"direct\", \"environment\"]",
    );
    let sky = |name: &str| format!("{env}[environment]\nfile = \"{name}\"\n");
    let e = rejected(&sky("sky.exr"), &[], &["sky.exr"]);
    assert!(
        matches!(&e, SceneError::File { key, .. } if key == "environment.file"),
        "{e}"
    );
    let e = rejected(
        &sky("sky.png"),
        &[("sky.png", b"not an image")],
        &["sky.png"],
    );
    assert!(matches!(e, SceneError::Image { .. }), "{e}");
}

#[test]
fn an_environment_with_negative_texels_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::Rgb32FImage::from_fn(4, 2, |x, y| {
        if (x, y) == (3, 1) {
            image::Rgb([0.5, -1.0, 0.5])
        } else {
            image::Rgb([1.0; 3])
        }
    });
    img.save(dir.path().join("neg.exr")).unwrap();
    let bytes = std::fs::read(dir.path().join("neg.exr")).unwrap();
    let env = edit(
        "effects = [\"direct\"]",
        "effects = [\"direct\", \"environment\"]",
    );
    let e = rejected(
        &format!("{env}[environment]\nfile = \"neg.exr\"\n"),
        &[("neg.exr", &bytes)],
        &["texel (3, 1)", "non-negative"],
    );
    assert!(matches!(e, SceneError::Image { .. }), "{e}");
}

#[test]
fn relative_paths_are_relative_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(
        dir.path().join("sub/m.json"),
        br#"{"model":"lambert","params":{"rho_d":0.25}}"#,
    )
    .unwrap();
    let text = edit(
        "model = { model = \"lambert\", params = { rho_d = 0.5 } }",
        "model = \"m.json\"",
    );
    let p = dir.path().join("sub/scene.toml");
    std::fs::write(&p, text).unwrap();
    // Read from elsewhere: the JSON is found beside the scene, not in the cwd.
    assert!(!Path::new("m.json").exists());
    Scene::read(&p).unwrap();
}
