//! The demo's embedded materials: the measured default and the synthetic one.

use crate::error::{CliResult, runtime};
use brdfkit::core::{Brdf, Rgb, Vec3};
use brdfkit::merl::{Dims, MerlTable};
use brdfkit::nbrdf::Nbrdf;
use brdfkit::synth::SynthSpec;

/// The embedded synthetic material (`--synthetic`).
pub const DEMO_SPEC: &str = include_str!("../../../../data-synthetic/demo-plastic.toml");

/// The embedded measured material (the default): its name and its six NBRDF files.
const MEASURED: &str = "specular-red-phenolic";
macro_rules! part {
    ($p:literal) => {
        include_bytes!(concat!(
            "../../../../data-measured/merl/specular-red-phenolic_",
            $p,
            ".npy"
        ))
    };
}
const MEASURED_PARTS: [&[u8]; 6] = [
    part!("fc1"),
    part!("b1"),
    part!("fc2"),
    part!("b2"),
    part!("fc3"),
    part!("b3"),
];

/// f_r of the material the table was made from.
pub type Truth = Box<dyn Fn(&Vec3, &Vec3) -> Rgb>;

/// The demo's material: a table and the function it was made from.
pub struct Material {
    pub name: String,
    pub about: String,
    pub table: MerlTable,
    pub truth: Truth,
}

pub fn material(synthetic: bool) -> CliResult<Material> {
    if synthetic {
        let spec =
            SynthSpec::from_toml_str(DEMO_SPEC, "embedded demo-plastic.toml").map_err(runtime)?;
        return Ok(Material {
            name: spec.name.clone(),
            about: spec.description.clone(),
            table: spec.synthesize().map_err(runtime)?,
            truth: Box::new(move |wi, wo| spec.truth(wi, wo)),
        });
    }
    let net = Nbrdf::from_npy_bytes(MEASURED, MEASURED_PARTS).map_err(runtime)?;
    let (table, stats) = net.to_table(Dims::MERL).map_err(runtime)?;
    Ok(Material {
        name: MEASURED.into(),
        about: format!(
            "measured: MERL BRDF database (Matusik et al. 2003), through its neural proxy \
             (Sztrajman et al. 2021, data-measured/README.md); {} negative values stored as 0",
            stats.clamped_values
        ),
        table,
        truth: Box::new(move |wi, wo| net.eval(wi, wo)),
    })
}
