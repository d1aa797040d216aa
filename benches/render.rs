//! Preview renderer timings (the targets of docs/rendering.md live here, not in tests):
//! a 256 x 256 Cook-Torrance sphere under a point light (target: well under a second),
//! and the same sphere under a constant environment at 16 spp (cost of the MIS
//! estimator per sample). Run: `cargo bench --bench render`.

use brdfkit_render::{Scene, render};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

#[path = "../crates/brdfkit-render/tests/common/mod.rs"]
mod common;

use common::{Camera, film_camera_sphere};

fn scene(effects: &str, light: &str) -> Scene {
    let cam = Camera {
        position: [0.0, 0.0, 4.0],
        look_at: [0.0; 3],
        fov: 40.0,
    };
    let blocks = film_camera_sphere((256, 256), "spp = 16", &cam, [0.0; 3], 1.0);
    let text = format!(
        "effects = [{effects}]\n{blocks}[material]\nmodel = {{ model = \"cook-torrance\", params = \
         {{ rho_d = 0.3, rho_s = 0.5, alpha = 0.2, fresnel = {{ conductor = {{ eta = 0.2, k = 3.0 }} }} }} }}\n{light}"
    );
    Scene::from_toml_str(&text, "bench.toml").expect("bench scene")
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("render_256x256");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    let point = scene(
        "\"direct\"",
        "[[light]]\ntype = \"point\"\nposition = [2, 3, 2]\nintensity = 10\n",
    );
    g.bench_function("point_light_cook_torrance", |b| {
        b.iter(|| render(&point).expect("render"))
    });
    let env = scene(
        "\"environment\"",
        "[environment]\nconstant = [1.0, 1.0, 1.0]\n",
    );
    g.bench_function("constant_environment_16spp", |b| {
        b.iter(|| render(&env).expect("render"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
