//! The (θh, θd, φd) grid: dimensions, the reference bin mapping, continuous index
//! coordinates, cell angles and cell solid-angle weights.
//!
//! Three maps between angles and indices live here, and they are **not** inverses of
//! each other bit for bit:
//!
//! - the **bin** of an angle ([`theta_h_bin`], [`theta_d_bin`], [`phi_d_bin`]) is the
//!   reference mapping of `BRDFRead.cpp` (Matusik et al. 2003), the same floating-point
//!   operations in the same order;
//! - the **continuous index coordinate** of an angle ([`theta_h_coord`] ...) is the
//!   value the reference truncates, so `bin == clamp(floor(coord))` bit for bit; it is
//!   what multilinear interpolation works in;
//! - the **angle of a cell** ([`theta_h_angle`] ...) is the lower edge of its bin:
//!   θh = (i/nθh)² · π/2, θd = j/nθd · π/2, φd = k/nφd · π.
//!
//! Feeding a cell's angle back into the bin function lands one bin lower for about 60 %
//! of the cells (the angle is the bin's lower edge and round-off drifts either way), so
//! resampling onto a grid assigns values by index, never by a nearest lookup at the
//! cell's own angles.

use brdfkit_core::HalfDiff;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;
use thiserror::Error;

/// Grid dimensions (number of bins) along θh, θd and φd, each positive (checked by
/// [`Dims::new`]; the fields are private so no other value can exist).
///
/// The flat index of cell (i, j, k) is `k + nφd · (j + nθd · i)`: φd varies fastest,
/// θh slowest, as in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dims {
    theta_h: usize,
    theta_d: usize,
    phi_d: usize,
}

/// Dimensions that cannot describe a table.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum DimsError {
    /// A dimension is zero or negative.
    #[error("invalid dims {0} x {1} x {2}: every dimension must be positive")]
    NotPositive(i64, i64, i64),
    /// A dimension beyond the int32 range of the file header.
    #[error("invalid dims {0} x {1} x {2}: a dimension exceeds the header's int32 range")]
    TooLarge(i64, i64, i64),
    /// The byte size of the table (3 channels × 8 bytes × cells, plus the 12-byte
    /// header) does not fit in 64 bits / the address space.
    #[error("dims {0} x {1} x {2} are too large: the table size overflows")]
    Overflow(i64, i64, i64),
}

/// Bytes of the file header: three little-endian int32.
pub const HEADER_BYTES: u64 = 12;

impl Dims {
    /// The MERL database grid: 90 × 90 × 180.
    pub const MERL: Dims = Dims {
        theta_h: 90,
        theta_d: 90,
        phi_d: 180,
    };

    /// Checked constructor: every dimension positive, within int32 (the header's type),
    /// and the file size representable in 64 bits and in memory.
    pub fn new(theta_h: i64, theta_d: i64, phi_d: i64) -> Result<Dims, DimsError> {
        if theta_h <= 0 || theta_d <= 0 || phi_d <= 0 {
            return Err(DimsError::NotPositive(theta_h, theta_d, phi_d));
        }
        if theta_h > i32::MAX as i64 || theta_d > i32::MAX as i64 || phi_d > i32::MAX as i64 {
            return Err(DimsError::TooLarge(theta_h, theta_d, phi_d));
        }
        let overflow = DimsError::Overflow(theta_h, theta_d, phi_d);
        let bytes = (theta_h as u64)
            .checked_mul(theta_d as u64)
            .and_then(|c| c.checked_mul(phi_d as u64))
            .and_then(|c| c.checked_mul(3 * 8))
            .and_then(|b| b.checked_add(HEADER_BYTES))
            .ok_or(overflow.clone())?;
        // The whole table must also be addressable (a 32-bit target).
        usize::try_from(bytes).map_err(|_| overflow)?;
        Ok(Dims {
            theta_h: theta_h as usize,
            theta_d: theta_d as usize,
            phi_d: phi_d as usize,
        })
    }

    /// Bins along θh (polar angle of the half vector), square-root spaced.
    pub const fn theta_h(&self) -> usize {
        self.theta_h
    }

    /// Bins along θd (polar angle of the difference vector), uniform over [0, π/2).
    pub const fn theta_d(&self) -> usize {
        self.theta_d
    }

    /// Bins along φd (azimuth of the difference vector), uniform over [0, π).
    pub const fn phi_d(&self) -> usize {
        self.phi_d
    }

    /// Number of cells (per channel).
    pub const fn cells(&self) -> usize {
        self.theta_h * self.theta_d * self.phi_d
    }

    /// Size of the file of a table of these dims, in bytes.
    pub const fn file_bytes(&self) -> u64 {
        HEADER_BYTES + 24 * self.cells() as u64
    }

    /// Flat index of cell (i, j, k): `k + nφd · (j + nθd · i)`.
    #[inline]
    pub const fn index(&self, i: usize, j: usize, k: usize) -> usize {
        k + self.phi_d * (j + self.theta_d * i)
    }

    /// (i, j, k) of a flat index.
    #[inline]
    pub const fn unflatten(&self, index: usize) -> (usize, usize, usize) {
        let k = index % self.phi_d;
        let r = index / self.phi_d;
        (r / self.theta_d, r % self.theta_d, k)
    }

    /// Bins (i, j, k) of Rusinkiewicz angles, by the reference mapping (φh ignored).
    #[inline]
    pub fn bins(&self, c: &HalfDiff) -> (usize, usize, usize) {
        (
            theta_h_bin(c.theta_h, self.theta_h),
            theta_d_bin(c.theta_d, self.theta_d),
            phi_d_bin(c.phi_d, self.phi_d),
        )
    }

    /// Flat index of the bin of Rusinkiewicz angles (the reference `lookup_brdf_val`).
    #[inline]
    pub fn bin_index(&self, c: &HalfDiff) -> usize {
        let (i, j, k) = self.bins(c);
        self.index(i, j, k)
    }

    /// Continuous index coordinates (u, v, w) of Rusinkiewicz angles; see
    /// [`theta_h_coord`]. Unclamped: u ∈ [0, ∞), v ∈ [0, ∞), w ∈ [0, nφd].
    #[inline]
    pub fn coords(&self, c: &HalfDiff) -> [f64; 3] {
        [
            theta_h_coord(c.theta_h, self.theta_h),
            theta_d_coord(c.theta_d, self.theta_d),
            phi_d_coord(c.phi_d, self.phi_d),
        ]
    }

    /// Angles of cell (i, j, k): the lower edges of its bin, φh = 0.
    #[inline]
    pub fn cell_angles(&self, i: usize, j: usize, k: usize) -> HalfDiff {
        HalfDiff::new(
            theta_h_angle(i as f64, self.theta_h),
            0.0,
            theta_d_angle(j as f64, self.theta_d),
            phi_d_angle(k as f64, self.phi_d),
        )
    }

    /// Solid-angle weight of cell (i, j, k); see [`cell_weight`].
    pub fn cell_weight(&self, i: usize, j: usize, _k: usize) -> f64 {
        cell_weight(*self, i, j)
    }
}

impl Default for Dims {
    fn default() -> Self {
        Dims::MERL
    }
}

impl fmt::Display for Dims {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} x {} x {}", self.theta_h, self.theta_d, self.phi_d)
    }
}

/// Truncates a non-negative coordinate to a bin and clamps it into `[0, n)`.
///
/// Truncation (not rounding) is the reference's `(int)` cast. The upper clamp catches
/// θh = π/2, θd = π/2 and φd = π, whose coordinate is exactly `n`, and angles beyond the
/// table (pairs below the horizon); the lower one catches a NaN (the reference's cast of
/// a NaN is undefined; here it goes to bin 0).
#[inline]
fn clamp_bin(coord: f64, n: usize) -> usize {
    if coord >= 0.0 {
        // `as` saturates, so a huge coordinate cannot wrap before the clamp.
        (coord as usize).min(n - 1)
    } else {
        0
    }
}

/// Continuous θh index coordinate: `sqrt(((θh / (π/2)) · n) · n)`, 0 for θh ≤ 0.
///
/// The reference `theta_half_index` of `BRDFRead.cpp` in its operation order; the bin is
/// this value truncated. Cell i sits at coordinate i (mathematically), its bin covers
/// [i, i + 1).
#[inline]
pub fn theta_h_coord(theta_h: f64, n: usize) -> f64 {
    // The reference returns bin 0 for θh ≤ 0 before its sqrt.
    if theta_h <= 0.0 {
        return 0.0;
    }
    let n = n as f64;
    let t = (theta_h / FRAC_PI_2) * n;
    (t * n).sqrt()
}

/// Continuous θd index coordinate: `θd / (π · 0.5) · n` (reference `theta_diff_index`).
#[inline]
pub fn theta_d_coord(theta_d: f64, n: usize) -> f64 {
    theta_d / (PI * 0.5) * n as f64
}

/// Continuous φd index coordinate: φd folded by +π when negative (reciprocity:
/// f(φd) = f(φd + π)), then `φd / π · n`. In [0, n] for φd ∈ [−π, π]; `n` (φd = π) is
/// the same place as 0.
///
/// The reference writes `φd / π · 360 / 2` for n = 180; multiplying by 2n and halving
/// are both exact scalings by powers of two around one rounding, so `φd / π · n` is
/// the same number bit for bit.
#[inline]
pub fn phi_d_coord(phi_d: f64, n: usize) -> f64 {
    let p = if phi_d < 0.0 { phi_d + PI } else { phi_d };
    p / PI * n as f64
}

/// θh bin of the reference code: `floor(sqrt(θh / (π/2) · n · n))`, θh ≤ 0 → 0,
/// clamped into [0, n).
#[inline]
pub fn theta_h_bin(theta_h: f64, n: usize) -> usize {
    clamp_bin(theta_h_coord(theta_h, n), n)
}

/// θd bin of the reference code: `floor(θd / (π/2) · n)`, clamped into [0, n).
#[inline]
pub fn theta_d_bin(theta_d: f64, n: usize) -> usize {
    clamp_bin(theta_d_coord(theta_d, n), n)
}

/// φd bin of the reference code: φd (+π if negative), `floor(φd / π · n)`, clamped into
/// [0, n). φd = π falls into the last bin by the clamp, as in the reference (not into
/// bin 0, where reciprocity would put it).
#[inline]
pub fn phi_d_bin(phi_d: f64, n: usize) -> usize {
    clamp_bin(phi_d_coord(phi_d, n), n)
}

/// θh of a (possibly fractional) index coordinate: (u / n)² · π/2. Cell i's angle.
#[inline]
pub fn theta_h_angle(u: f64, n: usize) -> f64 {
    let t = u / n as f64;
    t * t * FRAC_PI_2
}

/// θd of an index coordinate: v / n · π/2.
#[inline]
pub fn theta_d_angle(v: f64, n: usize) -> f64 {
    v / n as f64 * FRAC_PI_2
}

/// φd of an index coordinate: w / n · π.
#[inline]
pub fn phi_d_angle(w: f64, n: usize) -> f64 {
    w / n as f64 * PI
}

/// Solid-angle weight of the cells in row (i, j) (the same for every k): the measure of
/// the set of (wi, wo) pairs whose bins are (i, j, k).
///
/// With dωi dωo = 4 cos θd · sin θh dθh dφh · sin θd dθd dφd (Rusinkiewicz 1998, the
/// Jacobian of the half/difference change of variables), integrated exactly over
/// θh ∈ [(i/n)² π/2, ((i+1)/n)² π/2], θd ∈ [j/n π/2, (j+1)/n π/2], φh over 2π, and φd
/// over two intervals of π/nφd (φd and φd + π fold into one cell):
///
/// w = 4 · 2π · (cos θh₀ − cos θh₁) · ½ (sin² θd₁ − sin² θd₀) · 2π/nφd.
///
/// The differences are evaluated as products, cos a − cos b = 2 sin((a+b)/2)
/// sin((b−a)/2) and sin² b − sin² a = sin(b+a) sin(b−a), which keep full relative
/// precision for the tiny bins near θh = 0. The weights of all cells sum to
/// 4 · 2π · 1 · ½ · 2π = 8π² (this includes the pairs below the horizon; the pairs
/// with both directions above it measure (2π)² = 4π²).
pub fn cell_weight(dims: Dims, i: usize, j: usize) -> f64 {
    let (a, b) = (
        theta_h_angle(i as f64, dims.theta_h),
        theta_h_angle((i + 1) as f64, dims.theta_h),
    );
    let (c, d) = (
        theta_d_angle(j as f64, dims.theta_d),
        theta_d_angle((j + 1) as f64, dims.theta_d),
    );
    let d_cos_h = 2.0 * (0.5 * (a + b)).sin() * (0.5 * (b - a)).sin();
    let int_d = 0.5 * (d + c).sin() * (d - c).sin();
    let phi = 2.0 * PI / dims.phi_d as f64;
    4.0 * (2.0 * PI) * d_cos_h * int_d * phi
}

/// Snaps a coordinate within 1e-9 of an integer onto it.
///
/// Mapping a target grid's cell angles to source coordinates goes through a square and
/// a square root (θh) or a division and multiplication (θd, φd); a target cell that
/// coincides with a source node (doubling or halving a grid) then lands a few ulps off
/// the integer, and a truncation would pick the cell below. Coordinates are at most
/// ~10³, so 1e-9 is far above round-off (~1e-13) and far below any real offset between
/// grids of sensible size.
#[inline]
pub fn snap_coord(x: f64) -> f64 {
    let r = x.round();
    if (x - r).abs() <= 1e-9 { r } else { x }
}

/// Cells per I/O run (reading: per parallel task; writing: per buffered write). A read
/// task reads this many values of each channel (3 × 64 KiB) into a per-thread buffer
/// that stays in L2, then converts, validates and stores
/// them and their mask entries in one pass. Longer runs mean fewer `pread` calls (three
/// per run): 16384 and 32768 cells saved 3–5 % of the CPU of a MERL read, at two and
/// four times the buffer (beyond L2 on smaller caches) and fewer tasks to balance.
pub const IO_CHUNK_CELLS: usize = 8 * 1024;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_round_trip() {
        let d = Dims::new(7, 5, 11).unwrap();
        for idx in 0..d.cells() {
            let (i, j, k) = d.unflatten(idx);
            assert!(i < 7 && j < 5 && k < 11);
            assert_eq!(d.index(i, j, k), idx);
        }
        assert_eq!(Dims::MERL.file_bytes(), 34_992_012);
    }

    #[test]
    fn dims_checks() {
        assert_eq!(Dims::new(0, 1, 1), Err(DimsError::NotPositive(0, 1, 1)));
        assert_eq!(Dims::new(2, -1, 1), Err(DimsError::NotPositive(2, -1, 1)));
        assert!(matches!(
            Dims::new(i32::MAX as i64, i32::MAX as i64, i32::MAX as i64),
            Err(DimsError::Overflow(..))
        ));
        assert_eq!(Dims::new(90, 90, 180), Ok(Dims::MERL));
    }

    #[test]
    fn snapping() {
        assert_eq!(snap_coord(2.0 - 1e-13), 2.0);
        assert_eq!(snap_coord(2.0 + 1e-12), 2.0);
        assert_eq!(snap_coord(2.5), 2.5);
        assert_eq!(snap_coord(2.0 + 1e-6), 2.0 + 1e-6);
    }
}
