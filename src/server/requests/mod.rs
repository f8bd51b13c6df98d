//! Typed request bodies: one struct per POST endpoint, deserialized strictly (unknown
//! fields refused, `null` never taken for "absent", objects only where the API says
//! object) and documented by the same types ([`utoipa::ToSchema`]), so that the code
//! and the OpenAPI document cannot drift apart.
//!
//! Deserialization checks shapes and types; the numbers' ranges and the ids are checked
//! after it, by the one conversion to engine terms ([`Resolve`]), through [`super::parse`] and the query model.
//!
//! One module per route (as in [`super::routes`]), and [`lighting`]: light-group
//! settings, per-patch emission, skies, and the triples (colours, positions, directions)
//! they and the points are made of. [`illuminance`] also has the receivers (surfaces,
//! points, grids) that the daylight request reports on; [`render`] has the query of
//! `render.png` and the parsing of queries that `export.glb` shares.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{Deserialize, Deserializer, Visitor};
use serde_json::Value;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;

pub(crate) mod annual;
pub(crate) mod batch;
pub(crate) mod daylight;
pub(crate) mod export;
pub(crate) mod glare;
pub(crate) mod illuminance;
pub(crate) mod lighting;
pub(crate) mod optimize;
pub(crate) mod query;
pub(crate) mod radiosity;
pub(crate) mod render;

pub(crate) use annual::AnnualRequest;
pub(crate) use batch::BatchRequest;
pub(crate) use daylight::DaylightRequest;
pub(crate) use glare::GlareRequest;
pub(crate) use illuminance::IlluminanceRequest;
pub(crate) use optimize::OptimizeRequest;
pub(crate) use radiosity::RadiosityRequest;
pub(crate) use render::RenderRequest;
// Schemas written as JSON Schema, for the union types that have their own deserializers.
pub(crate) use crate::schema::raw;

/// A request read against a scene's model: the one conversion of every request to the
/// model's terms, checked (ranges, ids, limits), into a named type.
pub(crate) trait Resolve {
    /// What the request asks, in the model's terms.
    type Resolved;
    fn resolve(
        &self,
        model: &crate::model::Model,
    ) -> Result<Self::Resolved, crate::server::AppError>;
}

/// For optional fields: present means a value of `T`, never `null` (serde's `Option`
/// would take `null` for absent). Use with `#[serde(default, deserialize_with = "some")]`.
pub(crate) fn some<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}

/// Implements `Deserialize` for a struct whose derived deserializer is inherent
/// (`#[serde(remote = "Self")]`), taking a JSON object only: serde's derive also takes an
/// array of the fields in order, which the API does not.
macro_rules! object_only {
    ($t:ty, $expecting:literal) => {
        $crate::server::requests::deserialize_by!(
            $t,
            $expecting,
            deserialize_map,
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<$t, A::Error> {
                <$t>::deserialize(serde::de::value::MapAccessDeserializer::new(map))
            }
        );
    };
}
pub(crate) use object_only;

/// Declares a request body: the struct, deserialized strictly (unknown fields refused),
/// and its object-only `Deserialize`.
macro_rules! request {
    ($(#[$m:meta])* $name:ident, $expecting:literal { $($fields:tt)* }) => {
        $(#[$m])*
        #[derive(Debug, serde::Deserialize, utoipa::ToSchema)]
        #[serde(remote = "Self", deny_unknown_fields)]
        pub(crate) struct $name {
            $($fields)*
        }

        $crate::server::requests::object_only!($name, $expecting);
    };
}
pub(crate) use request;

/// Declares a request body that carries a lighting state ([`request`]), with the optional
/// `lights` (group settings), `emission` (per-patch exitance) and `luminaires` (placed
/// for the request) before its own fields, never `null`; and `fn lighting`, which
/// resolves the state (`emission` goes with neither of the others).
macro_rules! lit_request {
    ($(#[$m:meta])* $name:ident, $expecting:literal { $($fields:tt)* }) => {
        $crate::server::requests::request! {
            $(#[$m])*
            $name, $expecting {
                #[serde(default, deserialize_with = "crate::server::requests::some")]
                #[schema(nullable = false)]
                lights: Option<$crate::server::requests::lighting::Lights>,
                #[serde(default, deserialize_with = "crate::server::requests::some")]
                #[schema(nullable = false)]
                emission: Option<$crate::server::requests::lighting::Emission>,
                /// Luminaires added, moved, re-aimed, swapped or removed for this request
                /// only (with `lights`, not `emission`; factored and hierarchical
                /// transfers), at most 1,000.
                #[serde(default, deserialize_with = "crate::server::requests::some")]
                #[schema(nullable = false, max_items = 1000)]
                luminaires: Option<Vec<$crate::server::requests::lighting::LuminaireEntry>>,
                $($fields)*
            }
        }

        impl $name {
            /// The lighting state: group weights, or a per-patch emission.
            // A request that hands its lighting fields on (a report's) leaves it unused.
            #[allow(dead_code)]
            pub(crate) fn lighting(
                &self,
                model: &$crate::model::Model,
            ) -> Result<$crate::model::Lighting, $crate::server::AppError> {
                $crate::server::requests::lighting::lighting(
                    self.lights.as_ref(),
                    self.emission.as_ref(),
                    self.luminaires.as_deref(),
                    model,
                )
            }
        }
    };
}
pub(crate) use lit_request;

/// Implements `Deserialize` for a type whose JSON takes more than one shape, through a
/// visitor: the type, what it expects (the message for any other shape), the
/// deserializer method to call, and the visitor's `visit_*` methods.
macro_rules! deserialize_by {
    ($t:ty, $expecting:expr, $method:ident, $($methods:tt)*) => {
        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct V;
                impl<'de> serde::de::Visitor<'de> for V {
                    type Value = $t;
                    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                        f.write_str($expecting)
                    }
                    $($methods)*
                }
                d.$method(V)
            }
        }
    };
}
pub(crate) use deserialize_by;

/// A visitor's arms for a JSON number (float or integer), each as `f64` through `$make`.
macro_rules! visit_numbers {
    ($make:expr) => {
        fn visit_f64<E>(self, x: f64) -> Result<Self::Value, E> {
            Ok($make(x))
        }
        fn visit_i64<E>(self, x: i64) -> Result<Self::Value, E> {
            Ok($make(x as f64))
        }
        fn visit_u64<E>(self, x: u64) -> Result<Self::Value, E> {
            Ok($make(x as f64))
        }
    };
}
pub(crate) use visit_numbers;

/// A `$ref` to a component schema.
pub(crate) fn schema_ref(name: &str) -> Value {
    serde_json::json!({ "$ref": format!("#/components/schemas/{name}") })
}

/// A list of names, each at most once.
pub(crate) fn names(description: &str) -> RefOr<Schema> {
    raw(
        serde_json::json!({"type": "array", "items": {"type": "string", "minLength": 1}, "uniqueItems": true,
        "description": description}),
    )
}

/// Grid ids, each at most once.
pub(crate) fn grid_ids() -> RefOr<Schema> {
    names("Calculation grid ids from scene.toml.")
}

/// A string from a fixed set, with its own message for anything else.
pub(crate) trait Choice: Sized + 'static {
    /// The accepted strings, the default first.
    const NAMES: &'static [&'static str];
    fn pick(s: &str) -> Option<Self>;
    /// The message for an unknown string (see [`super::json::FIELD`]).
    fn refuse(got: &str) -> String;
}

pub(crate) fn choice<'de, D: Deserializer<'de>, T: Choice>(d: D) -> Result<T, D::Error> {
    struct V<T>(PhantomData<T>);
    impl<T: Choice> Visitor<'_> for V<T> {
        type Value = T;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "one of {}", T::NAMES.join(", "))
        }
        fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<T, E> {
            T::pick(s).ok_or_else(|| E::custom(T::refuse(&super::parse::shorten(s))))
        }
    }
    d.deserialize_str(V(PhantomData))
}

/// The schema of a [`Choice`]: its strings, the first the default.
pub(crate) fn choice_schema<T: Choice>(description: &str) -> RefOr<Schema> {
    raw(serde_json::json!({
        "type": "string", "enum": T::NAMES, "default": T::NAMES[0], "description": description
    }))
}

/// Implements `Deserialize` and the schema of a [`Choice`].
macro_rules! choice_impls {
    ($t:ty, $description:literal) => {
        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                $crate::server::requests::choice(d)
            }
        }
        impl utoipa::PartialSchema for $t {
            fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
                $crate::server::requests::choice_schema::<$t>($description)
            }
        }
        impl utoipa::ToSchema for $t {}
    };
}
pub(crate) use choice_impls;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::server::json::parse;
    use crate::server::AppError;

    fn err<T: serde::de::DeserializeOwned + std::fmt::Debug>(body: &str) -> String {
        match parse::<T>(body.as_bytes()) {
            Err(AppError::Invalid(m)) => m,
            other => panic!("{body}: {other:?}"),
        }
    }

    #[test]
    fn requests_refuse_nulls_arrays_for_objects_and_unknown_fields() {
        assert!(parse::<RadiosityRequest>(b"{}").is_ok());
        assert_eq!(
            err::<RadiosityRequest>(r#"{"lights": null}"#),
            "'lights' must be an object, got null"
        );
        let m = err::<IlluminanceRequest>(r#"{"points": [[[0, 0, 0], [0, 1, 0]]]}"#);
        assert!(m.starts_with("'points[0]' must be an object"), "{m}");
        let m = err::<RadiosityRequest>(r#"{"lights": {"a": {"hue": 1}}}"#);
        assert!(m.contains("unknown field 'hue' in 'lights.a'"), "{m}");
        let m = err::<RadiosityRequest>(r#"{"lights": {"a": {"color": [1, 1]}}}"#);
        assert!(
            m.contains("'lights.a.color' must be an array of three numbers"),
            "{m}"
        );
        let m = err::<RadiosityRequest>(r#"{"quantity": "luminance"}"#);
        assert!(m.starts_with("'quantity' must be"), "{m}");
        let m = err::<RenderRequest>(r#"{"format": "gif"}"#);
        assert!(m.starts_with("format 'gif'"), "{m}");
        let m = err::<BatchRequest>(r#"{"states": [[]]}"#);
        assert!(m.starts_with("'states[0]' must be an object"), "{m}");
    }
}
