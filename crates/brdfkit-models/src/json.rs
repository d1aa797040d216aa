//! Reading and writing model parameters in the JSON contract.
//!
//! `{"model": "<name>", "params": {...}}` where a per-channel parameter is a number (the
//! same in every channel) or an `[r, g, b]` triple, shape parameters are numbers, and
//! structural choices are strings or nested objects. Unknown keys are errors (a typo
//! must not silently fall back to a default); absent parameters take the model's
//! default start value.

use brdfkit_core::{ModelError, Rgb, UnknownName};
use serde_json::{Map, Value};
use std::str::FromStr;

/// The `params` object of a model description (an absent or null `params` is empty).
pub fn params_object<'a>(
    params: &'a Value,
    model: &str,
) -> Result<std::borrow::Cow<'a, Map<String, Value>>, ModelError> {
    match params {
        Value::Object(m) => Ok(std::borrow::Cow::Borrowed(m)),
        Value::Null => Ok(std::borrow::Cow::Owned(Map::new())),
        other => Err(ModelError::Invalid(format!(
            "`params` of `{model}` must be an object, found {}",
            kind(other)
        ))),
    }
}

/// Rejects keys other than `allowed`, naming the first unknown one.
pub fn deny_unknown(
    obj: &Map<String, Value>,
    allowed: &[&str],
    model: &str,
) -> Result<(), ModelError> {
    for k in obj.keys() {
        if !allowed.contains(&k.as_str()) {
            return Err(ModelError::Invalid(format!(
                "unknown parameter `{k}` for `{model}` (expected one of: {})",
                allowed.join(", ")
            )));
        }
    }
    Ok(())
}

/// A number, or `default` when absent.
pub fn number_or(
    obj: &Map<String, Value>,
    key: &str,
    default: f64,
    model: &str,
) -> Result<f64, ModelError> {
    entry_or(obj, key, default, model, as_number, "a number")
}

/// `obj[key]` read by `read`, or `default` when absent; an error saying the key must be
/// `what` when `read` refuses it.
fn entry_or<T>(
    obj: &Map<String, Value>,
    key: &str,
    default: T,
    model: &str,
    read: impl FnOnce(&Value) -> Option<T>,
    what: &str,
) -> Result<T, ModelError> {
    match obj.get(key) {
        None => Ok(default),
        Some(v) => read(v).ok_or_else(|| {
            ModelError::Invalid(format!(
                "`{key}` of `{model}` must be {what}, found {}",
                kind(v)
            ))
        }),
    }
}

/// A number or an `[r, g, b]` triple, or `default` in every channel when absent.
pub fn rgb_or(
    obj: &Map<String, Value>,
    key: &str,
    default: f64,
    model: &str,
) -> Result<Rgb, ModelError> {
    let what = "a number or an [r, g, b] triple of numbers";
    entry_or(obj, key, Rgb::splat(default), model, as_rgb, what)
}

/// A string, or `default` when absent.
pub fn string_or<'a>(
    obj: &'a Map<String, Value>,
    key: &str,
    default: &'a str,
    model: &str,
) -> Result<&'a str, ModelError> {
    match obj.get(key) {
        None => Ok(default),
        Some(Value::String(s)) => Ok(s),
        Some(v) => Err(ModelError::Invalid(format!(
            "`{key}` of `{model}` must be a string, found {}",
            kind(v)
        ))),
    }
}

/// A structural choice named by a string (through its `FromStr`), or `default` when
/// absent. An unknown name is the error ``unknown <what> `<name>` for `<model>` (expected
/// <names>)``, the wording the JSON contract has always used.
pub fn choice_or<T: FromStr<Err = UnknownName>>(
    obj: &Map<String, Value>,
    key: &str,
    default: T,
    model: &str,
) -> Result<T, ModelError> {
    match obj.get(key) {
        None => Ok(default),
        // Present: string_or only checks that it is a string (its default is unused).
        Some(_) => string_or(obj, key, "", model)?
            .parse()
            .map_err(|e| unknown_choice(e, model)),
    }
}

/// An [`UnknownName`] as the model error naming `model`.
pub fn unknown_choice(e: UnknownName, model: &str) -> ModelError {
    ModelError::Invalid(format!(
        "unknown {} `{}` for `{model}` (expected {})",
        e.what,
        e.given,
        e.known.join(", ")
    ))
}

/// Parses a number, or a triple, into an [`Rgb`].
pub fn as_rgb(v: &Value) -> Option<Rgb> {
    match v {
        Value::Number(_) => as_number(v).map(Rgb::splat),
        Value::Array(a) if a.len() == 3 => {
            let r = as_number(&a[0])?;
            let g = as_number(&a[1])?;
            let b = as_number(&a[2])?;
            Some(Rgb::new(r, g, b))
        }
        _ => None,
    }
}

/// A JSON number as f64 (JSON has no NaN or infinity, so the result is finite).
pub fn as_number(v: &Value) -> Option<f64> {
    v.as_f64()
}

/// An [`Rgb`] as an `[r, g, b]` JSON array.
pub fn rgb_value(c: Rgb) -> Value {
    Value::from(vec![c.r(), c.g(), c.b()])
}

/// A short name of a JSON value's type, for error messages.
pub fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn rgb_accepts_numbers_and_triples_only() {
        let o = json!({"a": 0.5, "b": [0.1, 0.2, 0.3], "c": [1, 2], "d": "x"});
        let o = o.as_object().unwrap();
        assert_eq!(rgb_or(o, "a", 0.0, "m").unwrap(), Rgb::splat(0.5));
        assert_eq!(rgb_or(o, "b", 0.0, "m").unwrap(), Rgb::new(0.1, 0.2, 0.3));
        assert_eq!(rgb_or(o, "zz", 0.7, "m").unwrap(), Rgb::splat(0.7));
        let e = rgb_or(o, "c", 0.0, "m").unwrap_err().to_string();
        assert!(e.contains("`c` of `m`") && e.contains("an array"), "{e}");
        assert!(rgb_or(o, "d", 0.0, "m").is_err());
    }

    #[test]
    fn unknown_keys_are_named() {
        let o = json!({"rho_d": 0.5, "rhod": 1});
        let e = deny_unknown(o.as_object().unwrap(), &["rho_d"], "lambert")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`rhod`") && e.contains("lambert"), "{e}");
    }
}
