//! [`StageTimes`]: where a fit's wall time went, stage by stage.

/// Wall time (seconds) of each stage of one fit, summed over its passes (three for a
/// per-channel fit). Not part of the record, whose contents do not depend on the
/// machine apart from `wall_time_s`: read it from [`FitResult::stages`](crate::FitResult)
/// (`benches/fit_stages.rs` prints it as the table of `docs/performance.md`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// The cell sets: the angular cutoffs, a user's subsample, and the warm-up and
    /// exploration subsamples (drawn once per cell set and settings, then shared).
    pub subsample: f64,
    /// The problems on each cell set: weights, scales and stored targets, the albedo
    /// penalty.
    pub prepare: f64,
    /// Every start's first stage: its exploration (ranked fits) or its warm-up, and
    /// the ranking's cost pass.
    pub explore: f64,
    /// The finishers' warm-up after a separate exploration.
    pub warm_up: f64,
    /// The finishers on all fitted cells (and the automatic robust stage).
    pub finish: f64,
    /// The loss report over the fitted and the full cells.
    pub losses: f64,
    /// The record: parameter records, the albedo check, the assembly.
    pub record: f64,
}

impl StageTimes {
    /// The stages' names and times, in the order a fit runs them.
    pub fn stages(&self) -> [(&'static str, f64); 7] {
        [
            ("subsample", self.subsample),
            ("prepare", self.prepare),
            ("explore", self.explore),
            ("warm-up", self.warm_up),
            ("finish", self.finish),
            ("losses", self.losses),
            ("record", self.record),
        ]
    }

    /// The sum of the stages.
    pub fn total(&self) -> f64 {
        self.stages().iter().map(|(_, t)| t).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stages_add_up_in_order() {
        let t = StageTimes {
            subsample: 1.0,
            prepare: 2.0,
            explore: 3.0,
            warm_up: 4.0,
            finish: 5.0,
            losses: 6.0,
            record: 7.0,
        };
        let names: Vec<_> = t.stages().iter().map(|s| s.0).collect();
        assert_eq!(names[0], "subsample");
        assert_eq!(names[6], "record");
        assert_eq!(t.total(), 28.0);
    }
}
