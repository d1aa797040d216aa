//! [`MerlTable`]: the three channel planes, the missing-sample mask, access and
//! in-memory construction.

use crate::error::{BadValue, Channel, TableError};
use crate::grid::Dims;
use brdfkit_core::Rgb;
use rayon::prelude::*;
use std::sync::OnceLock;

/// Scale factors from raw file values to physical reflectance (1/sr), R, G, B:
/// 1/1500, 1.15/1500, 1.66/1500 (`RED_SCALE`, `GREEN_SCALE`, `BLUE_SCALE` of the
/// reference `BRDFRead.cpp`, computed the same way).
pub const SCALES: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// The raw value written for a missing cell of a table built in memory.
pub const MISSING_RAW: f64 = -1.0;

/// The largest magnitude a raw value may have. MERL's brightest raw values are of order
/// 1e4; a value beyond ±1e30 is corruption, not a measurement, and reading or building
/// a table with one is an error rather than a silent clamp.
pub const MAX_ABS_RAW: f64 = 1e30;

/// A raw value the format accepts: finite and within ±[`MAX_ABS_RAW`] (NaN is not).
#[inline]
pub(crate) fn acceptable_raw(x: f64) -> bool {
    x.abs() <= MAX_ABS_RAW
}

/// A measured isotropic BRDF on the (θh, θd, φd) grid.
///
/// # Storage
/// The table keeps the file's **raw** values (three planes R, G, B, each in file order
/// `k + nφd · (j + nθd · i)`) and converts to physical units on access,
/// `value = raw × scale` ([`SCALES`]). Keeping the raw values is what makes a
/// read-then-write reproduce the file bit for bit: `raw × scale / scale` differs from
/// `raw` by an ulp for 8–14 % of values (measured over 10⁶ log-uniform raw values per
/// channel; R 14 %, G 14 %, B 8 %), so physical values alone could not give the raw
/// ones back. Keeping only raw values (not both) also keeps reading to one pass over
/// one buffer; the multiplication on access is negligible next to a lookup.
/// Tables built from physical values store `raw = value / scale`; reading them back
/// gives `(value / scale) × scale`, within one ulp of `value`.
///
/// # Missing samples
/// A cell is missing when any of its three raw values is negative (< 0; −0.0 is a valid
/// zero). Missing cells stay missing: they are never clamped to zero nor averaged in;
/// accessors return `None` for them. A missing cell keeps its raw values, so the file
/// writes back unchanged; cells marked missing in memory are written with raw −1.0.
#[derive(Clone, Debug, PartialEq)]
pub struct MerlTable {
    pub(crate) dims: Dims,
    /// 3 × cells raw values: the R plane, then G, then B.
    pub(crate) raw: Vec<f64>,
    /// Per cell: true when all three raw values are ≥ 0 (or −0.0).
    pub(crate) valid: Vec<bool>,
    pub(crate) n_valid: usize,
    /// The physical values cell by cell, built by the first large nearest lookup.
    pub(crate) cells: CellCache,
}

/// Values per cell in a [`CellCache`]: R, G, B and a pad, so that a cell is 32 bytes
/// aligned to 32 and never straddles two cache lines.
pub(crate) const CELL_STRIDE: usize = 4;

/// The table's physical values interleaved per cell (R, G, B, pad; NaN in all four for a
/// missing cell), for random lookups: one cache line per lookup instead of one per
/// channel plane. Random nearest lookups of a MERL table read three lines of three
/// 11.7 MB planes per pair, and the processor can only have so many misses in flight,
/// so the reads cost more than the arithmetic once that was vectorised
/// (docs/performance.md). Built on demand by the first batch large enough to pay for it
/// ([`MerlTable::cells_for`]) and kept, so that a table that is never looked up in bulk
/// (a fit, a report) holds no copy; dropped by any change to the table. A clone starts
/// without it; equality ignores it (it is a function of the raw values).
#[derive(Debug, Default)]
pub(crate) struct CellCache(pub(crate) OnceLock<(Vec<f64>, usize)>);

impl Clone for CellCache {
    fn clone(&self) -> Self {
        CellCache::default()
    }
}

impl PartialEq for CellCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Validity of a cell from its raw values: all three non-negative. A comparison with
/// NaN is false, but NaN never gets here (reading and construction reject it).
#[inline]
pub(crate) fn raw_valid(r: f64, g: f64, b: f64) -> bool {
    (r >= 0.0) & (g >= 0.0) & (b >= 0.0)
}

impl MerlTable {
    /// A table of `dims` with every cell missing (raw −1.0).
    pub fn all_missing(dims: Dims) -> Self {
        let mut raw = alloc_raw(dims.cells());
        raw.fill(MISSING_RAW);
        MerlTable::assemble(dims, raw, vec![false; dims.cells()], 0)
    }

    /// The table of checked planes: `valid` is each cell's mask and `n_valid` its count
    /// (the callers have just computed both); the cell geometry is built on first use.
    pub(crate) fn assemble(dims: Dims, raw: Vec<f64>, valid: Vec<bool>, n_valid: usize) -> Self {
        MerlTable {
            dims,
            raw,
            valid,
            n_valid,
            cells: CellCache::default(),
        }
    }

    /// A table from raw values (3 planes, file order). Fails on a wrong length or a
    /// non-finite value or one beyond ±[`MAX_ABS_RAW`]; negative values become missing cells.
    pub fn from_raw(dims: Dims, raw: Vec<f64>) -> Result<Self, TableError> {
        let n = dims.cells();
        if raw.len() != 3 * n {
            return Err(TableError::Length {
                dims,
                expected: 3 * n,
                actual: raw.len(),
            });
        }
        if let Some((bad, _)) = BadValue::first_in(&raw, dims, acceptable_raw) {
            return Err(TableError::bad_raw(bad));
        }
        let (valid, n_valid) = mask_of(&raw, n);
        Ok(MerlTable::assemble(dims, raw, valid, n_valid))
    }

    /// A table whose cell (i, j, k) is `f(i, j, k)` in physical units (`None`: missing),
    /// evaluated in parallel over θh slabs. Values must be finite and non-negative.
    pub fn from_fn<F>(dims: Dims, f: F) -> Result<Self, TableError>
    where
        F: Fn(usize, usize, usize) -> Option<Rgb> + Sync,
    {
        Self::try_from_raw_fn(dims, |i, j, k| to_raw(f(i, j, k), i, j, k))
    }

    /// A table whose cell (i, j, k) holds the raw values `raw(i, j, k)` (R, G, B; a
    /// negative one marks the cell missing), filled in parallel over θh slabs; the
    /// first error ends it.
    pub(crate) fn try_from_raw_fn<E, F>(dims: Dims, raw_of: F) -> Result<Self, E>
    where
        E: Send,
        F: Fn(usize, usize, usize) -> Result<[f64; 3], E> + Sync,
    {
        let n = dims.cells();
        let slab = dims.theta_d() * dims.phi_d();
        let mut raw = alloc_raw(n);
        let mut valid = vec![false; n];
        let (r, gb) = raw.split_at_mut(n);
        let (g, b) = gb.split_at_mut(n);
        r.par_chunks_mut(slab)
            .zip(g.par_chunks_mut(slab))
            .zip(b.par_chunks_mut(slab))
            .zip(valid.par_chunks_mut(slab))
            .enumerate()
            .try_for_each(|(i, (((r, g), b), v))| {
                for j in 0..dims.theta_d() {
                    for k in 0..dims.phi_d() {
                        let c = k + dims.phi_d() * j;
                        let x = raw_of(i, j, k)?;
                        (r[c], g[c], b[c]) = (x[0], x[1], x[2]);
                        v[c] = raw_valid(x[0], x[1], x[2]);
                    }
                }
                Ok(())
            })?;
        let n_valid = valid.par_iter().filter(|&&v| v).count();
        Ok(MerlTable::assemble(dims, raw, valid, n_valid))
    }

    /// Grid dimensions.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Number of cells (per channel).
    pub fn cells(&self) -> usize {
        self.dims.cells()
    }

    /// Number of valid (not missing) cells.
    pub fn valid_count(&self) -> usize {
        self.n_valid
    }

    /// Fraction of valid cells.
    pub fn valid_fraction(&self) -> f64 {
        self.n_valid as f64 / self.cells() as f64
    }

    /// The raw values: 3 planes (R, G, B) in file order.
    pub fn raw(&self) -> &[f64] {
        &self.raw
    }

    /// The raw plane of one channel.
    pub fn raw_plane(&self, c: Channel) -> &[f64] {
        let n = self.cells();
        &self.raw[c.index() * n..(c.index() + 1) * n]
    }

    /// The per-cell validity mask (true = a sample; false = missing), file order.
    pub fn valid_mask(&self) -> &[bool] {
        &self.valid
    }

    /// True when cell `index` holds a sample.
    #[inline]
    pub fn is_valid(&self, index: usize) -> bool {
        self.valid[index]
    }

    /// Raw values (R, G, B) of cell `index`, missing or not.
    #[inline]
    pub fn raw_at(&self, index: usize) -> [f64; 3] {
        let n = self.cells();
        [
            self.raw[index],
            self.raw[n + index],
            self.raw[2 * n + index],
        ]
    }

    /// Physical value of cell `index` (flat), `None` when missing. Panics when `index`
    /// is out of range, like slice indexing.
    #[inline]
    pub fn get_flat(&self, index: usize) -> Option<Rgb> {
        // Validity from the raw signs (the mask's definition) rather than the mask:
        // one round of independent loads instead of a load, a branch, then three more,
        // which matters for random lookups into a 35 MB table.
        let r = self.raw_at(index);
        raw_valid(r[0], r[1], r[2])
            .then(|| Rgb::new(r[0] * SCALES[0], r[1] * SCALES[1], r[2] * SCALES[2]))
    }

    /// The interleaved cell values ([`CellCache`], [`CELL_STRIDE`] per cell) for a batch
    /// of `pairs` lookups: built when the batch has at least an eighth as many pairs as
    /// the table has cells (building them reads every cell once; a smaller batch reads
    /// the planes), or kept from an earlier batch. `None`: read the planes.
    pub(crate) fn cells_for(&self, pairs: usize) -> Option<&[f64]> {
        let c = match self.cells.0.get() {
            Some(c) => c,
            None if pairs < self.cells() / 8 => return None,
            None => self.cells.0.get_or_init(|| self.interleave()),
        };
        Some(&c.0[c.1..c.1 + CELL_STRIDE * self.cells()])
    }

    /// The physical values per cell, in parallel, and the offset of the first cell: a
    /// multiple of 64 bytes from the buffer's start; see [`CellCache`].
    fn interleave(&self) -> (Vec<f64>, usize) {
        let n = self.cells();
        let mut buf = zeroed_f64(CELL_STRIDE * n + 8);
        let at = (buf.as_ptr() as usize).next_multiple_of(64) - buf.as_ptr() as usize;
        let at = at / 8;
        let out = &mut buf[at..at + CELL_STRIDE * n];
        let run = crate::grid::IO_CHUNK_CELLS;
        spread(out.chunks_mut(CELL_STRIDE * run).collect(), |q, out| {
            let (out, _) = out.as_chunks_mut::<CELL_STRIDE>();
            for (x, o) in (q * run..).zip(out) {
                *o = match self.get_flat(x) {
                    Some(v) => [v[0], v[1], v[2], 0.0],
                    None => [f64::NAN; CELL_STRIDE],
                };
            }
        });
        (buf, at)
    }

    /// Physical value of cell (i, j, k), `None` when missing or out of range.
    pub fn get(&self, i: usize, j: usize, k: usize) -> Option<Rgb> {
        if i >= self.dims.theta_h() || j >= self.dims.theta_d() || k >= self.dims.phi_d() {
            return None;
        }
        self.get_flat(self.dims.index(i, j, k))
    }

    /// Sets cell (i, j, k) to a physical value (stored as raw = value / scale), or marks
    /// it missing (raw −1.0) with `None`.
    pub fn set(
        &mut self,
        i: usize,
        j: usize,
        k: usize,
        value: Option<Rgb>,
    ) -> Result<(), TableError> {
        if i >= self.dims.theta_h() || j >= self.dims.theta_d() || k >= self.dims.phi_d() {
            return Err(TableError::OutOfRange {
                dims: self.dims,
                i,
                j,
                k,
            });
        }
        let raw = to_raw(value, i, j, k)?;
        self.set_raw_flat(self.dims.index(i, j, k), raw);
        Ok(())
    }

    /// Stores raw values into cell `index` and updates the mask (values checked finite
    /// by the caller).
    pub(crate) fn set_raw_flat(&mut self, index: usize, raw: [f64; 3]) {
        let n = self.cells();
        self.cells = CellCache::default();
        let was = self.valid[index];
        self.raw[index] = raw[0];
        self.raw[n + index] = raw[1];
        self.raw[2 * n + index] = raw[2];
        let now = raw_valid(raw[0], raw[1], raw[2]);
        self.valid[index] = now;
        self.n_valid = self.n_valid + now as usize - was as usize;
    }
}

pub(crate) use brdfkit_core::par::spread;

/// A zeroed buffer for the 3 raw planes of `n` cells, on transparent huge pages where
/// the system allows (see [`huge_capacity`]).
pub(crate) fn alloc_raw(n: usize) -> Vec<f64> {
    zeroed_f64(3 * n)
}

/// A zeroed buffer of `len` values, on transparent huge pages where the system allows
/// (from 1 MiB up, with `MADV_HUGEPAGE`), for the large arrays of bulk lookups:
/// the N × 6 pairs read from a file and the N × 3 values written back. With 4 KiB pages
/// their first-touch faults (17,000 for the 70 MB of 1.46 M pairs) cost more CPU than
/// the lookups themselves (`fit-brdf eval`, docs/performance.md).
pub fn zeroed_f64(len: usize) -> Vec<f64> {
    zeroed_f64_on_pages(len, huge_capacity(len * 8) / 8)
}

/// [`zeroed_f64`] without its rounding up to whole huge pages: the 2 MiB regions
/// wholly inside the buffer get huge pages, its two ends 4 KiB ones. For the many
/// long-lived columns of a fit's cells, where the rounding's whole huge pages past
/// each column's end added 22 MB to a default fit's peak (14 columns), for about 500
/// fewer 4 KiB faults a column.
pub fn zeroed_f64_exact(len: usize) -> Vec<f64> {
    zeroed_f64_on_pages(len, len)
}

/// A zeroed buffer of `len` values in an allocation of `capacity` (≥ `len`), advised
/// onto huge pages ([`advise_huge_pages`]).
fn zeroed_f64_on_pages(len: usize, capacity: usize) -> Vec<f64> {
    // `vec![0.0; _]` is a `calloc`: fresh pages the kernel zeroes on first touch, not a
    // zeroing pass here, so the advice below still applies to every page but the first.
    let mut v = vec![0.0f64; capacity];
    v.truncate(len);
    advise_huge_pages(v.as_ptr().cast(), v.capacity() * 8);
    v
}

/// An all-false validity mask of `n` cells, on a huge page where possible: the MERL
/// mask is 1.46 MB, 357 first-touch faults of 4 KiB pages (about 0.6 ms) otherwise.
pub(crate) fn alloc_mask(n: usize) -> Vec<bool> {
    let mut valid = vec![false; huge_capacity(n)];
    valid.truncate(n);
    advise_huge_pages(valid.as_ptr().cast(), valid.capacity());
    valid
}

/// Size of a transparent huge page on x86-64 and (with 4 KiB base pages) aarch64.
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;

/// Bytes an allocator may keep in front of a large block: glibc puts a 16-byte header
/// before the data and maps the request plus that header, rounded up to a page.
#[cfg(target_os = "linux")]
const ALLOC_SLACK: usize = 64;

/// Whether huge-page advice is on: `BRDFKIT_NO_THP` (any value) turns it off, to
/// measure its effect.
#[cfg(target_os = "linux")]
fn huge_pages_wanted() -> bool {
    std::env::var_os("BRDFKIT_NO_THP").is_none()
}

/// The capacity in bytes to request for a buffer of `bytes` so that the allocation can
/// lie on whole huge pages: rounded up so that the allocator's mapping (the block plus
/// [`ALLOC_SLACK`]) is a multiple of 2 MiB, which Linux then places 2 MiB-aligned.
/// Without this the partial huge pages at both ends (on average 2 MiB in total, about
/// 500 pages) fault in 4 KiB at a time, each fault costing about 1.7 µs more than its
/// share of a huge-page fault on the project machine. Only when the rounding adds at
/// most half again (buffers from 1 MiB up); otherwise `bytes` unchanged.
#[cfg(target_os = "linux")]
fn huge_capacity(bytes: usize) -> usize {
    let Some(rounded) = (bytes + ALLOC_SLACK)
        .checked_next_multiple_of(HUGE)
        .map(|r| r - ALLOC_SLACK)
    else {
        return bytes;
    };
    if huge_pages_wanted() && bytes >= HUGE / 2 && rounded - bytes <= bytes / 2 {
        rounded
    } else {
        bytes
    }
}

#[cfg(not(target_os = "linux"))]
fn huge_capacity(bytes: usize) -> usize {
    bytes
}

/// Asks Linux to back a fresh, still untouched allocation of `bytes` at `start` with
/// transparent huge pages.
///
/// Reading a table is dominated by first-touch page faults of its new buffer (35 MB is
/// 8,500 faults of 4 KiB pages; measured at about half of the read time), not by the
/// copy; and random lookups into 35 MB miss the TLB on nearly every access with 4 KiB
/// pages. With `transparent_hugepage` in `madvise` mode (a common default) the advice
/// cuts both 512-fold; in `always` mode it changes nothing, in `never` mode it is
/// ignored. Setting the environment variable `BRDFKIT_NO_THP` skips it.
///
/// The range is widened to whole pages, so that it covers the allocator's header page
/// too: `MADV_HUGEPAGE` on a range starting one page into a mapping would split the
/// mapping there and leave its first 2 MiB on 4 KiB pages. That header page is already
/// touched (the allocator wrote its header), which alone keeps the fault handler from
/// putting a huge page there; when the block starts in the first page of a 2 MiB-aligned
/// region (the usual case with [`huge_capacity`]) that region is collapsed into a huge
/// page at once (`MADV_COLLAPSE`, Linux 6.1+) rather than faulted 512 times.
///
/// Purely advisory: the calls change how memory is backed, never its contents, and any
/// failure (old kernel, THP disabled, no free huge page) leaves 4 KiB pages.
#[cfg(target_os = "linux")]
fn advise_huge_pages(start: *const u8, bytes: usize) {
    /// `MADV_COLLAPSE` from linux/mman.h (libc defines it for glibc targets only).
    const MADV_COLLAPSE: libc::c_int = 25;
    if bytes < HUGE / 2 || !huge_pages_wanted() {
        return;
    }
    // SAFETY: sysconf has no preconditions.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    let page = if page > 0 { page as usize } else { 4096 };
    let start = start as usize;
    let first = start / page * page;
    let end = (start + bytes).next_multiple_of(page);
    // SAFETY: [first, end) is the allocation widened to the pages it lies on, all mapped
    // in this process; MADV_HUGEPAGE only changes how the kernel backs them: the
    // contents, ours and the allocator's, are unaffected, so no Rust invariant depends
    // on the call.
    unsafe {
        libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
    }
    let region = start / HUGE * HUGE;
    if start - region < page && region + HUGE <= end {
        // SAFETY: the region lies within [first, end), mapped as above; MADV_COLLAPSE
        // copies the present pages into a huge page under the kernel's locks and keeps
        // every byte.
        unsafe {
            libc::madvise(region as *mut libc::c_void, HUGE, MADV_COLLAPSE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: *const u8, _bytes: usize) {}

/// Raw values of a physical value: value / scale per channel; `None` → raw −1.0.
fn to_raw(value: Option<Rgb>, i: usize, j: usize, k: usize) -> Result<[f64; 3], TableError> {
    let Some(v) = value else {
        return Ok([MISSING_RAW; 3]);
    };
    let mut raw = [0.0; 3];
    for c in Channel::ALL {
        let x = v[c.index()];
        let bad = BadValue {
            channel: c,
            i,
            j,
            k,
            value: x,
        };
        if !x.is_finite() {
            return Err(TableError::NonFinite(bad));
        }
        if (x / SCALES[c.index()]).abs() > MAX_ABS_RAW {
            return Err(TableError::TooLarge(bad));
        }
        if x < 0.0 {
            return Err(TableError::Negative(bad));
        }
        raw[c.index()] = x / SCALES[c.index()];
    }
    Ok(raw)
}

/// The validity mask of 3 raw planes of `n` cells, and the number of valid cells.
pub(crate) fn mask_of(raw: &[f64], n: usize) -> (Vec<bool>, usize) {
    let (r, gb) = raw.split_at(n);
    let (g, b) = gb.split_at(n);
    let valid: Vec<bool> = r
        .iter()
        .zip(g)
        .zip(b)
        .map(|((&r, &g), &b)| raw_valid(r, g, b))
        .collect();
    let n_valid = valid.iter().filter(|&&v| v).count();
    (valid, n_valid)
}
