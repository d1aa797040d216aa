//! What a render cost, per effect: the figures `fit-brdf render` prints and
//! [`RenderOutput::stats`](crate::RenderOutput::stats) carries. Its own module so the
//! image ([`crate::output`]) and the renderer ([`mod@crate::render`]) both use it without
//! depending on each other.

use crate::scene::Effect;
use std::fmt;
use std::time::Duration;

/// The cost of one effect (or of the camera rays).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EffectCost {
    /// Whether the scene asked for it (camera rays: always).
    pub requested: bool,
    /// Wall time of its precomputation (environment: sampling distribution and the
    /// BRDF lobe tables).
    pub setup: Duration,
    /// BRDF evaluations spent in the precomputation.
    pub setup_evals: u64,
    /// Worker time of its phases, summed over threads.
    pub time: Duration,
    /// Camera: camera samples. Direct: (hit, light) pairs. Environment: light samples
    /// plus BRDF samples drawn. Shadows: directions tested.
    pub samples: u64,
    /// BRDF evaluations during the render.
    pub brdf_evals: u64,
    /// Rays traced: camera rays, or shadow rays.
    pub rays: u64,
    /// Environment radiance lookups (environment: samples and background pixels).
    pub lookups: u64,
    /// Shadows: shadow rays that hit an occluder.
    pub occluded: u64,
}

impl EffectCost {
    pub(crate) fn add(&mut self, o: &EffectCost) {
        self.time += o.time;
        self.samples += o.samples;
        self.brdf_evals += o.brdf_evals;
        self.rays += o.rays;
        self.lookups += o.lookups;
        self.occluded += o.occluded;
    }

    /// True when nothing at all was spent (time and every counter zero).
    pub fn is_zero(&self) -> bool {
        self.setup.is_zero()
            && self.setup_evals == 0
            && self.time.is_zero()
            && self.samples == 0
            && self.brdf_evals == 0
            && self.rays == 0
            && self.lookups == 0
            && self.occluded == 0
    }
}

/// What a render cost, per effect.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Camera rays (always computed).
    pub camera: EffectCost,
    /// Direct light.
    pub direct: EffectCost,
    /// Environment light.
    pub environment: EffectCost,
    /// Shadow rays.
    pub shadows: EffectCost,
    /// Table lookups that found no sample (missing cells), rendered as zero.
    pub table_misses: u64,
    /// Wall time of the whole render, setup included.
    pub wall: Duration,
    /// Wall time of the pixel loop alone (setup excluded).
    pub loop_wall: Duration,
    /// Worker threads.
    pub threads: usize,
}

impl RenderStats {
    /// The cost of `effect`.
    pub fn effect(&self, effect: Effect) -> &EffectCost {
        match effect {
            Effect::Direct => &self.direct,
            Effect::Environment => &self.environment,
            Effect::Shadows => &self.shadows,
        }
    }

    /// The wall time attributed to `c` (one of this report's costs): its setup plus the
    /// pixel loop's wall time split in proportion to the thread time of each phase.
    /// An attribution, not a separate measurement (the phases run interleaved on every
    /// thread); exactly zero for an effect that did not run.
    pub fn wall_share(&self, c: &EffectCost) -> Duration {
        let total = self.camera.time + self.direct.time + self.environment.time + self.shadows.time;
        if total.is_zero() {
            return c.setup;
        }
        c.setup
            + self
                .loop_wall
                .mul_f64(c.time.as_secs_f64() / total.as_secs_f64())
    }
}

impl fmt::Display for RenderStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<12} {:>9} {:>10} {:>11} {:>13} {:>12} {:>12} {:>12} {:>11}",
            "effect",
            "requested",
            "setup ms",
            "thread ms",
            "wall ms (est)",
            "samples",
            "brdf evals",
            "rays",
            "env lookups"
        )?;
        let rows = [
            ("camera", &self.camera),
            ("direct", &self.direct),
            ("environment", &self.environment),
            ("shadows", &self.shadows),
        ];
        for (name, c) in rows {
            writeln!(
                f,
                "{:<12} {:>9} {:>10.3} {:>11.3} {:>13.3} {:>12} {:>12} {:>12} {:>11}",
                name,
                if c.requested { "yes" } else { "no" },
                c.setup.as_secs_f64() * 1e3,
                c.time.as_secs_f64() * 1e3,
                self.wall_share(c).as_secs_f64() * 1e3,
                c.samples,
                c.brdf_evals + c.setup_evals,
                c.rays,
                c.lookups
            )?;
        }
        if self.shadows.requested {
            writeln!(f, "occluded shadow rays: {}", self.shadows.occluded)?;
        }
        if self.table_misses > 0 {
            writeln!(
                f,
                "table lookups with no sample (rendered 0): {}",
                self.table_misses
            )?;
        }
        write!(
            f,
            "wall {:.3} ms on {} threads",
            self.wall.as_secs_f64() * 1e3,
            self.threads
        )
    }
}
