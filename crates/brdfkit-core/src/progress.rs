//! Progress: one event type ([`Event`]) and one observer trait ([`Observe`]) for every
//! long-running engine of brdfkit (fit, families, batch, report, study, render).
//!
//! In the spirit of argmin's `Observe` (an observer receives the solver's state after
//! each iteration): an engine takes `&dyn Observe` and tells it what happens; it never
//! prints. What the user sees is the caller's business: the `fit-brdf` CLI draws the
//! events as indicatif bars and lines (`crates/fit-brdf/src/progress.rs`), Python
//! forwards them to a callable, tests record them ([`Recorder`]), and `&()` ignores
//! them.
//!
//! Events may come from several threads at once (a fit's starts run in parallel), hence
//! `Send + Sync`. Payloads are owned so that an event can cross a channel (see
//! [`relay`]).

use std::sync::mpsc;
use std::sync::{Arc, Mutex};

/// Something a long-running engine reports while it works.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A fit is about to run its passes.
    FitPlanned(FitPlan),
    /// One solver iteration of one start of a fit.
    Iteration(IterEvent),
    /// A start of a fit is done.
    StartDone(StartDone),
    /// A stage of a fit is done (the stages of `brdfkit_fit::StageTimes`: `subsample`,
    /// then per pass `prepare`, `explore`, `warm-up`, `finish`, then `losses`, `record`).
    StageDone {
        /// The stage's name.
        stage: &'static str,
        /// The channel of a per-channel pass's stage (`None`: shared, or not a pass's).
        channel: Option<usize>,
        /// Its wall time.
        seconds: f64,
    },
    /// Family `index` of `count` (0-based) starts its fit.
    FamilyStarted {
        /// Position among the families (0-based).
        index: usize,
        /// Number of families.
        count: usize,
        /// The family's label.
        label: String,
    },
    /// Family `index` of `count` ended: `summary` is `None` when its fit failed (the
    /// error is returned to the caller).
    FamilyDone {
        /// Position among the families (0-based).
        index: usize,
        /// Number of families.
        count: usize,
        /// The family's label.
        label: String,
        /// How the fit ended, if it did not fail.
        summary: Option<FitSummary>,
    },
    /// A batch table's earlier output cannot be reused, for `reason`; it is refitted.
    TableRefit {
        /// The table's name.
        table: String,
        /// Why its output is stale.
        reason: String,
    },
    /// A batch table is already done with these options: skipped.
    TableSkipped {
        /// The table's name.
        table: String,
    },
    /// A batch knows its finished tables; fitting starts.
    BatchPlanned(BatchPlan),
    /// Batch table `index` of the `count` to fit (0-based) starts.
    TableStarted {
        /// Position among the tables to fit (0-based).
        index: usize,
        /// Number of tables to fit.
        count: usize,
        /// The table's name.
        table: String,
    },
    /// Batch table `index` of `count` is done and its outputs are written.
    TableDone {
        /// Position among the tables to fit (0-based).
        index: usize,
        /// Number of tables to fit.
        count: usize,
        /// The table's name.
        table: String,
        /// How it ended.
        end: TableEnd,
    },
    /// A report starts computing one of its sections (a short description).
    Section(String),
    /// A study made a step (a short line: what was measured and its figure).
    Step(String),
    /// A render finished `done` of its `total` rows.
    Rows {
        /// Rows finished.
        done: usize,
        /// Rows of the image.
        total: usize,
    },
}

/// What a fit is about to do.
#[derive(Debug, Clone, PartialEq)]
pub struct FitPlan {
    /// Number of starts per pass.
    pub starts: usize,
    /// Starts finished on all fitted cells per pass (the others stop after their
    /// warm-up and ranking).
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

/// How a family's fit ended, in the figures a progress line shows.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSummary {
    /// The name of the optimised loss (`cbrt`, `l2`, ...).
    pub loss_name: String,
    /// The optimised loss over the full table.
    pub loss: f64,
    /// The fit's wall time.
    pub wall_time_s: f64,
    /// Iterations by stage, as the fit record summarises them (`"12 + 30 full"`).
    pub iterations: String,
    /// Whether the kept start converged.
    pub converged: bool,
}

/// The work of a batch run, known once the finished tables are checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BatchPlan {
    /// Tables of the batch (of this shard).
    pub tables: usize,
    /// Already done with these options: skipped.
    pub resumed: usize,
    /// To fit.
    pub to_fit: usize,
}

/// How a batch table's fit ended.
#[derive(Debug, Clone, PartialEq)]
pub enum TableEnd {
    /// Fitted in this many seconds.
    Fitted(f64),
    /// Failed; the message names the table file.
    Failed(String),
}

/// Receives the [`Event`]s of an engine. Called from several threads at once.
pub trait Observe: Send + Sync {
    /// One event.
    fn observe(&self, event: &Event);

    /// True for an observer that ignores every event: an engine may then skip the work
    /// of making them (a fit runs without its [`relay`]).
    fn is_silent(&self) -> bool {
        false
    }
}

/// The unit observer observes nothing: `engine(..., &())` runs silently.
impl Observe for () {
    fn observe(&self, _event: &Event) {}

    fn is_silent(&self) -> bool {
        true
    }
}

/// A closure is an observer: `&|e: &Event| eprintln!("{e:?}")`.
impl<F: Fn(&Event) + Send + Sync> Observe for F {
    fn observe(&self, event: &Event) {
        self(event)
    }
}

/// Keeps every event, in the order received (for tests and for callers that look at
/// the events after the work).
#[derive(Debug, Default)]
pub struct Recorder(Mutex<Vec<Event>>);

impl Recorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Recorder::default()
    }

    /// The events so far.
    pub fn events(&self) -> Vec<Event> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

impl Observe for Recorder {
    fn observe(&self, event: &Event) {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(event.clone());
    }
}

/// Messages of a [`relay`]: an event, or the end of the work.
enum Relayed {
    Event(Event),
    End,
}

/// The sending end of a [`relay`].
struct Sender(mpsc::Sender<Relayed>);

impl Observe for Sender {
    fn observe(&self, event: &Event) {
        // The receiver outlives every send of `f` (it ends at `End`).
        let _ = self.0.send(Relayed::Event(event.clone()));
    }
}

/// Runs `f` with an owned, `'static` observer that forwards every event to `obs`.
///
/// For engines that hand their observer to code requiring `'static` (argmin's
/// `Executor::add_observer`) while their callers lend a `&dyn Observe`: the events cross
/// a channel to a scoped thread that calls `obs`, in the order each thread sent them,
/// and every event sent before `f` returns reaches `obs` before `relay` returns.
pub fn relay<R>(obs: &dyn Observe, f: impl FnOnce(Arc<dyn Observe>) -> R) -> R {
    let (tx, rx) = mpsc::channel();
    std::thread::scope(|s| {
        s.spawn(move || {
            while let Ok(Relayed::Event(e)) = rx.recv() {
                obs.observe(&e);
            }
        });
        let end = tx.clone();
        let r = f(Arc::new(Sender(tx)));
        // An explicit end: a clone of the observer kept by `f` cannot hang the scope.
        let _ = end.send(Relayed::End);
        r
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(s: &str) -> Event {
        Event::Step(s.into())
    }

    #[test]
    fn a_relay_delivers_every_event_in_order_before_it_returns() {
        let rec = Recorder::new();
        let n = relay(&rec, |o| {
            for k in 0..1000 {
                o.observe(&step(&k.to_string()));
            }
            7
        });
        assert_eq!(n, 7);
        let want: Vec<Event> = (0..1000).map(|k| step(&k.to_string())).collect();
        assert_eq!(rec.events(), want);
    }

    #[test]
    fn a_relay_returns_even_when_its_observer_is_kept() {
        let rec = Recorder::new();
        let kept = relay(&rec, |o| {
            o.observe(&step("a"));
            o
        });
        // Sent after the relay ended: dropped, never delivered, and no hang.
        kept.observe(&step("late"));
        assert_eq!(rec.events(), vec![step("a")]);
    }

    #[test]
    fn events_from_many_threads_all_arrive() {
        let rec = Recorder::new();
        relay(&rec, |o| {
            std::thread::scope(|s| {
                for t in 0..4 {
                    let o = o.clone();
                    s.spawn(move || {
                        for k in 0..250 {
                            o.observe(&step(&format!("{t}/{k}")));
                        }
                    });
                }
            })
        });
        let ev = rec.events();
        assert_eq!(ev.len(), 1000);
        // Each thread's events keep their order.
        for t in 0..4 {
            let mine: Vec<&Event> = ev
                .iter()
                .filter(|e| matches!(e, Event::Step(s) if s.starts_with(&format!("{t}/"))))
                .collect();
            let want: Vec<Event> = (0..250).map(|k| step(&format!("{t}/{k}"))).collect();
            assert_eq!(mine, want.iter().collect::<Vec<_>>());
        }
    }

    #[test]
    fn unit_and_closures_observe() {
        ().observe(&step("ignored"));
        let seen = Mutex::new(0);
        let count = |_: &Event| *seen.lock().unwrap() += 1;
        count.observe(&step("x"));
        (&count as &dyn Observe).observe(&step("y"));
        assert_eq!(*seen.lock().unwrap(), 2);
    }
}
