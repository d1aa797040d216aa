//! Progress on stderr: the one place where the command line draws the library's
//! progress events ([`brdfkit::core::progress::Event`]) as indicatif bars and lines.
//! Every verb that runs a long engine (fit, report, demo, batch, study, render) hands
//! it a [`Progress`]; `--quiet` makes it draw
//! nothing. Bars appear only once the work has run for a second, and only on a
//! terminal (indicatif draws nothing otherwise).
//!
//! What is progress and what is not: events, and the verb's own announcements of long
//! work ([`Progress::say`]), are drawn here; results (stdout, `--stage-times` tables,
//! "wrote FILE" lines) and notes about the input the user must see (a `.bsdf` file
//! resampled, an export's approximations) are the verbs' to print.

use brdfkit::core::progress::{BatchPlan, Event, FitPlan, FitSummary, Observe, TableEnd};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The bar of one family's fit: starts done, with the best loss so far.
struct FitBar {
    bar: ProgressBar,
    t0: Instant,
    shown: AtomicBool,
    iters: AtomicU64,
    label: String,
}

impl FitBar {
    fn new(label: &str) -> Self {
        let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} {msg} [{bar:24}] {pos}/{len} starts, {elapsed}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        FitBar {
            bar,
            t0: Instant::now(),
            shown: AtomicBool::new(false),
            iters: AtomicU64::new(0),
            label: label.to_string(),
        }
    }

    fn maybe_show(&self) {
        if self.t0.elapsed() > Duration::from_secs(1) && !self.shown.swap(true, Ordering::Relaxed) {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
    }

    fn plan(&self, plan: &FitPlan) {
        self.bar.set_length((plan.starts * plan.passes) as u64);
        self.bar
            .set_message(format!("fitting {} on {} cells", self.label, plan.cells));
    }

    fn iteration(&self, best_cost: f64) {
        let n = self.iters.fetch_add(1, Ordering::Relaxed) + 1;
        self.maybe_show();
        if n.is_multiple_of(8) {
            self.bar.set_message(format!(
                "fitting {}: {} iterations, best loss {:.4e}",
                self.label,
                n,
                (2.0 * best_cost).sqrt()
            ));
            self.bar.tick();
        }
    }

    fn start_done(&self) {
        self.maybe_show();
        self.bar.inc(1);
    }
}

/// A bar of `len` steps shown by a timer once the work has run for a second (so a
/// first batch table that takes minutes gets its bar too): a batch's tables, a render's
/// rows.
fn delayed_bar(len: usize, template: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template(template)
            .expect("static template")
            .progress_chars("=> "),
    );
    let b = bar.clone();
    std::thread::spawn(move || {
        std::thread::sleep(Duration::from_secs(1));
        if !b.is_finished() {
            b.set_draw_target(ProgressDrawTarget::stderr());
            b.enable_steady_tick(Duration::from_millis(200));
        }
    });
    bar
}

/// The bars being drawn.
#[derive(Default)]
struct Bars {
    fit: Option<FitBar>,
    batch: Option<ProgressBar>,
    rows: Option<ProgressBar>,
}

/// Draws progress events on stderr (nothing when quiet).
pub struct Progress {
    quiet: bool,
    /// A line before and after each family (`report`, `demo`); bars only otherwise.
    family_lines: bool,
    bars: Mutex<Bars>,
}

impl Progress {
    /// Bars, and the lines of batches, reports and studies.
    pub fn new(quiet: bool) -> Self {
        Progress {
            quiet,
            family_lines: false,
            bars: Mutex::new(Bars::default()),
        }
    }

    /// [`Progress::new`] with a line before and after each family's fit.
    pub fn with_family_lines(quiet: bool) -> Self {
        Progress {
            family_lines: true,
            ..Progress::new(quiet)
        }
    }

    fn bars(&self) -> MutexGuard<'_, Bars> {
        self.bars.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A line of progress (above any bar being drawn).
    pub fn say(&self, s: &str) {
        if self.quiet {
            return;
        }
        let bars = self.bars();
        let drawn = (bars.batch.as_ref())
            .or(bars.rows.as_ref())
            .or(bars.fit.as_ref().map(|f| &f.bar));
        match drawn {
            Some(b) => b.suspend(|| eprintln!("{s}")),
            None => eprintln!("{s}"),
        }
    }

    /// Removes the bars.
    pub fn finish(&self) {
        let mut bars = self.bars();
        if let Some(b) = bars.batch.take() {
            b.finish_and_clear();
        }
        if let Some(f) = bars.fit.take() {
            f.bar.finish_and_clear();
        }
        if let Some(b) = bars.rows.take() {
            b.finish_and_clear();
        }
    }

    /// The events of one family's fit.
    fn fit_event(&self, e: &Event) {
        let mut bars = self.bars();
        let bar = bars.fit.get_or_insert_with(|| FitBar::new("the model"));
        match e {
            Event::FitPlanned(p) => bar.plan(p),
            Event::Iteration(i) => bar.iteration(i.best_cost),
            Event::StartDone(_) => bar.start_done(),
            _ => {}
        }
    }

    fn family_started(&self, index: usize, count: usize, label: &str) {
        if self.family_lines {
            self.say(&format!("[{}/{count}] fitting {label} ...", index + 1));
        }
        self.bars().fit = Some(FitBar::new(label));
    }

    fn family_done(&self, s: Option<&FitSummary>) {
        if let Some(b) = self.bars().fit.take() {
            b.bar.finish_and_clear();
        }
        if let (Some(s), true) = (s, self.family_lines) {
            self.say(&format!(
                "      {} loss {:.4e} in {:.2} s ({} iterations{})",
                s.loss_name,
                s.loss,
                s.wall_time_s,
                s.iterations,
                if s.converged { "" } else { ", not converged" }
            ));
        }
    }

    fn batch_planned(&self, p: &BatchPlan) {
        self.bars().batch = Some(delayed_bar(
            p.to_fit,
            "{spinner} [{bar:24}] {pos}/{len} tables, {elapsed}, eta {eta}: {msg}",
        ));
        if p.resumed > 0 {
            self.say(&format!(
                "{} of {} tables already done with these options: skipped",
                p.resumed, p.tables
            ));
        }
    }

    fn table_done(&self, index: usize, count: usize, table: &str, end: &TableEnd) {
        match end {
            TableEnd::Fitted(dt) => self.say(&format!(
                "[{}/{count}] {table}: fitted in {dt:.2} s",
                index + 1
            )),
            TableEnd::Failed(e) => {
                self.say(&format!("[{}/{count}] {table}: FAILED: {e}", index + 1))
            }
        }
        if let Some(b) = &self.bars().batch {
            b.inc(1);
        }
    }
}

impl Observe for Progress {
    fn observe(&self, e: &Event) {
        if self.quiet {
            return;
        }
        match e {
            Event::FitPlanned(_) | Event::Iteration(_) | Event::StartDone(_) => self.fit_event(e),
            Event::StageDone { .. } => {}
            Event::FamilyStarted {
                index,
                count,
                label,
            } => self.family_started(*index, *count, label),
            Event::FamilyDone { summary, .. } => self.family_done(summary.as_ref()),
            Event::TableRefit { table, reason } => {
                self.say(&format!("{table}: refitting: {reason}"))
            }
            Event::TableSkipped { .. } => {}
            Event::BatchPlanned(p) => self.batch_planned(p),
            Event::TableStarted { table, .. } => {
                if let Some(b) = &self.bars().batch {
                    b.set_message(table.clone());
                }
            }
            Event::TableDone {
                index,
                count,
                table,
                end,
            } => self.table_done(*index, *count, table, end),
            Event::Section(s) => self.say(&format!("report: {s}")),
            Event::Step(s) => self.say(s),
            Event::Rows { done, total } => {
                let mut bars = self.bars();
                let bar = bars.rows.get_or_insert_with(|| {
                    delayed_bar(
                        *total,
                        "{spinner} [{bar:24}] {pos}/{len} rows, {elapsed}, eta {eta}",
                    )
                });
                bar.set_position(*done as u64);
            }
        }
    }

    fn is_silent(&self) -> bool {
        self.quiet
    }
}
