//! Mitsuba 3: the material as a `<bsdf>` XML element and as a `load_dict` dictionary.

use crate::*;
use brdfkit_core::Rgb;
use serde_json::{Value, json};
use std::fmt::Write as _;

/// A Mitsuba plugin parameter, by its XML tag.
enum Param {
    Str(&'static str),
    Float(f64),
    Bool(bool),
    Rgb(Rgb),
}

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
        let (kind, params) = self.mitsuba_params();
        let _ = writeln!(s, "<bsdf type=\"{kind}\" version=\"3.0.0\">");
        for (name, v) in params {
            let _ = match v {
                Param::Str(t) => writeln!(s, "    <string name=\"{name}\" value=\"{t}\"/>"),
                Param::Float(x) => writeln!(s, "    <float name=\"{name}\" value=\"{x}\"/>"),
                Param::Bool(b) => writeln!(s, "    <boolean name=\"{name}\" value=\"{b}\"/>"),
                Param::Rgb(c) => {
                    let c = rgb_text(c, ", ");
                    writeln!(s, "    <rgb name=\"{name}\" value=\"{c}\"/>")
                }
            };
        }
        s += "</bsdf>\n";
        s
    }

    /// The Mitsuba 3 dictionary (for `mitsuba.load_dict`), as JSON: a JSON object with
    /// these values is also a Python dict literal. For a material mapped for
    /// [`Renderer::Mitsuba`]; the cross-check evaluates exactly this dictionary.
    pub fn mitsuba_dict(&self) -> Value {
        let (kind, params) = self.mitsuba_params();
        let mut d = serde_json::Map::new();
        d.insert("type".into(), json!(kind));
        for (name, v) in params {
            let v = match v {
                Param::Str(t) => json!(t),
                Param::Float(x) => json!(x),
                Param::Bool(b) => json!(b),
                Param::Rgb(c) => rgb_value(c),
            };
            d.insert(name.into(), v);
        }
        Value::Object(d)
    }

    /// The Mitsuba 3 plugin and its parameters in the XML's order: the one mapping that
    /// [`mitsuba_xml`](Self::mitsuba_xml) and [`mitsuba_dict`](Self::mitsuba_dict)
    /// both write, so the file and the cross-checked dictionary cannot differ.
    fn mitsuba_params(&self) -> (&'static str, Vec<(&'static str, Param)>) {
        match *self {
            RendererMaterial::Diffuse { reflectance } => {
                ("diffuse", vec![("reflectance", Param::Rgb(reflectance))])
            }
            RendererMaterial::Conductor {
                distribution,
                alpha,
                eta,
                k,
                specular,
            } => {
                let mut v = vec![("distribution", Param::Str(distribution.name()))];
                let alphas = alpha_entries(alpha, MITSUBA_ALPHA);
                v.extend(alphas.into_iter().map(|(name, a)| (name, Param::Float(a))));
                v.extend([
                    ("eta", Param::Rgb(eta)),
                    ("k", Param::Rgb(k)),
                    ("specular_reflectance", Param::Rgb(specular)),
                ]);
                ("roughconductor", v)
            }
            RendererMaterial::Plastic {
                diffuse,
                specular,
                alpha,
                eta,
                nonlinear,
            } => (
                "roughplastic",
                vec![
                    ("distribution", Param::Str("ggx")),
                    ("alpha", Param::Float(alpha)),
                    ("int_ior", Param::Float(eta)),
                    ("ext_ior", Param::Float(1.0)),
                    ("diffuse_reflectance", Param::Rgb(diffuse)),
                    ("specular_reflectance", Param::Rgb(specular)),
                    ("nonlinear", Param::Bool(nonlinear)),
                ],
            ),
        }
    }
}
