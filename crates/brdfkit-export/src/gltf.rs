//! glTF 2.0: the metallic-roughness material and its KHR extensions, as a document.

use crate::*;
use brdfkit_core::scattering::Masking;
use brdfkit_core::{Rgb, downcast};
use brdfkit_models::gltf_pbr::GltfPbr;
use brdfkit_models::gltf_pbr_ext::{Clearcoat, GltfPbrExt, Sheen, Specular};
use brdfkit_models::sheen::SheenVisibility;
use serde_json::{Value, json};

/// A glTF 2.0 metallic-roughness material: the factors of `pbrMetallicRoughness`.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfMaterial {
    /// `baseColorFactor` (RGB; alpha is 1).
    pub base_color: Rgb,
    /// `metallicFactor`.
    pub metallic: f64,
    /// `roughnessFactor`.
    pub roughness: f64,
    /// The masking the model was fitted with (glTF has no field for it: a note).
    pub masking: Masking,
    /// `KHR_materials_sheen`, if the model has it.
    pub sheen: Option<Sheen>,
    /// The sheen visibility the model was fitted with (a note).
    pub sheen_visibility: SheenVisibility,
    /// `KHR_materials_clearcoat`, if the model has it.
    pub clearcoat: Option<Clearcoat>,
    /// `KHR_materials_specular` and `KHR_materials_ior`, if the model has them.
    pub specular: Option<Specular>,
}

/// The glTF material of a `gltf-pbr` or `gltf-pbr-ext` description (and the model in
/// words), or why not.
pub fn gltf_material(description: &Value) -> Result<(GltfMaterial, String), ExportError> {
    if description.get("per_channel").is_some() {
        return Err(ExportError::PerChannel);
    }
    let model = brdfkit_models::from_json(description)?;
    let g = if let Some(core) = downcast::<GltfPbr>(model.as_ref()) {
        GltfPbrExt::new(core.clone())
    } else if let Some(ext) = downcast::<GltfPbrExt>(model.as_ref()) {
        ext.clone()
    } else {
        return Err(ExportError::NotGltf {
            model: model.name().into(),
        });
    };
    let core = g.core();
    let mut words = format!("{} ({}", model.name(), core.masking().name());
    for e in g.extensions() {
        words += &format!(", {e}");
    }
    words += ")";
    Ok((
        GltfMaterial {
            base_color: core.base_color(),
            metallic: core.metallic(),
            roughness: core.roughness(),
            masking: core.masking(),
            sheen: g.sheen(),
            sheen_visibility: g.sheen_visibility(),
            clearcoat: g.clearcoat(),
            specular: g.specular(),
        },
        words,
    ))
}

impl GltfMaterial {
    /// What a glTF viewer does differently (the document's `extras`, stderr).
    pub fn notes(&self) -> Vec<String> {
        vec![
            format!(
                "fitted with the {} Smith term; glTF viewers differ here (the Khronos Sample \
                 Renderer, three.js and Filament use the height-correlated form, the \
                 specification's text the separable one): highlights of rough materials \
                 differ by a few percent",
                self.masking.name()
            ),
            "factors are linear RGB, as glTF's baseColorFactor is; viewers evaluate in float32"
                .into(),
        ]
        .into_iter()
        .chain(self.extension_notes())
        .collect()
    }

    /// Where viewers may differ from the model on its extensions.
    fn extension_notes(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.sheen.is_some() {
            v.push(format!(
                "sheen fitted with the {} visibility and brdfkit's own table of the sheen \
                 albedo E (clamped to 1); viewers choose their visibility and E table \
                 (three.js: Charlie D with the Ashikhmin form, its `V_Neubelt`), so grazing sheen differs; \
                 Blender 3.4's importer adds a Velvet BSDF (sheenColor, sigma = sheenRoughness) to \
                 the Principled BSDF instead, without scaling the base (docs/export.md)",
                self.sheen_visibility.name()
            ));
        }
        if self.clearcoat.is_some() {
            v.push(
                "clear coat layered with fresnel_coat's Fresnel at N·V, as \
                 KHR_materials_clearcoat specifies (three.js also puts Schlick's Fresnel at \
                 V·H on the coat lobe)"
                    .into(),
            );
        }
        if self.specular.is_some() {
            v.push(
                "Blender 3.4's importer maps specularColor and ior to the Principled Specular \
                 (lum(specularColor) · f0(ior) / 0.08) and Specular Tint and ignores \
                 specularFactor (kept on its glTF Material Output node only): a specularFactor \
                 far from 1 looks different there (docs/export.md)"
                    .into(),
            );
        }
        v
    }

    /// The `extensions` object of the material and the names for `extensionsUsed`.
    fn extensions(&self) -> (serde_json::Map<String, Value>, Vec<&'static str>) {
        let mut m = serde_json::Map::new();
        if let Some(s) = self.sheen {
            let c = s.color;
            m.insert(
                "KHR_materials_sheen".into(),
                json!({"sheenColorFactor": [c.r(), c.g(), c.b()], "sheenRoughnessFactor": s.roughness}),
            );
        }
        if let Some(c) = self.clearcoat {
            m.insert(
                "KHR_materials_clearcoat".into(),
                json!({"clearcoatFactor": c.factor, "clearcoatRoughnessFactor": c.roughness}),
            );
        }
        if let Some(s) = self.specular {
            let c = s.color;
            m.insert(
                "KHR_materials_specular".into(),
                json!({"specularFactor": s.factor, "specularColorFactor": [c.r(), c.g(), c.b()]}),
            );
            m.insert("KHR_materials_ior".into(), json!({"ior": s.ior}));
        }
        let used = [
            "KHR_materials_sheen",
            "KHR_materials_clearcoat",
            "KHR_materials_specular",
            "KHR_materials_ior",
        ]
        .into_iter()
        .filter(|k| m.contains_key(*k))
        .collect();
        (m, used)
    }

    /// A minimal glTF 2.0 document (JSON) holding this material alone:
    /// `asset.version` "2.0" and `materials[0].pbrMetallicRoughness` with
    /// `baseColorFactor` [r, g, b, 1], `metallicFactor` and `roughnessFactor`, the
    /// material's `KHR_materials_*` extensions (named in `extensionsUsed`); `source`
    /// and `notes` go into the material's `extras.brdfkit`.
    pub fn document(&self, source: &str, notes: &[String]) -> Value {
        let b = self.base_color;
        let (exts, used) = self.extensions();
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": concat!("brdfkit ", env!("CARGO_PKG_VERSION"))},
            "materials": [{
                "name": "brdfkit",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [b.r(), b.g(), b.b(), 1.0],
                    "metallicFactor": self.metallic,
                    "roughnessFactor": self.roughness,
                },
                "extras": {"brdfkit": {"source": source, "notes": notes}},
            }],
        });
        if !used.is_empty() {
            doc["extensionsUsed"] = json!(used);
            doc["materials"][0]["extensions"] = Value::Object(exts);
        }
        doc
    }
}
