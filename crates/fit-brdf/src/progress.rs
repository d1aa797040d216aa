//! Progress on stderr: the library's observers ([`FitObserver`], [`FamilyObserver`],
//! [`BatchObserver`]) drawn as indicatif bars and lines. Bars appear only once the work
//! has run for a second, and only on a terminal (indicatif draws nothing otherwise).

use brdfkit::fit::batch::{BatchObserver, Finished, Plan, Table};
use brdfkit::fit::families::{Family, FamilyObserver, Outcome};
use brdfkit::fit::{FitObserver, FitPlan, IterEvent, Loss, StartDone};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// The bar of one family's fit: starts done, with the best loss so far.
struct FitBar {
    bar: ProgressBar,
    t0: Instant,
    shown: AtomicBool,
    iters: AtomicU64,
    label: String,
    quiet: bool,
}

impl FitBar {
    fn new(label: &str, quiet: bool) -> Arc<Self> {
        let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} {msg} [{bar:24}] {pos}/{len} starts, {elapsed}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        Arc::new(FitBar {
            bar,
            t0: Instant::now(),
            shown: AtomicBool::new(false),
            iters: AtomicU64::new(0),
            label: label.to_string(),
            quiet,
        })
    }

    fn maybe_show(&self) {
        if !self.quiet
            && self.t0.elapsed() > Duration::from_secs(1)
            && !self.shown.swap(true, Ordering::Relaxed)
        {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
    }
}

impl FitObserver for FitBar {
    fn on_plan(&self, plan: &FitPlan) {
        self.bar.set_length((plan.starts * plan.passes) as u64);
        self.bar
            .set_message(format!("fitting {} on {} cells", self.label, plan.cells));
    }
    fn on_iter(&self, ev: &IterEvent) {
        let n = self.iters.fetch_add(1, Ordering::Relaxed) + 1;
        self.maybe_show();
        if n.is_multiple_of(8) {
            self.bar.set_message(format!(
                "fitting {}: {} iterations, best loss {:.4e}",
                self.label,
                n,
                (2.0 * ev.best_cost).sqrt()
            ));
            self.bar.tick();
        }
    }
    fn on_start_done(&self, _d: &StartDone) {
        self.maybe_show();
        self.bar.inc(1);
    }
}

/// Progress of the families of `fit`, `report` and `demo`: a bar per fit and, with
/// `lines`, a line before and after each family.
pub struct Families {
    quiet: bool,
    /// The optimised loss, shown after each family (None: no lines).
    lines: Option<Loss>,
    bar: RefCell<Option<Arc<FitBar>>>,
}

impl Families {
    /// Bars only (`fit`).
    pub fn bars(quiet: bool) -> Self {
        Families {
            quiet,
            lines: None,
            bar: RefCell::new(None),
        }
    }

    /// Bars and a line per family (`report`, `demo`).
    pub fn with_lines(loss: Loss, quiet: bool) -> Self {
        Families {
            lines: Some(loss),
            ..Families::bars(quiet)
        }
    }
}

impl FamilyObserver for Families {
    fn on_family_start(&self, k: usize, n: usize, f: &Family) -> Option<Arc<dyn FitObserver>> {
        if self.lines.is_some() && !self.quiet {
            eprintln!("[{}/{n}] fitting {} ...", k + 1, f.label);
        }
        let bar = FitBar::new(&f.label, self.quiet);
        *self.bar.borrow_mut() = Some(bar.clone());
        Some(bar)
    }

    fn on_family_done(&self, _k: usize, _n: usize, o: Option<&Outcome>) {
        if let Some(b) = self.bar.borrow_mut().take() {
            b.bar.finish_and_clear();
        }
        if let (Some(loss), Some(o), false) = (self.lines, o, self.quiet) {
            eprintln!(
                "      {loss} loss {:.4e} in {:.2} s ({} iterations{})",
                o.record.losses_full.get(loss).overall,
                o.record.wall_time_s,
                o.record.stage_iterations().summary(),
                if o.record.converged {
                    ""
                } else {
                    ", not converged"
                }
            );
        }
    }
}

/// Progress of a batch: a line per refit note and per table, and a bar over the tables,
/// shown by a timer once the batch has run for a second (so a first table that takes
/// minutes gets its bar too).
pub struct Batch {
    quiet: bool,
    bar: RefCell<Option<ProgressBar>>,
}

impl Batch {
    pub fn new(quiet: bool) -> Self {
        Batch {
            quiet,
            bar: RefCell::new(None),
        }
    }

    fn line(&self, s: &str) {
        if self.quiet {
            return;
        }
        match &*self.bar.borrow() {
            Some(b) => b.suspend(|| eprintln!("{s}")),
            None => eprintln!("{s}"),
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(b) = self.bar.borrow_mut().take() {
            b.finish_and_clear();
        }
    }
}

impl BatchObserver for Batch {
    fn on_refit(&self, t: &Table, why: &str) {
        self.line(&format!("{}: refitting: {why}", t.name));
    }

    fn on_plan(&self, p: &Plan) {
        let bar =
            ProgressBar::with_draw_target(Some(p.to_fit as u64), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{bar:24}] {pos}/{len} tables, {elapsed}, eta {eta}: {msg}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        if !self.quiet {
            let b = bar.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_secs(1));
                if !b.is_finished() {
                    b.set_draw_target(ProgressDrawTarget::stderr());
                    b.enable_steady_tick(Duration::from_millis(200));
                }
            });
        }
        *self.bar.borrow_mut() = Some(bar);
        if p.resumed > 0 {
            self.line(&format!(
                "{} of {} tables already done with these options: skipped",
                p.resumed, p.tables
            ));
        }
    }

    fn on_table_start(&self, _k: usize, _n: usize, t: &Table) {
        if let Some(b) = &*self.bar.borrow() {
            b.set_message(t.name.clone());
        }
    }

    fn on_table_done(&self, k: usize, n: usize, t: &Table, how: Finished<'_>) {
        match how {
            Finished::Fitted(dt) => {
                self.line(&format!("[{}/{n}] {}: fitted in {dt:.2} s", k + 1, t.name))
            }
            Finished::Failed(e) => self.line(&format!("[{}/{n}] {}: FAILED: {e}", k + 1, t.name)),
        }
        if let Some(b) = &*self.bar.borrow() {
            b.inc(1);
        }
    }
}
