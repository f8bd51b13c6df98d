//! Strict JSON bodies: the content type must be JSON, the document an object, and no
//! object anywhere in it may repeat a key (serde would silently keep the last one, so
//! `{"lights": {"lamp": 0, "lamp": 1}}` would mean whatever came last).
//!
//! A body is read in two passes over its bytes: [`check`] validates the syntax and the
//! keys without building anything (400 for bad syntax, 422 for a repeated key or a
//! document that is not an object), then [`decode`] deserializes the request type, whose
//! mistakes become 422s naming the field path (`points[0].position`). Nesting depth is
//! bounded by serde_json's recursion limit (128).

use std::collections::HashSet;
use std::fmt;

use axum::http::{header, HeaderMap};
use serde::de::{DeserializeOwned, DeserializeSeed, Deserializer, Error as _, MapAccess};
use serde::de::{IgnoredAny, SeqAccess, Visitor};
use serde_path_to_error::Segment;

use super::AppError;
use crate::model::error::shorten;

/// Checks that a request with a body declares a JSON media type: `application/json` or
/// any `…/…+json`, parameters (charset) allowed. Browsers' cross-site form posts can only
/// send `text/plain`, urlencoded or multipart, so this also keeps them out.
pub(crate) fn require_json(headers: &HeaderMap) -> Result<(), AppError> {
    let Some(ct) = headers.get(header::CONTENT_TYPE) else {
        return Err(AppError::UnsupportedMediaType(
            "the request has a body but no Content-Type: send Content-Type: application/json"
                .into(),
        ));
    };
    let ct = ct.to_str().unwrap_or("");
    let essence = essence(ct);
    if essence == "application/json" || (essence.contains('/') && essence.ends_with("+json")) {
        Ok(())
    } else {
        Err(AppError::UnsupportedMediaType(format!(
            "Content-Type '{}' is not JSON: send Content-Type: application/json",
            ct.chars().take(100).collect::<String>()
        )))
    }
}

/// The media type of a Content-Type value: `type/subtype` in lower case, without
/// parameters.
pub(crate) fn essence(content_type: &str) -> String {
    let media = content_type.split(';').next().unwrap_or("");
    media.trim().to_ascii_lowercase()
}

/// Parses a request body of type `T`: [`check`], then [`decode`].
pub(crate) fn parse<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, AppError> {
    check(bytes)?;
    decode(bytes)
}

/// Checks that `bytes` is one JSON object with no repeated key at any depth: 400 for bad
/// syntax, 422 for a document that is not an object or repeats a key.
pub(crate) fn check(bytes: &[u8]) -> Result<(), AppError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let kind = Strict.deserialize(&mut de).and_then(|k| {
        de.end()?;
        Ok(k)
    });
    match kind {
        Ok("an object") => Ok(()),
        Ok(other) => Err(AppError::Invalid(format!(
            "the body must be a JSON object, got {other}"
        ))),
        Err(e) if e.is_syntax() || e.is_eof() => {
            Err(AppError::BadRequest(format!("malformed JSON: {e}")))
        }
        Err(e) => Err(AppError::Invalid(format!("invalid JSON: {e}"))),
    }
}

/// Deserializes a checked body into `T`; a mistake is a 422 that names the field path.
pub(crate) fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, AppError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    serde_path_to_error::deserialize(&mut de)
        .map_err(|e| {
            let inner = e.inner();
            let text = inner.to_string();
            let at = format!(" at line {} column {}", inner.line(), inner.column());
            let msg = text.strip_suffix(&at).unwrap_or(&text);
            let segments: Vec<&Segment> = e.path().iter().collect();
            // The path of an unknown field ends with that field: name its object.
            let own = if msg.starts_with("unknown field `") {
                &segments[..segments.len().saturating_sub(1)]
            } else {
                &segments[..]
            };
            AppError::Invalid(describe(&path_text(own), msg))
        })
        .and_then(|v| {
            de.end()
                .map_err(|e| AppError::BadRequest(format!("malformed JSON: {e}")))?;
            Ok(v)
        })
}

/// Stands for the field in a custom error message that names its field itself:
/// [`describe`] puts the field's path in its place (its first occurrence, which comes
/// before any client text). Custom messages without it are prefixed with the path.
pub(crate) const FIELD: &str = "\u{1}";

/// A field path as shown in messages: `points[0].position`, `lights.ceiling`; long keys
/// cut short.
fn path_text(segments: &[&Segment]) -> String {
    let mut out = String::new();
    for seg in segments {
        match seg {
            Segment::Seq { index } => out += &format!("[{index}]"),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out += &key.chars().take(64).collect::<String>();
            }
            Segment::Unknown => out += "?",
        }
    }
    out
}

/// Rewords serde's messages for a client: `'points[0].normal' must be an array of three
/// numbers, got "x"`, `unknown field 'hue' in 'lights.ceiling' (expected: intensity,
/// color)`, `missing field 'grid' in 'targets[0]'`.
fn describe(path: &str, msg: &str) -> String {
    let subject = if path.is_empty() {
        "the body".to_string()
    } else {
        format!("'{path}'")
    };
    let within = if path.is_empty() {
        String::new()
    } else {
        format!(" in '{path}'")
    };
    if msg.contains(FIELD) {
        return msg.replacen(FIELD, path, 1);
    }
    let types = msg
        .strip_prefix("invalid type: ")
        .or_else(|| msg.strip_prefix("invalid value: "));
    if let Some((got, want)) = types.and_then(|r| r.rsplit_once(", expected ")) {
        return format!(
            "{subject} must be {}, got {}",
            expected(want),
            unexpected(got)
        );
    }
    if let Some((n, want)) = msg
        .strip_prefix("invalid length ")
        .and_then(|r| r.split_once(", expected "))
    {
        return format!("{subject} must be {}, got {n} elements", expected(want));
    }
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        let (name, known) = match rest.rsplit_once("`, expected ") {
            Some((name, known)) => (name, known.replace(['`'], "").replace(" or ", ", ")),
            None => (
                rest.trim_end_matches("`, there are no fields"),
                "none".into(),
            ),
        };
        let known = known.strip_prefix("one of ").unwrap_or(&known).to_string();
        return format!(
            "unknown field '{}'{within} (expected: {known})",
            shorten(name)
        );
    }
    if let Some(name) = msg.strip_prefix("missing field `") {
        return format!("missing field '{}'{within}", name.trim_end_matches('`'));
    }
    if path.is_empty() {
        msg.to_string()
    } else {
        format!("{path}: {msg}")
    }
}

/// serde's name of an expected type, in the API's words.
fn expected(want: &str) -> &str {
    match want {
        "f64" | "f32" | "u32" | "usize" => "a number",
        "a boolean" => "true or false",
        "a sequence" => "an array",
        "a map" => "an object",
        other => other,
    }
}

/// serde's description of an unexpected value, in JSON's words, cut short.
fn unexpected(got: &str) -> String {
    let plain = match got {
        "sequence" => "an array",
        "map" => "an object",
        "unit value" | "null" => "null",
        other => other
            .strip_prefix("string ")
            .or_else(|| other.strip_prefix("integer "))
            .or_else(|| other.strip_prefix("floating point "))
            .or_else(|| other.strip_prefix("boolean "))
            .unwrap_or(other),
    };
    let plain = plain.trim_matches('`');
    if plain.chars().count() > 80 {
        format!("{}…", plain.chars().take(80).collect::<String>())
    } else {
        plain.to_string()
    }
}

/// Walks a JSON value without building it, refusing repeated keys; gives the kind of the
/// value (for the top level's message).
struct Strict;

impl<'de> DeserializeSeed<'de> for Strict {
    type Value = &'static str;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<&'static str, D::Error> {
        d.deserialize_any(StrictVisitor)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = &'static str;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<&'static str, E> {
        Ok("a boolean")
    }
    fn visit_i64<E>(self, _: i64) -> Result<&'static str, E> {
        Ok("a number")
    }
    fn visit_u64<E>(self, _: u64) -> Result<&'static str, E> {
        Ok("a number")
    }
    fn visit_f64<E>(self, _: f64) -> Result<&'static str, E> {
        Ok("a number")
    }
    fn visit_str<E>(self, _: &str) -> Result<&'static str, E> {
        Ok("a string")
    }
    fn visit_unit<E>(self) -> Result<&'static str, E> {
        Ok("null")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<&'static str, A::Error> {
        while seq.next_element_seed(Strict)?.is_some() {}
        Ok("an array")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<&'static str, A::Error> {
        let mut keys = HashSet::new();
        while let Some(k) = map.next_key::<String>()? {
            if keys.contains(&k) {
                let shown: String = k.chars().take(64).collect();
                return Err(A::Error::custom(format!(
                    "the key '{shown}' appears twice in one object"
                )));
            }
            map.next_value_seed(Strict)?;
            keys.insert(k);
        }
        Ok("an object")
    }
}

/// Exactly `N` numbers from a sequence: a shorter or longer one is refused with its
/// length, as `expected` says.
pub(crate) fn numbers<'de, const N: usize, A: SeqAccess<'de>>(
    mut seq: A,
    expected: &dyn serde::de::Expected,
) -> Result<[f64; N], A::Error> {
    let mut t = [0.0; N];
    for (i, x) in t.iter_mut().enumerate() {
        *x = seq
            .next_element()?
            .ok_or_else(|| A::Error::invalid_length(i, expected))?;
    }
    let more = count_rest(&mut seq)?;
    if more > 0 {
        return Err(A::Error::invalid_length(N + more, expected));
    }
    Ok(t)
}

/// Skips the rest of a sequence, counting its elements (for a length message).
fn count_rest<'de, A: SeqAccess<'de>>(seq: &mut A) -> Result<usize, A::Error> {
    let mut n = 0;
    while seq.next_element::<IgnoredAny>()?.is_some() {
        n += 1;
    }
    Ok(n)
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
            match check(body.as_bytes()) {
                Err(AppError::Invalid(m)) => assert!(m.contains("appears twice"), "{m}"),
                other => panic!("{body}: {other:?}"),
            }
        }
        assert!(check(br#"{"a": {"b": 1}, "b": {"a": 2}}"#).is_ok());
    }

    #[test]
    fn syntax_errors_are_bad_requests_and_non_objects_invalid() {
        assert!(matches!(check(b"{"), Err(AppError::BadRequest(_))));
        assert!(matches!(check(b"{} x"), Err(AppError::BadRequest(_))));
        assert!(matches!(check(b"[1]"), Err(AppError::Invalid(_))));
        assert!(matches!(
            check(b"{\"a\": 1e999}"),
            Err(AppError::BadRequest(_) | AppError::Invalid(_))
        ));
        let deep = "[".repeat(100_000);
        assert!(check(deep.as_bytes()).is_err());
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Probe {
        flag: Option<bool>,
        list: Option<Vec<Inner>>,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Inner {
        x: f64,
    }

    #[test]
    fn decoding_errors_name_the_field_path() {
        let err = |body: &str| match parse::<Probe>(body.as_bytes()) {
            Err(AppError::Invalid(m)) => m,
            other => panic!("{body}: {other:?}"),
        };
        assert_eq!(
            err(r#"{"flag": "yes"}"#),
            "'flag' must be true or false, got \"yes\""
        );
        assert_eq!(
            err(r#"{"list": [{"x": 1}, {"x": [1]}]}"#),
            "'list[1].x' must be a number, got an array"
        );
        assert_eq!(
            err(r#"{"list": [{"y": 1}]}"#),
            "unknown field 'y' in 'list[0]' (expected: x)"
        );
        assert_eq!(
            err(r#"{"lists": 1}"#),
            "unknown field 'lists' (expected: flag, list)"
        );
        assert_eq!(err(r#"{"list": [{}]}"#), "missing field 'x' in 'list[0]'");
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
