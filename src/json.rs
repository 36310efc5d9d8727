//! Reading the JSON spec files (experiments, render tables): one parser, one error form.
//!
//! Errors read `path: message`, with the JSON path in the form `estimators[2].kernel` (the
//! file name is added by the caller), so every spec reports bad input the same way.

use serde::de::DeserializeOwned;

/// Parses `text` as the spec type `T` (which should be `deny_unknown_fields`); `what` names the
/// kind of file for a message about the top-level value ("the experiment").
pub fn parse<T: DeserializeOwned>(text: &str, what: &str) -> Result<T, String> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("malformed JSON: {e}"))?;
    if !value.is_object() {
        return Err(format!(
            "the file must hold one JSON object ({what}), got {}",
            kind(&value)
        ));
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path == "." {
            inner.to_string()
        } else {
            format!("{path}: {inner}")
        }
    })
}

/// `an array`, `a string`, … for messages.
pub fn kind(value: &serde_json::Value) -> &'static str {
    match value {
        serde_json::Value::Object(_) => "an object",
        serde_json::Value::Array(_) => "an array",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Null => "null",
    }
}

/// Which kind of spec a file holds, from its top-level keys: render tables have `variants`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecKind {
    Experiment,
    RenderTable,
}

/// The kind of spec in `text`, if it is a JSON object with `estimators` or `variants`.
pub fn spec_kind(text: &str) -> Option<SpecKind> {
    let value: serde_json::Value = serde_json::from_str(text).ok()?;
    let obj = value.as_object()?;
    if obj.contains_key("variants") && !obj.contains_key("estimators") {
        Some(SpecKind::RenderTable)
    } else {
        Some(SpecKind::Experiment)
    }
}
