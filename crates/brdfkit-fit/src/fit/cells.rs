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
