//! The cell sets of a fit: the cells the losses are reported on, the fitted cells, and
//! the warm-up and exploration subsamples. They depend on the data and the settings,
//! never on the model: the subsamples are drawn through
//! [`FitData::shared_subsample`], so every family fitted to the same cells (a batch, a
//! report, `fit --model a,b,c`), every pass and every start uses one draw.

use crate::config::{CellFilter, FitConfig};
use crate::data::FitData;
use crate::error::FitError;
use std::borrow::Cow;
use std::sync::Arc;

/// Size of the exploration set of a ranked fit: the warm-up size over this, unless
/// [`FitConfig::explore_cells`] gives a size.
const EXPLORE_DIVISOR: usize = 8;

/// Smallest separate exploration set of the default rule (a few cells per stratum of
/// the 16 × 16 grid); below it the warm-up set is explored directly.
const EXPLORE_MIN_CELLS: usize = 4096;

/// Seed offset of the exploration subsample.
const EXPLORE_SEED: u64 = 0x4558_504C;

/// Seed offset of the warm-up subsample (distinct from a user subsample's draw).
const WARM_UP_SEED: u64 = 0x5741_524D;

/// The cells of one fit (see the module doc).
pub(super) struct Cells<'d> {
    /// The cells of the final losses: the ones a score of the result takes
    /// ([`CellFilter`]).
    pub(super) full: Cow<'d, FitData>,
    /// A user's subsample of `full` (`FitConfig::subsample`), if any.
    fit: Option<Arc<FitData>>,
    warm: Option<Arc<FitData>>,
    explore: Option<Arc<FitData>>,
    ranked: bool,
}

/// Borrowed views of [`Cells`], what the stages read.
pub(super) struct CellSets<'a> {
    /// The fitted cells.
    pub(super) fit: &'a FitData,
    pub(super) warm: Option<&'a FitData>,
    pub(super) explore: Option<&'a FitData>,
    /// Whether the starts are ranked after their exploration: only when a warm-up
    /// makes exploring cheap and some start can be left unfinished (otherwise every
    /// start is finished, as with one start).
    pub(super) ranked: bool,
}

impl<'d> Cells<'d> {
    /// The cells of a fit of `data` under `config`.
    pub(super) fn of(data: &'d FitData, config: &FitConfig) -> Result<Cells<'d>, FitError> {
        let full = CellFilter::of(config).apply(data)?;
        let fit = config
            .subsample
            .map(|f| full.shared_subsample(f, config.seed));
        let n = fit.as_deref().map_or(full.len(), FitData::len);
        let warm_cells = config.warm_up_cells_for(n);
        let ranked = warm_cells.is_some() && config.finish < config.starts.max(1);
        let (warm, explore) = {
            let fitset: &FitData = fit.as_deref().unwrap_or(&full);
            let warm = warm_cells
                .map(|c| fitset.shared_subsample(c as f64 / n as f64, config.seed ^ WARM_UP_SEED));
            // Drawn from the warm-up set (stratified again; multiplicities multiply, so
            // its weighted sums still estimate the full set's), not from the full set.
            let explore = match (explore_cells(config, warm_cells, ranked), &warm) {
                (Some(c), Some(w)) => {
                    Some(w.shared_subsample(c as f64 / w.len() as f64, config.seed ^ EXPLORE_SEED))
                }
                _ => None,
            };
            (warm, explore)
        };
        Ok(Cells {
            full,
            fit,
            warm,
            explore,
            ranked,
        })
    }

    /// The fitted cells: the user's subsample, or all of `full`.
    pub(super) fn fitset(&self) -> &FitData {
        self.fit.as_deref().unwrap_or(&self.full)
    }

    /// Whether the fitted cells are the loss report's cells (no user subsample).
    pub(super) fn fits_all(&self) -> bool {
        self.fit.is_none()
    }

    pub(super) fn sets(&self) -> CellSets<'_> {
        CellSets {
            fit: self.fitset(),
            warm: self.warm.as_deref(),
            explore: self.explore.as_deref(),
            ranked: self.ranked,
        }
    }
}

/// The exploration set's size of a ranked fit: an eighth of the warm-up's size (each
/// start converges there; the finishers then pass through the warm-up set to the full
/// one), unless that would be under [`EXPLORE_MIN_CELLS`], when the warm-up set is the
/// exploration set; or the configured size when under the warm-up's.
fn explore_cells(config: &FitConfig, warm_cells: Option<usize>, ranked: bool) -> Option<usize> {
    warm_cells
        .filter(|_| ranked)
        .and_then(|w| match config.explore_cells {
            None => Some(w / EXPLORE_DIVISOR).filter(|&e| e >= EXPLORE_MIN_CELLS),
            Some(e) => (e < w).then_some(e),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_merl::{Dims, MerlTable};

    /// A 60 × 60 × 120 table of a Lambertian surface: 250,000-odd valid cells.
    fn data() -> FitData {
        let m = brdfkit_models::default_model("lambert").unwrap();
        let t = MerlTable::from_brdf(m.as_ref(), Dims::new(60, 60, 120).unwrap()).unwrap();
        FitData::from_table(&t).unwrap()
    }

    #[test]
    fn the_sets_follow_the_rules_and_are_drawn_once() {
        let d = data();
        let cfg = FitConfig::default()
            .starts(8)
            .unwrap()
            .warm_up(Some(16_384))
            .unwrap();
        let a = Cells::of(&d, &cfg).unwrap();
        let s = a.sets();
        assert!(s.ranked, "8 starts, 1 finisher, a warm-up: ranked");
        let w = s.warm.expect("a warm-up set");
        assert!((w.len() as f64 - 16_384.0).abs() < 300.0, "{}", w.len());
        // An eighth of 16,384 is under EXPLORE_MIN_CELLS: the warm-up set explores.
        assert!(s.explore.is_none());
        assert!(
            std::ptr::eq(s.fit, &d),
            "no cutoff, no subsample: the data itself"
        );
        // A second fit (another family) gets the same draw, not a new one.
        let b = Cells::of(&d, &cfg).unwrap();
        assert!(std::ptr::eq(b.sets().warm.unwrap(), w));
        // The draw is the plain stratified subsample, bit for bit.
        let again = d.stratified_subsample(16_384.0 / d.len() as f64, WARM_UP_SEED);
        assert_eq!(again.values(), w.values());
        assert_eq!(again.multiplicity(), w.multiplicity());
    }

    #[test]
    fn one_start_or_one_finisher_per_start_is_not_ranked() {
        let d = data();
        let cfg = FitConfig::default().warm_up(Some(16_384)).unwrap();
        assert!(!Cells::of(&d, &cfg).unwrap().sets().ranked);
        let cfg = cfg.starts(4).unwrap().finish(4).unwrap();
        let c = Cells::of(&d, &cfg).unwrap();
        assert!(!c.sets().ranked && c.sets().warm.is_some());
        let big = FitConfig::default().warm_up(Some(1 << 20)).unwrap();
        assert!(
            Cells::of(&d, &big).unwrap().sets().warm.is_none(),
            "too few cells"
        );
    }

    #[test]
    fn the_exploration_set_is_an_eighth_unless_given() {
        let cfg = FitConfig::default();
        assert_eq!(explore_cells(&cfg, Some(65_536), true), Some(8_192));
        assert_eq!(explore_cells(&cfg, Some(16_384), true), None);
        assert_eq!(explore_cells(&cfg, Some(65_536), false), None);
        let given = cfg.explore_cells(Some(1024)).unwrap();
        assert_eq!(explore_cells(&given, Some(65_536), true), Some(1024));
    }
}
