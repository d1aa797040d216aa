//! `fit-brdf render SCENE.toml --out IMAGE`: the scene-driven preview renderer.

use crate::cli::RenderArgs;
use crate::error::{CliResult, bad_input, bad_msg, runtime};
use brdfkit_render::{Scene, render_observed};
use std::path::Path;

fn extension(p: &Path) -> String {
    p.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

pub fn run(a: RenderArgs) -> CliResult<()> {
    let out_ext = extension(&a.out);
    if out_ext != "png" && out_ext != "exr" {
        return Err(bad_msg(format!(
            "{}: unknown image format `{out_ext}`, expected .png or .exr",
            a.out.display()
        )));
    }
    if let Some(e) = &a.exr
        && extension(e) != "exr"
    {
        return Err(bad_msg(format!(
            "{}: --exr expects a .exr path",
            e.display()
        )));
    }
    let mut scene = Scene::read(&a.scene).map_err(bad_input)?;
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(bad_msg("--spp must be at least 1"));
        }
        scene.film.spp = spp;
    }
    if let Some(size) = &a.size {
        let parsed = size.split_once('x').and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        });
        let (w, h) = parsed.ok_or_else(|| {
            bad_msg(format!(
                "--size `{size}`: expected WIDTHxHEIGHT, e.g. 256x256"
            ))
        })?;
        scene.set_resolution(w, h).map_err(bad_input)?;
    }
    let progress = crate::progress::Progress::new(a.quiet);
    let out = render_observed(&scene, &progress);
    progress.finish();
    let out = out.map_err(bad_input)?;
    if out_ext == "png" {
        out.write_png(&a.out).map_err(runtime)?;
    } else {
        out.write_exr(&a.out).map_err(runtime)?;
    }
    if let Some(e) = &a.exr {
        out.write_exr(e).map_err(runtime)?;
    }
    if a.json {
        crate::output::write_text(None, &(stats_json(&out) + "\n"))?;
    }
    if !a.quiet {
        eprintln!(
            "rendered {} ({} x {}, {} spp) -> {}",
            a.scene.display(),
            out.width,
            out.height,
            out.spp,
            a.out.display()
        );
        eprintln!("{}", out.stats);
    }
    Ok(())
}

/// The per-effect cost as JSON (times in seconds).
fn stats_json(out: &brdfkit_render::RenderOutput) -> String {
    let s = &out.stats;
    let effect = |c: &brdfkit_render::EffectCost| {
        serde_json::json!({
            "requested": c.requested,
            "setup_s": c.setup.as_secs_f64(),
            "setup_evals": c.setup_evals,
            "thread_time_s": c.time.as_secs_f64(),
            "wall_share_s": s.wall_share(c).as_secs_f64(),
            "samples": c.samples,
            "brdf_evals": c.brdf_evals,
            "rays": c.rays,
            "lookups": c.lookups,
        })
    };
    serde_json::to_string_pretty(&serde_json::json!({
        "width": out.width,
        "height": out.height,
        "spp": out.spp,
        "threads": s.threads,
        "wall_s": s.wall.as_secs_f64(),
        "table_misses": s.table_misses,
        "effects": {
            "camera": effect(&s.camera),
            "direct": effect(&s.direct),
            "environment": effect(&s.environment),
            "shadows": effect(&s.shadows),
        },
    }))
    .expect("JSON of numbers")
}
