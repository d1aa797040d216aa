//! Progress of a fit: the events of [`brdfkit_core::progress`] ([`Event::FitPlanned`],
//! [`Event::Iteration`], [`Event::StartDone`]) sent to the caller's [`Observe`]. Each
//! start's solver reports its iterations through argmin's own observer interface,
//! bridged here; a fit without an observer is silent.

use argmin::core::observers::Observe as ArgminObserve;
use argmin::core::{Error, KV, State};
use brdfkit_core::progress::{Event, IterEvent, Observe};
use std::sync::Arc;

/// Bridges argmin's observer interface to an [`Observe`] (argmin keeps its observers
/// `'static`: the fit hands it a [`brdfkit_core::progress::relay`]).
pub(crate) struct Bridge {
    pub obs: Arc<dyn Observe>,
    pub start: usize,
    pub channel: Option<usize>,
    pub warm_up: bool,
}

impl<I: State<Float = f64>> ArgminObserve<I> for Bridge {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), Error> {
        self.obs.observe(&Event::Iteration(IterEvent {
            start: self.start,
            channel: self.channel,
            iter: state.get_iter(),
            cost: state.get_cost(),
            best_cost: state.get_best_cost(),
            warm_up: self.warm_up,
        }));
        Ok(())
    }
}
