//! pbrt-v4: the material as a `Material` directive.

use crate::*;
use std::fmt::Write as _;

impl RendererMaterial {
    /// The pbrt-v4 `Material` directive, with `source` and `notes` as comments. For a
    /// material mapped for [`Renderer::Pbrt`] (ρs = 1: pbrt has no specular scale, so
    /// `specular` is not written).
    pub fn pbrt(&self, source: &str, notes: &[String]) -> String {
        let mut s = format!("# brdfkit export of {source}\n");
        for n in notes {
            let _ = writeln!(s, "# note: {n}");
        }
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                let _ = writeln!(
                    s,
                    "Material \"diffuse\" \"rgb reflectance\" [ {} ]",
                    rgb_text(*reflectance, " ")
                );
            }
            RendererMaterial::Conductor { alpha, eta, k, .. } => {
                s += "Material \"conductor\"\n";
                let names = ("roughness", "uroughness", "vroughness");
                for (name, a) in alpha_entries(*alpha, names) {
                    let _ = writeln!(s, "    \"float {name}\" [ {a} ]");
                }
                s += "    \"bool remaproughness\" false\n";
                let _ = writeln!(s, "    \"rgb eta\" [ {} ]", rgb_text(*eta, " "));
                let _ = writeln!(s, "    \"rgb k\" [ {} ]", rgb_text(*k, " "));
            }
            RendererMaterial::Plastic {
                diffuse,
                alpha,
                eta,
                ..
            } => {
                s += "Material \"coateddiffuse\"\n";
                let _ = writeln!(s, "    \"rgb reflectance\" [ {} ]", rgb_text(*diffuse, " "));
                let _ = writeln!(s, "    \"float roughness\" [ {alpha} ]");
                s += "    \"bool remaproughness\" false\n";
                let _ = writeln!(s, "    \"float eta\" [ {eta} ]");
            }
        }
        s
    }
}
