//! [`Fitted`]: the model(s) a fit produced, one shared or one per channel, and their
//! JSON contract (`docs/conventions.md`).

use brdfkit_core::{Model, ModelError};
use serde_json::{Value, json};

/// The fitted model(s).
#[derive(Debug, Clone)]
pub enum Fitted {
    /// One model for all channels (shared shape parameters).
    Shared(Box<dyn Model>),
    /// One model per channel (R, G, B); model c is meant for channel c only.
    PerChannel([Box<dyn Model>; 3]),
}

impl Fitted {
    /// The model of channel c.
    pub fn channel_model(&self, c: usize) -> &dyn Model {
        match self {
            Fitted::Shared(m) => m.as_ref(),
            Fitted::PerChannel(ms) => ms[c].as_ref(),
        }
    }

    /// The shared model, if the fit was shared.
    pub fn shared(&self) -> Option<&dyn Model> {
        match self {
            Fitted::Shared(m) => Some(m.as_ref()),
            Fitted::PerChannel(_) => None,
        }
    }

    /// The JSON contract of the result: the model's `to_json()`, or
    /// `{"per_channel": [r, g, b]}`.
    pub fn to_json(&self) -> Value {
        match self {
            Fitted::Shared(m) => m.to_json(),
            Fitted::PerChannel(ms) => {
                json!({"per_channel": [ms[0].to_json(), ms[1].to_json(), ms[2].to_json()]})
            }
        }
    }
}

impl Fitted {
    /// A model description, `{"per_channel": [r, g, b]}` as [`Fitted::to_json`] writes
    /// it, or a fit record (its `model`, as `fit --record` writes it).
    pub fn from_json(v: &Value) -> Result<Fitted, ModelError> {
        let v = match v.get("losses_full").and(v.get("model")) {
            Some(m) if m.is_object() => m,
            _ => v,
        };
        if let Some(pc) = v.get("per_channel") {
            let arr = pc.as_array().filter(|a| a.len() == 3).ok_or_else(|| {
                ModelError::Invalid(
                    "`per_channel` must be an array of three model descriptions".into(),
                )
            })?;
            let m = |c: usize| brdfkit_models::from_json(&arr[c]);
            return Ok(Fitted::PerChannel([m(0)?, m(1)?, m(2)?]));
        }
        Ok(Fitted::Shared(brdfkit_models::from_json(v)?))
    }

    /// The model of each channel.
    pub fn channel_models(&self) -> [&dyn Model; 3] {
        [0, 1, 2].map(|c| self.channel_model(c))
    }
}
