//! Resamples a neural proxy onto a MERL-format table and writes it.
//!
//! `cargo run --release -p brdfkit-nbrdf --example nbrdf_table -- DIR/NAME OUT.binary [NθH,NθD,NφD]`
//!
//! e.g. `data-measured/merl/gold-paint gold-paint.binary`: prints the cells, the missing
//! cells, the clamped values and the time of the resample.

use brdfkit_merl::Dims;
use brdfkit_nbrdf::Nbrdf;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(2..=3).contains(&args.len()) {
        eprintln!("usage: nbrdf_table DIR/NAME OUT.binary [NθH,NθD,NφD]");
        return ExitCode::from(2);
    }
    let dims = match args.get(2) {
        None => Dims::MERL,
        Some(s) => {
            let n: Vec<i64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
            match n[..] {
                [a, b, c] => match Dims::new(a, b, c) {
                    Ok(d) => d,
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::from(2);
                    }
                },
                _ => {
                    eprintln!("error: dims must be three integers, e.g. 90,90,180");
                    return ExitCode::from(2);
                }
            }
        }
    };
    let net = match Nbrdf::load(&PathBuf::from(&args[0])) {
        Ok(n) => n,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let t = Instant::now();
    let (table, st) = match net.to_table(dims) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let secs = t.elapsed().as_secs_f64();
    if let Err(e) = table.write(std::path::Path::new(&args[1])) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    println!(
        "{}: {} cells, {} missing ({:.2} %), {} values clamped to 0 in {} cells (most negative {:.3e} /sr); resampled in {:.3} s",
        net.name(),
        st.cells,
        st.missing,
        100.0 * st.missing_fraction(),
        st.clamped_values,
        st.clamped_cells,
        st.most_negative,
        secs
    );
    ExitCode::SUCCESS
}
