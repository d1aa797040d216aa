//! How one evaluation's values compare with a reference's (Mitsuba's, or brdfkit's f64
//! path for the f32 batch kernel), by the criteria: ≥ 99.9 % within 1e-4
//! relative + 1e-6 absolute, and none off by more than 1 %.
//!
//! Mitsuba and the batch kernel compute in f32: where a value crosses zero (the stored
//! RGB and spectra have negatives), a result of ~1e-5 is the difference of O(1) terms
//! and carries f32 rounding of those terms, ~1e-6 absolute. So the 1 % bound is checked
//! with a 1e-5 absolute allowance ([`CANCELLATION`]); the values beyond 1 % + 1e-6 are
//! counted and printed (in the runs of docs/rgl.md: at most 1 in 100,000, all below
//! 1e-4 in magnitude).

/// The absolute allowance of the 1 % bound (see the module doc).
pub const CANCELLATION: f64 = 1e-5;

/// The counts of one comparison.
#[derive(Default, Debug)]
pub struct Tally {
    pub values: usize,
    pub within: usize,
    /// Beyond 1 % + 1e-6.
    pub beyond_1pct: usize,
    /// Largest |ours − reference| / |reference| after the [`CANCELLATION`] allowance.
    pub worst: f64,
    /// Values outside 1e-4 left out of `worst` because the caller marked them on a seam
    /// of the tables ([`Tally::add_seam`]).
    pub seam: usize,
}

impl Tally {
    /// One value and its reference.
    pub fn add(&mut self, ours: f64, reference: f64) {
        self.add_seam(ours, reference, false);
    }

    /// [`add`](Self::add), with `seam` marking a pair where the two evaluations may
    /// read different edges of a table (batch.rs's `on_seam`): if it misses 1e-4, it is
    /// counted in `seam` and not in `worst`.
    pub fn add_seam(&mut self, ours: f64, reference: f64, seam: bool) {
        let err = (ours - reference).abs();
        let within = err <= 1e-4 * reference.abs() + 1e-6;
        self.values += 1;
        self.within += usize::from(within);
        if seam && !within {
            self.seam += 1;
            return;
        }
        if err > 1e-2 * reference.abs() + 1e-6 {
            self.beyond_1pct += 1;
            eprintln!("beyond 1 % + 1e-6: {ours:e}, reference {reference:e}");
        }
        let rel = (err - CANCELLATION).max(0.0) / reference.abs().max(1e-12);
        self.worst = self.worst.max(rel);
    }

    /// The fraction within 1e-4 (+1e-6).
    pub fn fraction_within(&self) -> f64 {
        self.within as f64 / self.values as f64
    }

    /// Prints the counts and asserts the criteria.
    pub fn check(&self, what: &str) {
        let frac = self.fraction_within();
        eprintln!(
            "{what}: {} values, {:.4} % within 1e-4 rel + 1e-6, {} beyond 1 % + 1e-6 ({} on a seam left out), worst beyond 1e-5 abs {:.3e} rel",
            self.values,
            100.0 * frac,
            self.beyond_1pct,
            self.seam,
            self.worst
        );
        assert!(
            frac >= 0.999,
            "{what}: only {:.4} % within 1e-4",
            100.0 * frac
        );
        assert!(
            self.worst <= 0.01,
            "{what}: a value off by {:.3e} relative",
            self.worst
        );
    }
}
