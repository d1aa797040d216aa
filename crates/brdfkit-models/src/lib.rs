//! The analytic BRDF models of brdfkit, one per module.
//!
//! Every model implements [`brdfkit_core::Model`]: a validated builder, a flat parameter
//! vector with names, domains and a default start, `eval`, an analytic gradient, a fast
//! path over precomputed [`brdfkit_core::GeometryBatch`] geometry, and the JSON contract
//! `{"model": "<name>", "params": {...}}` read by [`from_json`]. See `docs/models.md`.

#![warn(missing_docs)]

/// `impl Model { pub const NAME }`: the model's name in the JSON contract, which
/// `Model::name` returns and other crates use instead of spelling it.
macro_rules! model_name {
    ($t:ty, $name:expr) => {
        impl $t {
            /// The model's name in the JSON contract.
            pub const NAME: &'static str = $name;
        }
    };
}

pub mod cosine_lobe;
pub mod json;
mod lanes;
mod pair;
pub mod par;
#[macro_use]
mod params;
pub mod raw;
pub mod shape;
pub mod sheen;
pub mod testing;

// Models (one file each).
pub mod ashikhmin_shirley;
pub mod blinn_phong;
pub mod cook_torrance;
pub mod gltf_pbr;
pub mod gltf_pbr_ext;
pub mod lafortune;
pub mod lambert;
pub mod named;
pub mod oren_nayar;
pub mod phong;
pub mod plausible_phong;
pub mod published;
pub mod rough_plastic;
pub mod sum;
pub mod ward;

use brdfkit_core::{Model, ModelError};
use serde_json::Value;

/// Every model name of the JSON contract.
pub const MODEL_NAMES: &[&str] = &[
    "lambert",
    "oren-nayar",
    "phong",
    "plausible-phong",
    "blinn-phong",
    "ward",
    "lafortune",
    "cook-torrance",
    "ashikhmin-shirley",
    "sum",
    "gltf-pbr",
    "gltf-pbr-ext",
    "rough-plastic",
];

/// Builds a model from its JSON description `{"model": "<name>", "params": {...}}`.
///
/// Absent parameters take the model's default start; unknown keys and out-of-domain
/// values are errors naming the parameter.
pub fn from_json(v: &Value) -> Result<Box<dyn Model>, ModelError> {
    let obj = v.as_object().ok_or_else(|| {
        ModelError::Invalid(format!(
            "a model description must be an object {{\"model\": ..., \"params\": {{...}}}}, found {}",
            json::kind(v)
        ))
    })?;
    json::deny_unknown(obj, &["model", "params"], "model description")?;
    let name = match obj.get("model") {
        Some(Value::String(s)) => s.as_str(),
        Some(other) => {
            return Err(ModelError::Invalid(format!(
                "`model` must be a string, found {}",
                json::kind(other)
            )));
        }
        None => return Err(ModelError::Invalid("missing field `model`".into())),
    };
    let params = obj.get("params").unwrap_or(&Value::Null);
    from_name_and_params(name, params)
}

/// Builds a model from its name and its `params` value (null means all defaults).
pub fn from_name_and_params(name: &str, params: &Value) -> Result<Box<dyn Model>, ModelError> {
    fn boxed<M: Model + 'static>(m: Result<M, ModelError>) -> Result<Box<dyn Model>, ModelError> {
        m.map(|m| Box::new(m) as Box<dyn Model>)
    }
    match name {
        "lambert" => boxed(lambert::Lambert::from_params_json(params)),
        "oren-nayar" => boxed(oren_nayar::OrenNayar::from_params_json(params)),
        "phong" => boxed(phong::Phong::from_params_json(params)),
        "plausible-phong" => boxed(plausible_phong::PlausiblePhong::from_params_json(params)),
        "blinn-phong" => boxed(blinn_phong::BlinnPhong::from_params_json(params)),
        "lafortune" => boxed(lafortune::Lafortune::from_params_json(params)),
        "sum" => boxed(sum::Sum::from_params_json(params)),
        "ward" => boxed(ward::Ward::from_params_json(params)),
        "cook-torrance" => boxed(cook_torrance::CookTorrance::from_params_json(params)),
        "ashikhmin-shirley" => boxed(ashikhmin_shirley::AshikhminShirley::from_params_json(
            params,
        )),
        "gltf-pbr" => boxed(gltf_pbr::GltfPbr::from_params_json(params)),
        "gltf-pbr-ext" => boxed(gltf_pbr_ext::GltfPbrExt::from_params_json(params)),
        "rough-plastic" => boxed(rough_plastic::RoughPlastic::from_params_json(params)),
        other => published::from_params_json(other, params).unwrap_or_else(|| {
            Err(ModelError::Invalid(format!(
                "unknown model `{other}` (known: {}; published parameterisations: {})",
                MODEL_NAMES.join(", "),
                published::PUBLISHED_NAMES.join(", ")
            )))
        }),
    }
}

/// Parses a model description from JSON text.
pub fn from_json_str(s: &str) -> Result<Box<dyn Model>, ModelError> {
    let v: Value =
        serde_json::from_str(s).map_err(|e| ModelError::Invalid(format!("not valid JSON: {e}")))?;
    from_json(&v)
}

/// The model `name` at its default start (structural choices at their defaults).
pub fn default_model(name: &str) -> Result<Box<dyn Model>, ModelError> {
    from_name_and_params(name, &Value::Null)
}
