//! The renderer: direct light from the declared lights and the environment by
//! multiple importance sampling, and nothing that was not asked for.
//!
//! # What a pixel gets
//!
//! Per pixel, `spp` samples k; sample k looks through camera ray c(k) (the pixel centre
//! for the `center` filter, a uniform point in the pixel for `box`). Where the ray meets
//! an object at x with normal n, viewing direction wo, the sample's value is
//!
//! L = Σ_lights L_light + L_env,
//!
//! with no global illumination (objects reflect only the lights and the environment).
//!
//! - Point light of intensity I (W/sr) at distance r along wi:
//!   L = f_r(wi, wo) · I · cos θi / r²  (V = 1 unless `shadows`).
//! - Directional light of irradiance E (W/m²) travelling along −wi:
//!   L = f_r(wi, wo) · E · cos θi.
//! - Environment, one light sample w_l ~ p_env and one BRDF sample w_b ~ p_brdf, combined
//!   by Veach's multi-sample MIS estimator (Veach & Guibas, SIGGRAPH 1995, eq. 8):
//!
//!   L_env = w_l · f L_e cos θ / p_env (at w_l) + w_b · f L_e cos θ / p_brdf (at w_b),
//!
//!   with the power heuristic w_a = p_a² / (p_a² + p_b²) (or the balance heuristic
//!   p_a / (p_a + p_b)), each p evaluated for the other's sample too. p_env and p_brdf are
//!   [`EnvDistribution`] and [`LobeSampler`]. An all-black environment is not sampled
//!   (BRDF sampling alone, weight 1).
//!
//! With `shadows`, every contribution is multiplied by the visibility V of its direction
//! (a shadow ray towards the light, up to the light for a point light). A convex object
//! cannot occlude itself along a direction above its tangent plane, so a shadow ray is
//! tested against the *other* object only, exactly, with no offset epsilon.
//!
//! Sample positions are stratified per pixel: the `box` filter's camera jitter, the
//! light sample's two dimensions and the BRDF sample's two dimensions each come from a
//! jittered ⌊√spp⌋² grid in shuffled order ([`stratified_2d`]); the cosine/table choice
//! of the lobe sampler is an independent uniform.
//!
//! The pixel is the mean of its samples; its standard error is the sample standard
//! deviation / √spp ([`RenderOutput::std_error`]), which for stratified samples is an
//! upper bound in expectation (stratification only removes variance). Pixels are seeded independently
//! (PCG32 stream = pixel index), so the image is bit-identical for any thread count.
//!
//! # Cost accounting
//!
//! Work runs per row in chunks of pixels and phases (camera rays, direct, environment,
//! shadows); each phase's time is measured once per chunk and summed over threads
//! ([`EffectCost::time`] is worker time, not wall time). A phase whose effect was not
//! requested does not run: its time and counters stay exactly zero.

use crate::env::{EnvDistribution, Environment};
use crate::error::RenderError;
use crate::geometry::Ray;
use crate::output::RenderOutput;
use crate::rng::{Pcg32, stratified_2d};
use crate::sampling::{LobeFrame, LobeSampler};
use crate::scene::{Light, Mis, PixelFilter, Scene};
use crate::stats::{EffectCost, RenderStats};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_core::quadrature::frame_around;
use brdfkit_core::{Rgb, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Per-chunk counters.
#[derive(Clone, Copy, Debug, Default)]
struct Counters {
    camera: EffectCost,
    direct: EffectCost,
    environment: EffectCost,
    shadows: EffectCost,
    table_misses: u64,
}

impl Counters {
    fn merge(mut self, o: Counters) -> Counters {
        self.camera.add(&o.camera);
        self.direct.add(&o.direct);
        self.environment.add(&o.environment);
        self.shadows.add(&o.shadows);
        self.table_misses += o.table_misses;
        self
    }
}

/// Which object a ray met.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Obj {
    Sphere,
    Plane,
}

/// A shading point: position, frame (t, b, n) and the local viewing direction.
#[derive(Clone, Copy, Debug)]
struct Shading {
    p: Vec3,
    t: Vec3,
    b: Vec3,
    n: Vec3,
    wo: Vec3,
    /// wo's node and mirror frame for the lobe sampler: once per point, not per sample.
    lobe: LobeFrame,
    obj: Obj,
    material: usize,
}

impl Shading {
    #[inline]
    fn local(&self, v: &Vec3) -> Vec3 {
        Vec3::new(v.dot(&self.t), v.dot(&self.b), v.dot(&self.n))
    }
    #[inline]
    fn world(&self, v: &Vec3) -> Vec3 {
        v.x * self.t + v.y * self.b + v.z * self.n
    }
}

#[derive(Clone, Copy, Debug)]
enum CamHit {
    /// A front-facing surface point.
    Surface(Shading),
    /// The back of the plane: black, opaque.
    Back,
    /// Nothing: the environment (if shown) along this direction.
    Miss(Vec3),
}

/// A contribution waiting for its visibility test.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    origin: Vec3,
    dir: Vec3,
    t_max: f64,
    from: Obj,
    value: Rgb,
    target: u32,
}

#[derive(Default)]
struct Scratch {
    rngs: Vec<Pcg32>,
    cams: Vec<CamHit>,
    cam_value: Vec<Rgb>,
    values: Vec<Rgb>,
    direct_cands: Vec<Candidate>,
    env_cands: Vec<Candidate>,
    strat_a: Vec<[f64; 2]>,
    strat_b: Vec<[f64; 2]>,
}

struct Ctx<'a> {
    scene: &'a Scene,
    env: Option<(&'a Environment, EnvDistribution)>,
    lobes: Vec<LobeSampler>,
}

impl Ctx<'_> {
    #[inline]
    fn intersect(&self, ray: &Ray) -> CamHit {
        let s = &self.scene;
        let mut best: Option<(f64, Obj)> = None;
        if let Some(sp) = &s.sphere
            && let Some(t) = sp.shape.intersect(ray, f64::INFINITY)
        {
            best = Some((t, Obj::Sphere));
        }
        if let Some(pl) = &s.plane
            && let Some(t) = pl.shape.intersect(ray, best.map_or(f64::INFINITY, |b| b.0))
        {
            best = Some((t, Obj::Plane));
        }
        let Some((t, obj)) = best else {
            return CamHit::Miss(ray.dir);
        };
        let p = ray.origin + t * ray.dir;
        let (n, material) = match obj {
            Obj::Sphere => {
                let sp = s.sphere.as_ref().unwrap();
                (sp.shape.normal_at(&p), sp.material)
            }
            Obj::Plane => {
                let pl = s.plane.as_ref().unwrap();
                (pl.shape.normal, pl.material)
            }
        };
        let (tt, bb) = frame_around(&n);
        let view = -ray.dir;
        let wo = Vec3::new(view.dot(&tt), view.dot(&bb), view.dot(&n));
        if wo.z <= 0.0 {
            // Seen from behind (the plane's back; the sphere only at grazing round-off).
            return CamHit::Back;
        }
        CamHit::Surface(Shading {
            p,
            t: tt,
            b: bb,
            n,
            wo,
            lobe: LobeFrame::of(&wo),
            obj,
            material,
        })
    }

    /// Traces the shadow ray of each candidate: an unblocked one adds its value to
    /// `out[target]`; the rays and the blocked ones are counted in `cost`.
    fn resolve(&self, cands: &[Candidate], cost: &mut EffectCost, out: &mut [Rgb]) {
        for cand in cands {
            cost.samples += 1;
            cost.rays += 1;
            if self.occluded(cand) {
                cost.occluded += 1;
            } else {
                out[cand.target as usize] += cand.value;
            }
        }
    }

    /// Whether the segment from a point on object `from` is blocked by the other object.
    #[inline]
    fn occluded(&self, c: &Candidate) -> bool {
        let ray = Ray {
            origin: c.origin,
            dir: c.dir,
        };
        match c.from {
            Obj::Sphere => self
                .scene
                .plane
                .as_ref()
                .is_some_and(|p| p.shape.intersect(&ray, c.t_max).is_some()),
            Obj::Plane => self
                .scene
                .sphere
                .as_ref()
                .is_some_and(|s| s.shape.intersect(&ray, c.t_max).is_some()),
        }
    }
}

#[inline]
fn mis_weight(mis: Mis, a: f64, b: f64) -> f64 {
    match mis {
        Mis::Balance => a / (a + b),
        Mis::Power => (a * a) / (a * a + b * b),
    }
}

/// Renders `scene`. Only the effects in `scene.effects` are computed.
pub fn render(scene: &Scene) -> Result<RenderOutput, RenderError> {
    render_observed(scene, &())
}

/// [`render`], telling `obs` of every finished row ([`Event::Rows`]: `done` counts the
/// rows finished so far, whichever they are; rows finish in parallel).
pub fn render_observed(scene: &Scene, obs: &dyn Observe) -> Result<RenderOutput, RenderError> {
    let start = Instant::now();
    let film = &scene.film;
    let (w, h, spp) = (film.width, film.height, film.spp);
    let bad = |key: &'static str, message: String| RenderError::Invalid {
        scene: scene.path.clone(),
        key,
        message,
    };
    let max_side = crate::scene::MAX_SIDE as usize;
    if !(1..=max_side).contains(&w) || !(1..=max_side).contains(&h) {
        return Err(bad(
            "film",
            format!("{w} x {h}: each side must be in 1..={max_side}"),
        ));
    }
    if !(1..=crate::scene::MAX_SPP as usize).contains(&spp) {
        return Err(bad(
            "film.spp",
            format!("must be in 1..={}, got {spp}", crate::scene::MAX_SPP),
        ));
    }
    if !film.exposure.is_finite() {
        return Err(bad("film.exposure", "must be finite".into()));
    }
    if scene.sphere.is_none() && scene.plane.is_none() {
        return Err(bad("sphere", "the scene has no object".into()));
    }
    let n_mat = scene.materials.len();
    if scene.sphere.as_ref().is_some_and(|o| o.material >= n_mat)
        || scene.plane.as_ref().is_some_and(|o| o.material >= n_mat)
    {
        return Err(bad(
            "material",
            format!("an object refers to material {n_mat} or beyond; there are {n_mat}"),
        ));
    }
    if scene.effects.environment && scene.environment.is_none() {
        return Err(bad(
            "environment",
            "the environment effect is on but there is no environment".into(),
        ));
    }
    let fx = scene.effects;

    // Environment setup: only when asked for.
    let mut env_setup = EffectCost::default();
    let mut ctx = Ctx {
        scene,
        env: None,
        lobes: Vec::new(),
    };
    if fx.environment {
        let t0 = Instant::now();
        if let Some(env) = scene.environment.as_ref() {
            ctx.env = Some((env, EnvDistribution::build(env)));
        }
        ctx.lobes = scene.materials.par_iter().map(LobeSampler::build).collect();
        env_setup.setup = t0.elapsed();
        env_setup.setup_evals = ctx.lobes.iter().map(|l| l.build_evaluations).sum();
    }

    // With the centre filter and no environment every sample of a pixel would repeat
    // the same deterministic computation: one is enough.
    let spp = if film.filter == PixelFilter::Center && !fx.environment {
        1
    } else {
        spp
    };
    let n_cam = match film.filter {
        PixelFilter::Center => 1,
        PixelFilter::Box => spp,
    };
    // Pixels per chunk: enough work per phase (≥ 4096 samples, or one pixel when spp
    // alone exceeds that) that timing it costs nothing, and never more than a row.
    let chunk_px = (4096 / spp).clamp(1, w);

    let mut radiance = vec![Rgb::ZERO; w * h];
    let mut std_error = vec![Rgb::ZERO; w * h];
    let loop_start = Instant::now();
    let rows_done = AtomicUsize::new(0);
    let counters = radiance
        .par_chunks_mut(w)
        .zip(std_error.par_chunks_mut(w))
        .enumerate()
        .map_init(Scratch::default, |scratch, (y, (rad_row, se_row))| {
            let mut c = Counters::default();
            let mut x0 = 0;
            while x0 < w {
                let x1 = (x0 + chunk_px).min(w);
                let ch = Chunk {
                    y,
                    x0,
                    x1,
                    spp,
                    n_cam,
                };
                render_chunk(&ctx, &ch, scratch, &mut c, rad_row, se_row);
                x0 = x1;
            }
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            obs.observe(&Event::Rows { done, total: h });
            c
        })
        .reduce(Counters::default, Counters::merge);
    let loop_wall = loop_start.elapsed();

    for (i, v) in radiance.iter().enumerate() {
        if !v.is_finite() {
            return Err(RenderError::NonFinite {
                scene: scene.path.clone(),
                x: i % w,
                y: i / w,
                value: v.0,
            });
        }
    }

    let mut stats = RenderStats {
        camera: counters.camera,
        direct: counters.direct,
        environment: counters.environment,
        shadows: counters.shadows,
        table_misses: counters.table_misses,
        wall: Duration::ZERO,
        loop_wall,
        threads: rayon::current_num_threads(),
    };
    stats.camera.requested = true;
    stats.direct.requested = fx.direct;
    stats.environment.requested = fx.environment;
    stats.environment.setup = env_setup.setup;
    stats.environment.setup_evals = env_setup.setup_evals;
    stats.shadows.requested = fx.shadows;
    stats.wall = start.elapsed();
    Ok(RenderOutput {
        width: w,
        height: h,
        spp,
        radiance,
        std_error,
        exposure: film.exposure,
        stats,
    })
}

/// The pixels `x0..x1` of row `y` that one call of [`render_chunk`] renders, with the
/// sample counts they share. Grouped so each phase takes one argument, not five.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    y: usize,
    x0: usize,
    x1: usize,
    spp: usize,
    /// Camera rays per pixel: 1 for the centre filter (shared by every sample), `spp`
    /// for the box filter.
    n_cam: usize,
}

impl Chunk {
    #[inline]
    fn pixels(&self) -> usize {
        self.x1 - self.x0
    }

    /// The camera ray that sample `k` of pixel `p` looks through.
    #[inline]
    fn cam_of(&self, p: usize, k: usize) -> usize {
        if self.n_cam == 1 { p } else { p * self.spp + k }
    }
}

/// Renders one chunk of a row: the phases run in turn over all of the chunk's pixels
/// (rather than all phases per pixel) so that each phase is timed once per chunk, and
/// their sum is written to `rad_row` / `se_row`.
fn render_chunk(
    ctx: &Ctx,
    ch: &Chunk,
    s: &mut Scratch,
    c: &mut Counters,
    rad_row: &mut [Rgb],
    se_row: &mut [Rgb],
) {
    let fx = ctx.scene.effects;
    camera_phase(ctx, ch, s, &mut c.camera);
    s.direct_cands.clear();
    if fx.direct {
        direct_phase(ctx, s, c);
    }
    s.env_cands.clear();
    if let Some((env, dist)) = &ctx.env {
        let es = EnvSampler { ctx, env, dist };
        environment_phase(&es, ch, s, c);
    }
    if fx.shadows {
        let t0 = Instant::now();
        let sc = &mut c.shadows;
        ctx.resolve(&s.direct_cands, sc, &mut s.cam_value);
        ctx.resolve(&s.env_cands, sc, &mut s.values);
        sc.time += t0.elapsed();
    }
    let t0 = Instant::now();
    pixel_estimates(ch, s, rad_row, se_row);
    // Part of the camera phase's bookkeeping.
    c.camera.time += t0.elapsed();
}

/// Seeds each pixel's generator and traces its camera rays into `s.cams`, then sizes
/// the per-ray and per-sample accumulators the later phases add into.
fn camera_phase(ctx: &Ctx, ch: &Chunk, s: &mut Scratch, cost: &mut EffectCost) {
    let scene = ctx.scene;
    let film = &scene.film;
    let t0 = Instant::now();
    s.rngs.clear();
    s.cams.clear();
    for x in ch.x0..ch.x1 {
        let mut rng = Pcg32::for_pixel(film.seed, (ch.y * film.width + x) as u64);
        match film.filter {
            PixelFilter::Center => {
                let ray = scene.camera.ray(x as f64 + 0.5, ch.y as f64 + 0.5);
                s.cams.push(ctx.intersect(&ray));
            }
            PixelFilter::Box => {
                stratified_2d(&mut rng, ch.n_cam, &mut s.strat_a);
                for j in &s.strat_a {
                    let ray = scene.camera.ray(x as f64 + j[0], ch.y as f64 + j[1]);
                    s.cams.push(ctx.intersect(&ray));
                }
            }
        }
        s.rngs.push(rng);
    }
    s.cam_value.clear();
    s.cam_value.resize(s.cams.len(), Rgb::ZERO);
    s.values.clear();
    s.values.resize(ch.pixels() * ch.spp, Rgb::ZERO);
    let rays = (ch.pixels() * ch.n_cam) as u64;
    cost.samples += rays;
    cost.rays += rays;
    cost.time += t0.elapsed();
}

/// Direct light, once per camera ray (every sample of a ray sees the same lights):
/// L = f_r · I cos θi / r² for a point light, f_r · E cos θi for a directional one.
/// With shadows the contribution waits in `s.direct_cands` for its visibility test.
fn direct_phase(ctx: &Ctx, s: &mut Scratch, c: &mut Counters) {
    let scene = ctx.scene;
    let shadows = scene.effects.shadows;
    let t0 = Instant::now();
    let d = &mut c.direct;
    for (ci, cam) in s.cams.iter().enumerate() {
        let CamHit::Surface(sh) = cam else { continue };
        let mat = &scene.materials[sh.material];
        for light in &scene.lights {
            d.samples += 1;
            let (dir, t_max, scale) = light_towards(light, &sh.p);
            let wi = sh.local(&dir);
            if wi.z <= 0.0 {
                continue;
            }
            d.brdf_evals += 1;
            let (f, miss) = mat.eval(&wi, &sh.wo);
            c.table_misses += miss as u64;
            let value = f * scale * wi.z;
            if value.max_channel() <= 0.0 && value.is_finite() {
                continue;
            }
            if shadows {
                s.direct_cands.push(Candidate {
                    origin: sh.p,
                    dir,
                    t_max,
                    from: sh.obj,
                    value,
                    target: ci as u32,
                });
            } else {
                s.cam_value[ci] += value;
            }
        }
    }
    d.time += t0.elapsed();
}

/// The world direction from `p` towards `light`, the distance a shadow ray must stay
/// clear for, and the light's arriving radiometric scale (I / r² for a point light,
/// E for a directional one).
#[inline]
fn light_towards(light: &Light, p: &Vec3) -> (Vec3, f64, Rgb) {
    match light {
        Light::Point {
            position,
            intensity,
        } => {
            let to = position - p;
            let r2 = to.norm_squared();
            let r = r2.sqrt();
            (to / r, r, *intensity / r2)
        }
        Light::Directional {
            direction,
            irradiance,
        } => (-direction, f64::INFINITY, *irradiance),
    }
}

/// The environment: the camera rays that miss see it (if shown), and every surface
/// sample takes one light and one BRDF sample combined by MIS
/// ([`EnvSampler::light_sample`], [`EnvSampler::brdf_sample`]).
fn environment_phase(es: &EnvSampler, ch: &Chunk, s: &mut Scratch, c: &mut Counters) {
    let t0 = Instant::now();
    if es.ctx.scene.film.show_environment {
        for (ci, cam) in s.cams.iter().enumerate() {
            if let CamHit::Miss(dir) = cam {
                c.environment.lookups += 1;
                s.cam_value[ci] += es.env.radiance(dir);
            }
        }
    }
    let mut sink = Sink {
        shadows: es.ctx.scene.effects.shadows,
        cands: &mut s.env_cands,
        values: &mut s.values,
    };
    for p in 0..ch.pixels() {
        let rng = &mut s.rngs[p];
        // Stratified light and BRDF sample positions over the pixel's samples.
        stratified_2d(rng, ch.spp, &mut s.strat_a);
        stratified_2d(rng, ch.spp, &mut s.strat_b);
        for k in 0..ch.spp {
            let CamHit::Surface(sh) = &s.cams[ch.cam_of(p, k)] else {
                continue;
            };
            let target = (p * ch.spp + k) as u32;
            es.light_sample(sh, target, s.strat_a[k], &mut sink, c);
            let pick = rng.uniform();
            es.brdf_sample(sh, target, pick, s.strat_b[k], &mut sink, c);
        }
    }
    c.environment.time += t0.elapsed();
}

/// The environment with its importance-sampling distribution, and the scene it lights:
/// what the two MIS estimators of a surface sample share.
struct EnvSampler<'a> {
    ctx: &'a Ctx<'a>,
    env: &'a Environment,
    dist: &'a EnvDistribution,
}

impl EnvSampler<'_> {
    /// The light-sampling half of Veach's multi-sample estimator (Veach & Guibas 1995,
    /// eq. 8): w_l · f L_e cos θ / p_env at w_l ~ p_env.
    #[inline]
    fn light_sample(
        &self,
        sh: &Shading,
        target: u32,
        u: [f64; 2],
        sink: &mut Sink,
        c: &mut Counters,
    ) {
        let Some(ls) = self.dist.sample(self.env, u) else {
            return;
        };
        let e = &mut c.environment;
        e.samples += 1;
        e.lookups += 1;
        let wi = sh.local(&ls.dir);
        if wi.z > 0.0 {
            e.brdf_evals += 1;
            let (f, miss) = self.ctx.scene.materials[sh.material].eval(&wi, &sh.wo);
            c.table_misses += miss as u64;
            let lobe = &self.ctx.lobes[sh.material];
            let wgt = mis_weight(self.ctx.scene.film.mis, ls.pdf, lobe.pdf_in(&wi, &sh.lobe));
            let value = f * ls.radiance * (wi.z * wgt / ls.pdf);
            sink.push(sh, ls.dir, value, target);
        }
    }

    /// The BRDF-sampling half: w_b · f L_e cos θ / p_brdf at w_b ~ p_brdf, with weight 1
    /// when the environment cannot be sampled (all black).
    #[inline]
    fn brdf_sample(
        &self,
        sh: &Shading,
        target: u32,
        pick: f64,
        u: [f64; 2],
        sink: &mut Sink,
        c: &mut Counters,
    ) {
        let bs = self.ctx.lobes[sh.material].sample_in(&sh.lobe, pick, u);
        let e = &mut c.environment;
        e.samples += 1;
        if !(bs.wi.z > 0.0 && bs.pdf > 0.0) {
            return;
        }
        let dir = sh.world(&bs.wi);
        e.lookups += 1;
        let (le, env_pdf) = self.dist.radiance_and_pdf(self.env, &dir);
        if le.max_channel() > 0.0 {
            e.brdf_evals += 1;
            let (f, miss) = self.ctx.scene.materials[sh.material].eval(&bs.wi, &sh.wo);
            c.table_misses += miss as u64;
            let wgt = if self.dist.can_sample() {
                mis_weight(self.ctx.scene.film.mis, bs.pdf, env_pdf)
            } else {
                1.0
            };
            let value = f * le * (bs.wi.z * wgt / bs.pdf);
            sink.push(sh, dir, value, target);
        }
    }
}

/// Where an environment contribution goes: straight into its sample's value, or, with
/// shadows, into the candidates that wait for their visibility test.
struct Sink<'a> {
    shadows: bool,
    cands: &'a mut Vec<Candidate>,
    values: &'a mut [Rgb],
}

impl Sink<'_> {
    #[inline]
    fn push(&mut self, sh: &Shading, dir: Vec3, value: Rgb, target: u32) {
        if self.shadows {
            self.cands.push(Candidate {
                origin: sh.p,
                dir,
                t_max: f64::INFINITY,
                from: sh.obj,
                value,
                target,
            });
        } else {
            self.values[target as usize] += value;
        }
    }
}

/// Each pixel's mean over its samples (direct light per camera ray plus environment per
/// sample), and its standard error: sqrt(Σ (x_k − mean)² / (n (n − 1))), the two-pass
/// unbiased sample variance over n, exactly zero when all samples agree.
fn pixel_estimates(ch: &Chunk, s: &Scratch, rad_row: &mut [Rgb], se_row: &mut [Rgb]) {
    let spp = ch.spp;
    let n = spp as f64;
    for p in 0..ch.pixels() {
        let sample = |k: usize| s.values[p * spp + k] + s.cam_value[ch.cam_of(p, k)];
        let mut sum = Rgb::ZERO;
        for k in 0..spp {
            sum += sample(k);
        }
        let mean = sum / n;
        rad_row[ch.x0 + p] = mean;
        se_row[ch.x0 + p] = if spp > 1 {
            let mut ss = Rgb::ZERO;
            for k in 0..spp {
                let d = sample(k) - mean;
                ss += d * d;
            }
            (ss / (n * (n - 1.0))).map(f64::sqrt)
        } else {
            Rgb::ZERO
        };
    }
}
