//! Strict JSON bodies: the content type must be JSON, the document an object, and no
//! object anywhere in it may repeat a key (serde_json would silently keep the last one,
//! so `{"lights": {"lamp": 0, "lamp": 1}}` would mean whatever came last).
//!
//! Nesting depth is bounded by serde_json's recursion limit (128).

use std::fmt;

use axum::http::{header, HeaderMap};
use serde::de::{DeserializeSeed, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};

use super::AppError;

/// Checks that a request with a body declares a JSON media type: `application/json` or
/// any `…/…+json`, parameters (charset) allowed. Browsers' cross-site form posts can only
/// send `text/plain`, urlencoded or multipart, so this also keeps them out.
pub fn require_json(headers: &HeaderMap) -> Result<(), AppError> {
    let Some(ct) = headers.get(header::CONTENT_TYPE) else {
        return Err(AppError::UnsupportedMediaType(
            "the request has a body but no Content-Type: send Content-Type: application/json"
                .into(),
        ));
    };
    let ct = ct.to_str().unwrap_or("");
    let essence = ct
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    if essence == "application/json" || (essence.contains('/') && essence.ends_with("+json")) {
        Ok(())
    } else {
        Err(AppError::UnsupportedMediaType(format!(
            "Content-Type '{}' is not JSON: send Content-Type: application/json",
            ct.chars().take(100).collect::<String>()
        )))
    }
}

/// Parses a JSON object: 400 for bad syntax, 422 for a document that is not an object or
/// repeats a key.
pub fn parse_object(bytes: &[u8]) -> Result<Map<String, Value>, AppError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let value = Strict.deserialize(&mut de).and_then(|v| {
        de.end()?;
        Ok(v)
    });
    match value {
        Ok(Value::Object(m)) => Ok(m),
        Ok(other) => Err(AppError::Invalid(format!(
            "the body must be a JSON object, got {}",
            kind(&other)
        ))),
        Err(e) if e.is_syntax() || e.is_eof() => {
            Err(AppError::BadRequest(format!("malformed JSON: {e}")))
        }
        Err(e) => Err(AppError::Invalid(format!("invalid JSON: {e}"))),
    }
}

/// A JSON value's kind, for messages.
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

/// Builds a `serde_json::Value`, refusing repeated keys.
struct Strict;

impl<'de> DeserializeSeed<'de> for Strict {
    type Value = Value;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        d.deserialize_any(StrictVisitor)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        Strict.deserialize(d)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(4096));
        while let Some(v) = seq.next_element_seed(Strict)? {
            out.push(v);
        }
        Ok(Value::Array(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(k) = map.next_key::<String>()? {
            if out.contains_key(&k) {
                let shown: String = k.chars().take(64).collect();
                return Err(A::Error::custom(format!(
                    "the key '{shown}' appears twice in one object"
                )));
            }
            let v = map.next_value_seed(Strict)?;
            out.insert(k, v);
        }
        Ok(Value::Object(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_keys_are_refused_at_any_depth() {
        for body in [
            r#"{"lights": 1, "lights": 2}"#,
            r#"{"lights": {"lamp": 0, "lamp": 1}}"#,
            r#"{"states": [{"lights": {}}, {"emission": {"1": [1,1,1], "1": [0,0,0]}}]}"#,
        ] {
            match parse_object(body.as_bytes()) {
                Err(AppError::Invalid(m)) => assert!(m.contains("appears twice"), "{m}"),
                other => panic!("{body}: {other:?}"),
            }
        }
        assert!(parse_object(br#"{"a": {"b": 1}, "b": {"a": 2}}"#).is_ok());
    }

    #[test]
    fn syntax_errors_are_bad_requests_and_non_objects_invalid() {
        assert!(matches!(parse_object(b"{"), Err(AppError::BadRequest(_))));
        assert!(matches!(
            parse_object(b"{} x"),
            Err(AppError::BadRequest(_))
        ));
        assert!(matches!(parse_object(b"[1]"), Err(AppError::Invalid(_))));
        assert!(matches!(
            parse_object(b"{\"a\": 1e999}"),
            Err(AppError::BadRequest(_) | AppError::Invalid(_))
        ));
        let deep = "[".repeat(100_000);
        assert!(parse_object(deep.as_bytes()).is_err());
    }

    #[test]
    fn json_media_types_pass_and_others_are_unsupported() {
        let h = |ct: &str| {
            let mut m = HeaderMap::new();
            m.insert(header::CONTENT_TYPE, ct.parse().unwrap());
            m
        };
        for ok in [
            "application/json",
            "Application/JSON; charset=utf-8",
            "application/merge-patch+json",
        ] {
            assert!(require_json(&h(ok)).is_ok(), "{ok}");
        }
        for bad in [
            "text/plain",
            "application/x-www-form-urlencoded",
            "multipart/form-data; boundary=x",
            "json",
        ] {
            assert!(
                matches!(
                    require_json(&h(bad)),
                    Err(AppError::UnsupportedMediaType(_))
                ),
                "{bad}"
            );
        }
        assert!(require_json(&HeaderMap::new()).is_err());
    }
}
