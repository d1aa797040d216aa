//! Renders a scene file and writes `<out>.exr` (linear) and `<out>.png` (sRGB), printing
//! the per-effect cost. Optionally writes the raw float32 radiance (row-major RGB) for
//! comparisons: `render SCENE.toml OUT [RAW.f32]`.

use brdfkit_render::{Scene, render};
use std::io::Write;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: render SCENE.toml OUT_PREFIX [RAW.f32]");
        std::process::exit(2);
    }
    let scene = match Scene::read(&args[1]) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let out = match render(&scene) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    println!("{}", out.stats);
    let prefix = &args[2];
    for r in [
        out.write_exr(format!("{prefix}.exr")),
        out.write_png(format!("{prefix}.png")),
    ] {
        if let Err(e) = r {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
    if let Some(raw) = args.get(3) {
        let mut f = std::fs::File::create(raw).expect("creating the raw file");
        for c in &out.radiance {
            for v in c.0 {
                f.write_all(&(v as f32).to_le_bytes()).unwrap();
            }
        }
    }
}
