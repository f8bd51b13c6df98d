//! Schema pieces for the OpenAPI document (feature `server`).
//!
//! The answers' serde types, in [`crate::model`], [`crate::scene`] and the server, derive
//! `utoipa::ToSchema` when the `server` feature is on
//! (`#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]`), so the document
//! describes exactly what they serialize to. This module holds what the derive cannot say
//! by itself: triples, work-plane layouts, and the one value of a `&'static str` field.

use serde_json::{json, Value};
use utoipa::openapi::extensions::Extensions;
use utoipa::openapi::schema::{Object, Schema, SchemaType};
use utoipa::openapi::RefOr;
use utoipa::{PartialSchema, ToSchema};

/// A schema written as JSON Schema: for the union types that have their own
/// deserializers (number or object, array or object, …), with limits from the constants
/// the checks use.
pub(crate) fn raw(v: Value) -> RefOr<Schema> {
    let Value::Object(m) = v else {
        panic!("a schema is a JSON object")
    };
    let mut o = Object::new();
    o.schema_type = SchemaType::AnyValue;
    o.extensions = Some(Extensions::from_iter(m));
    Schema::Object(o).into()
}

/// An RGB triple, or a point or vector in metres (the component `Rgb`); for
/// [`crate::color::Rgb`], [`crate::color::Rgb64`], `[f32; 3]` and `[f64; 3]` fields:
/// `#[schema(value_type = crate::schema::Rgb)]`.
pub(crate) struct Rgb;

impl PartialSchema for Rgb {
    fn schema() -> RefOr<Schema> {
        raw(json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}))
    }
}
impl ToSchema for Rgb {}

/// `[columns, rows]` of a work plane (x fastest), or null: for `Option<[usize; 2]>`.
pub(crate) fn layout() -> RefOr<Schema> {
    raw(
        json!({"oneOf": [{"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 2, "maxItems": 2}, {"type": "null"}],
        "description": "[columns, rows] of a work plane (x fastest), or null."}),
    )
}

/// A string from a fixed set of words.
pub(crate) fn words(words: &[&str]) -> RefOr<Schema> {
    raw(json!({"type": "string", "enum": words}))
}

/// Schemas of `&'static str` fields that always hold one word (a unit):
/// `#[schema(schema_with = crate::schema::lx)]`.
macro_rules! one_word {
    ($($name:ident = $word:literal),+ $(,)?) => {
        $(
            #[doc = concat!("The string `\"", $word, "\"`.")]
            pub(crate) fn $name() -> RefOr<Schema> {
                words(&[$word])
            }
        )+
    };
}

one_word!(lx = "lx", lm = "lm", lm_per_m2 = "lm/m2", metre = "m");
