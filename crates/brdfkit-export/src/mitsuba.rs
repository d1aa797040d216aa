//! Mitsuba 3: the material as a `<bsdf>` XML element and as a `load_dict` dictionary.

use crate::*;
use serde_json::{Value, json};
use std::fmt::Write as _;

/// Mitsuba's names for an isotropic α and for αu, αv.
const MITSUBA_ALPHA: (&str, &str, &str) = ("alpha", "alpha_u", "alpha_v");

impl RendererMaterial {
    /// The Mitsuba 3 XML `<bsdf>` element (loadable by `mitsuba.load_string`), with
    /// `source` and `notes` as comments. For a material mapped for [`Renderer::Mitsuba`].
    pub fn mitsuba_xml(&self, source: &str, notes: &[String]) -> String {
        // "--" may not appear inside an XML comment.
        let safe = |t: &str| t.replace("--", "- -");
        let mut s = format!("<!-- brdfkit export of {} -->\n", safe(source));
        s += "<!-- standalone: mitsuba.load_string(text); inside a scene file, drop version=\"3.0.0\" \
              (Mitsuba accepts it on the root element only) -->\n";
        for n in notes {
            let _ = writeln!(s, "<!-- note: {} -->", safe(n));
        }
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                s += "<bsdf type=\"diffuse\" version=\"3.0.0\">\n";
                let _ = writeln!(
                    s,
                    "    <rgb name=\"reflectance\" value=\"{}\"/>",
                    rgb_text(*reflectance, ", ")
                );
            }
            RendererMaterial::Conductor {
                distribution,
                alpha,
                eta,
                k,
                specular,
            } => {
                s += "<bsdf type=\"roughconductor\" version=\"3.0.0\">\n";
                let _ = writeln!(
                    s,
                    "    <string name=\"distribution\" value=\"{}\"/>",
                    distribution.name()
                );
                for (name, a) in alpha_entries(*alpha, MITSUBA_ALPHA) {
                    let _ = writeln!(s, "    <float name=\"{name}\" value=\"{a}\"/>");
                }
                let _ = writeln!(
                    s,
                    "    <rgb name=\"eta\" value=\"{}\"/>",
                    rgb_text(*eta, ", ")
                );
                let _ = writeln!(s, "    <rgb name=\"k\" value=\"{}\"/>", rgb_text(*k, ", "));
                let _ = writeln!(
                    s,
                    "    <rgb name=\"specular_reflectance\" value=\"{}\"/>",
                    rgb_text(*specular, ", ")
                );
            }
            RendererMaterial::Plastic {
                diffuse,
                specular,
                alpha,
                eta,
                nonlinear,
            } => {
                s += "<bsdf type=\"roughplastic\" version=\"3.0.0\">\n";
                s += "    <string name=\"distribution\" value=\"ggx\"/>\n";
                let _ = writeln!(s, "    <float name=\"alpha\" value=\"{alpha}\"/>");
                let _ = writeln!(s, "    <float name=\"int_ior\" value=\"{eta}\"/>");
                s += "    <float name=\"ext_ior\" value=\"1\"/>\n";
                for (name, c) in [
                    ("diffuse_reflectance", diffuse),
                    ("specular_reflectance", specular),
                ] {
                    let _ = writeln!(
                        s,
                        "    <rgb name=\"{name}\" value=\"{}\"/>",
                        rgb_text(*c, ", ")
                    );
                }
                let _ = writeln!(s, "    <boolean name=\"nonlinear\" value=\"{nonlinear}\"/>");
            }
        }
        s += "</bsdf>\n";
        s
    }

    /// The Mitsuba 3 dictionary (for `mitsuba.load_dict`), as JSON: a JSON object with
    /// these values is also a Python dict literal. For a material mapped for
    /// [`Renderer::Mitsuba`]; the cross-check evaluates exactly this dictionary.
    pub fn mitsuba_dict(&self) -> Value {
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                json!({"type": "diffuse", "reflectance": rgb_value(*reflectance)})
            }
            RendererMaterial::Conductor {
                distribution,
                alpha,
                eta,
                k,
                specular,
            } => {
                let mut d = json!({"type": "roughconductor", "distribution": distribution.name(),
                    "eta": rgb_value(*eta), "k": rgb_value(*k),
                    "specular_reflectance": rgb_value(*specular)});
                for (name, a) in alpha_entries(*alpha, MITSUBA_ALPHA) {
                    d[name] = json!(a);
                }
                d
            }
            RendererMaterial::Plastic {
                diffuse,
                specular,
                alpha,
                eta,
                nonlinear,
            } => json!({"type": "roughplastic", "distribution": "ggx", "alpha": alpha,
                "int_ior": eta, "ext_ior": 1.0, "diffuse_reflectance": rgb_value(*diffuse),
                "specular_reflectance": rgb_value(*specular), "nonlinear": nonlinear}),
        }
    }
}
