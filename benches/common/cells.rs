//! The cells file `benches/peers/fit_scipy.py` reads (shared by the `fit` and `peers`
//! benches): 8 bytes `BRDFCELL`, u64 n, then 14 little-endian float64 arrays of n
//! values — the 10 geometry columns, the 3 value planes, the solid-angle measures.

use brdfkit::fit::FitData;
use std::io::Write;
use std::path::Path;

/// Writes `data` in the cells format.
pub fn write_cells(data: &FitData, path: &Path) -> std::io::Result<()> {
    let g = data.geometry();
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    f.write_all(b"BRDFCELL")?;
    f.write_all(&(data.len() as u64).to_le_bytes())?;
    let v = data.values();
    for col in [
        &g.wi_x, &g.wi_y, &g.wi_z, &g.wo_x, &g.wo_y, &g.wo_z, &g.h_x, &g.h_y, &g.h_z, &g.cos_d,
        &v[0], &v[1], &v[2],
    ] {
        for x in col.iter() {
            f.write_all(&x.to_le_bytes())?;
        }
    }
    for x in data.measure() {
        f.write_all(&x.to_le_bytes())?;
    }
    f.flush()
}
