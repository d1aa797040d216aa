//! Every example scene under `examples/scenes/` reads and renders (downsized), and the
//! effects it declares are exactly the ones that cost something.

use brdfkit_render::{Effect, Scene, render};
use std::path::Path;

#[test]
fn example_scenes_read_and_render() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let mut s = Scene::read(&path).unwrap_or_else(|e| panic!("{e}"));
        s.set_resolution(48, 40).unwrap();
        s.film.spp = s.film.spp.min(8);
        let out = render(&s).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            out.radiance
                .iter()
                .filter(|c| c.max_channel() > 0.0)
                .count()
                > 100,
            "{}: nearly black",
            path.display()
        );
        for e in Effect::ALL {
            let c = out.stats.effect(e);
            assert_eq!(c.requested, s.effects.has(e));
            assert_eq!(c.is_zero(), !s.effects.has(e), "{}: {e}", path.display());
        }
        n += 1;
    }
    assert!(n >= 2, "expected at least two example scenes, found {n}");
}

#[test]
fn set_resolution_keeps_the_horizontal_field_of_view() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes");
    let s = Scene::read(dir.join("sphere-point.toml")).unwrap();
    let mut small = s.clone();
    small.set_resolution(64, 32).unwrap();
    // Left-edge centre ray is the same direction at any size with the same fov.
    let a = s.camera.ray(0.0, 128.0).dir;
    let b = small.camera.ray(0.0, 16.0).dir;
    assert!((a - b).norm() < 1e-12);
    assert!(small.clone().set_resolution(0, 10).is_err());
}
