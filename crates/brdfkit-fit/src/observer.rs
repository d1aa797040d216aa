//! Progress reporting: a [`FitObserver`] receives events from every start's solver
//! (through an argmin observer) and the fit driver. The CLI puts a progress bar behind
//! it; a fit without an observer is silent.

use argmin::core::observers::Observe;
use argmin::core::{Error, KV, State};
use std::sync::Arc;

/// What a fit is about to do.
#[derive(Debug, Clone, PartialEq)]
pub struct FitPlan {
    /// Number of starts per pass.
    pub starts: usize,
    /// Starts finished on all fitted cells per pass (the others stop after their
    /// warm-up; see [`crate::FitConfig::finish`]).
    pub finish: usize,
    /// Number of passes (1 for shared shape parameters, 3 for per-channel fits).
    pub passes: usize,
    /// Iteration cap per start.
    pub max_iters: u64,
    /// Cells the solver sees.
    pub cells: usize,
}

/// One solver iteration of one start.
#[derive(Debug, Clone, PartialEq)]
pub struct IterEvent {
    /// Start index.
    pub start: usize,
    /// Channel of a per-channel pass (`None` for a shared fit).
    pub channel: Option<usize>,
    /// Iteration number (from 0).
    pub iter: u64,
    /// Current cost ½ · (overall loss)².
    pub cost: f64,
    /// Best cost so far in this start.
    pub best_cost: f64,
    /// True during the warm-up on the subsample, false on the fitted cells.
    pub warm_up: bool,
}

/// A start that is done: finished on the fitted cells, or stopped after its warm-up
/// and ranking (then `iterations` is 0 and `loss` its ranking loss).
#[derive(Debug, Clone, PartialEq)]
pub struct StartDone {
    /// Start index.
    pub start: usize,
    /// Channel of a per-channel pass.
    pub channel: Option<usize>,
    /// Final value of the optimised loss (weighted RMS).
    pub loss: f64,
    /// Iterations taken.
    pub iterations: u64,
    /// Why it stopped.
    pub termination: String,
}

/// Receives progress events. Called from several threads at once (starts run in
/// parallel); every method has an empty default.
pub trait FitObserver: Send + Sync {
    /// Before any start runs.
    fn on_plan(&self, _plan: &FitPlan) {}
    /// After every solver iteration.
    fn on_iter(&self, _ev: &IterEvent) {}
    /// When a start has finished.
    fn on_start_done(&self, _done: &StartDone) {}
}

/// Bridges argmin's observer interface to a [`FitObserver`].
pub(crate) struct Bridge {
    pub obs: Arc<dyn FitObserver + 'static>,
    pub start: usize,
    pub channel: Option<usize>,
    pub warm_up: bool,
}

impl<I: State<Float = f64>> Observe<I> for Bridge {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), Error> {
        self.obs.on_iter(&IterEvent {
            start: self.start,
            channel: self.channel,
            iter: state.get_iter(),
            cost: state.get_cost(),
            best_cost: state.get_best_cost(),
            warm_up: self.warm_up,
        });
        Ok(())
    }
}

/// A [`FitObserver`] from a closure called after every iteration:
/// `Arc::new(OnIter(|ev: &IterEvent| bar.set_message(format!("{:.3e}", ev.cost))))`.
pub struct OnIter<F>(pub F);

impl<F: Fn(&IterEvent) + Send + Sync> FitObserver for OnIter<F> {
    fn on_iter(&self, ev: &IterEvent) {
        (self.0)(ev)
    }
}
