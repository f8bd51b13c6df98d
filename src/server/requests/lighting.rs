//! Lighting in requests: `"lights": {"<group>": 0.5 | {"intensity": 0.5, "color": [r, g,
//! b]}}` or, in factored mode, a per-patch `"emission"` (dense `[[r, g, b], …]` or sparse
//! `{"<index>": [r, g, b]}`, lm/m²); and the triples requests are made of.

use std::collections::BTreeMap;

use serde::de::{MapAccess, SeqAccess};
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::{PartialSchema, ToSchema};

use super::{deserialize_by, raw, schema_ref, some, visit_numbers};
use crate::color::{Rgb, Rgb64};
use crate::input_limits::{MAX_REQUEST_COORD_M, MAX_STATE_EMISSION, MAX_STATE_INTENSITY};
use crate::model::lighting::LightState;
use crate::model::placed::{place, LuminairePlacement, Photometry};
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::Lighting;
use crate::model::Model;
use crate::server::json::numbers;
use crate::server::parse::{bounded, shorten};
use crate::server::AppError;

/// Three JSON numbers, as sent; their ranges are checked by whoever uses them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Triple(pub [f64; 3]);

deserialize_by! {
    Triple,
    "an array of three numbers",
    deserialize_seq,
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Triple, A::Error> {
        numbers(seq, &self).map(Triple)
    }
}

/// Declares a triple with its schema (a component of that name).
macro_rules! triple {
    ($(#[$doc:meta])* $name:ident, $schema:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, Deserialize)]
        #[serde(transparent)]
        pub(crate) struct $name(pub Triple);

        impl PartialSchema for $name {
            fn schema() -> RefOr<Schema> {
                raw($schema)
            }
        }
        impl ToSchema for $name {}
    };
}

fn triple_schema(lo: f64, hi: f64, description: &str) -> serde_json::Value {
    json!({"type": "array", "items": {"type": "number", "minimum": lo, "maximum": hi},
        "minItems": 3, "maxItems": 3, "description": description})
}

triple!(
    /// A linear RGB colour filter.
    Color,
    triple_schema(
        0.0,
        MAX_STATE_INTENSITY as f64,
        "Linear RGB colour filter, each channel in [0, 1e6]."
    )
);
triple!(
    /// A point, metres.
    Position,
    triple_schema(
        -MAX_REQUEST_COORD_M,
        MAX_REQUEST_COORD_M,
        "A point, metres; each coordinate within ±1e6."
    )
);
triple!(
    /// A direction (normalised by the server).
    Direction,
    {
        let f = f32::MAX as f64;
        let mut s = triple_schema(
            -f,
            f,
            "A direction (normalised by the server); not all zero.",
        );
        // "Some component is not zero" (spelt without `not`, which generators handle badly).
        s["contains"] = json!({"anyOf": [{"exclusiveMinimum": 0}, {"exclusiveMaximum": 0}]});
        s
    }
);

/// Light group id → setting. Groups left out keep their defaults.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(transparent)]
pub(crate) struct Lights(pub BTreeMap<String, LightSetting>);

impl PartialSchema for Lights {
    fn schema() -> RefOr<Schema> {
        raw(
            json!({"type": "object", "additionalProperties": schema_ref("LightSetting"),
            "propertyNames": {"minLength": 1},
            "description": "Light group id → setting. Groups left out keep their defaults. Unknown groups are a 422."}),
        )
    }
}
impl ToSchema for Lights {}

/// One group's setting: an intensity, or an intensity and a colour.
#[derive(Debug, Clone)]
pub(crate) enum LightSetting {
    Intensity(f64),
    Fields(SettingFields),
}

/// `{"intensity": 0.5, "color": [r, g, b]}`: what is left out keeps the group's default.
#[derive(Debug, Clone, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct SettingFields {
    #[serde(default, deserialize_with = "some")]
    intensity: Option<f64>,
    #[serde(default, deserialize_with = "some")]
    color: Option<Color>,
}

super::object_only!(SettingFields, "an object {intensity, color}");

impl LightSetting {
    /// Intensity 1 at colour `c` (the `light.ID=r,g,b` of a query).
    pub(crate) fn colored(c: Triple) -> LightSetting {
        LightSetting::Fields(SettingFields {
            intensity: Some(1.0),
            color: Some(Color(c)),
        })
    }
}

deserialize_by! {
    LightSetting,
    "a number (the intensity) or an object {intensity, color}",
    deserialize_any,
    visit_numbers!(LightSetting::Intensity);
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<LightSetting, A::Error> {
        let de = serde::de::value::MapAccessDeserializer::new(map);
        SettingFields::deserialize(de).map(LightSetting::Fields)
    }
}

impl PartialSchema for LightSetting {
    fn schema() -> RefOr<Schema> {
        let intensity = json!({"type": "number", "minimum": 0, "maximum": MAX_STATE_INTENSITY});
        let mut level = intensity.clone();
        level["description"] = json!("Intensity (dimming factor; 1 = as modelled).");
        raw(
            json!({"oneOf": [level, {"type": "object", "additionalProperties": false,
            "properties": {"intensity": intensity, "color": schema_ref("Color")}}]}),
        )
    }
}
impl ToSchema for LightSetting {}

/// Per-patch emitted exitance, lm/m²: one `[r, g, b]` per patch, or patch index → `[r,
/// g, b]`.
#[derive(Debug, Clone)]
pub(crate) enum Emission {
    Dense(Vec<Triple>),
    Sparse(BTreeMap<String, Triple>),
}

deserialize_by! {
    Emission,
    "an array of [r,g,b] per patch or an object of patch index → [r,g,b]",
    deserialize_any,
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Emission, A::Error> {
        let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(4096));
        while let Some(t) = seq.next_element()? {
            out.push(t);
        }
        Ok(Emission::Dense(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Emission, A::Error> {
        let mut out = BTreeMap::new();
        while let Some((k, t)) = map.next_entry()? {
            out.insert(k, t);
        }
        Ok(Emission::Sparse(out))
    }
}

impl PartialSchema for Emission {
    fn schema() -> RefOr<Schema> {
        let exitance = triple_schema(
            0.0,
            MAX_STATE_EMISSION,
            "Emitted exitance [r, g, b], lm/m², each in [0, 1e9].",
        );
        raw(json!({
        "description": "Factored mode only: per-patch emitted exitance (lm/m²), dense (one [r,g,b] per patch, exactly as many as the scene has patches) or sparse (patch index → [r,g,b]). Replaces the light groups.",
        "oneOf": [
            {"type": "array", "items": exitance},
            {"type": "object", "propertyNames": {"pattern": "^(0|[1-9][0-9]*)$"}, "additionalProperties": exitance}
        ]}))
    }
}
impl ToSchema for Emission {}

/// An intensity (dimming factor) in `[0, MAX_STATE_INTENSITY]`.
fn intensity(x: f64, what: &str) -> Result<f32, AppError> {
    Ok(bounded(x, what, 0.0, MAX_STATE_INTENSITY as f64)? as f32)
}

/// A colour filter, each channel in `[0, MAX_STATE_INTENSITY]`.
fn color(c: Color, what: &str) -> Result<Rgb, AppError> {
    for x in c.0 .0 {
        bounded(x, what, 0.0, MAX_STATE_INTENSITY as f64)?;
    }
    Ok(Rgb64(c.0 .0).to_f32())
}

/// Per-group weights of a lighting state (absent: every group at its default).
pub(crate) fn light_weights(lights: Option<&Lights>, model: &Model) -> Result<Vec<Rgb>, AppError> {
    let scene = &model.baked.scene;
    let mut state = LightState::default();
    for (id, s) in lights.map(|l| &l.0).into_iter().flatten() {
        let name = shorten(id);
        let (level, rgb) = match s {
            LightSetting::Intensity(x) => (Some(intensity(*x, &format!("light '{name}'"))?), None),
            LightSetting::Fields(f) => (
                f.intensity
                    .map(|x| intensity(x, &format!("light '{name}' intensity")))
                    .transpose()?,
                f.color
                    .map(|c| color(c, &format!("light '{name}' color")))
                    .transpose()?,
            ),
        };
        state.set(scene, id, level, rgb)?;
    }
    Ok(model.weights(&state)?)
}

/// The per-patch emission vector, n × 3 (factored transfer only).
pub(crate) fn emission_vector(e: &Emission, model: &Model) -> Result<Vec<f32>, AppError> {
    model.require_factored()?;
    let n = model.patches();
    let mut out = vec![0f32; 3 * n];
    let out_rgb = Rgb::column_mut(&mut out);
    let mut put = |i: usize, t: &Triple| -> Result<(), AppError> {
        out_rgb[i] = model.emission_value(i, t.0)?;
        Ok(())
    };
    match e {
        Emission::Dense(list) => {
            if list.len() != n {
                return Err(AppError::Invalid(format!(
                    "emission has {} entries; the scene has {n} patches (one [r,g,b] per patch)",
                    list.len()
                )));
            }
            for (i, t) in list.iter().enumerate() {
                put(i, t)?;
            }
        }
        Emission::Sparse(map) => {
            for (k, t) in map {
                // Canonical decimal indices only: "+1", "01" or " 1" would alias patch 1.
                let i: usize = k
                    .parse()
                    .ok()
                    .filter(|i: &usize| i.to_string() == *k)
                    .ok_or_else(|| {
                        AppError::Invalid(format!(
                            "emission key '{}' is not a patch index (a decimal number without sign or leading zeros)",
                            k.chars().take(40).collect::<String>()
                        ))
                    })?;
                put(i, t)?;
            }
        }
    }
    Ok(out)
}

/// A request's sky, resolved for the scene's site (which it needs).
pub(crate) fn sky_state(
    spec: Option<&SkySpec>,
    model: &Model,
) -> Result<Option<SkyState>, AppError> {
    spec.map(|s| Ok(s.resolve(model.site()?)?)).transpose()
}

/// A lighting state from a request's `lights`, `emission` and `luminaires` (`emission`
/// with neither of the others).
pub(crate) fn lighting(
    lights: Option<&Lights>,
    emission: Option<&Emission>,
    luminaires: Option<&[LuminaireEntry]>,
    model: &Model,
) -> Result<Lighting, AppError> {
    match (lights, emission, luminaires) {
        (Some(_), Some(_), _) => Err(AppError::Invalid(
            "give either 'lights' (group settings) or 'emission' (per patch), not both".into(),
        )),
        (_, Some(_), Some(_)) => Err(AppError::Invalid(
            "'luminaires' go with 'lights' (group settings), not with 'emission' (per patch)"
                .into(),
        )),
        (_, Some(e), None) => Ok(Lighting::Emission(emission_vector(e, model)?)),
        (l, None, Some(list)) => {
            model.require_factored()?;
            let weights = light_weights(l, model)?;
            let edits: Vec<LuminairePlacement> = list.iter().map(|e| e.placement()).collect();
            Ok(Lighting::Placed(place(
                &model.baked.scene,
                model.patches(),
                weights,
                &edits,
            )?))
        }
        (l, None, None) => Ok(Lighting::Groups(light_weights(l, model)?)),
    }
}

super::request! {
    /// A luminaire for this request only. An `id` the scene does not have adds a luminaire
    /// (it needs a `position`, and `lumens` unless its photometry is in absolute candela);
    /// one of the scene's luminaires is moved, re-aimed, swapped or recoloured by the
    /// fields given (the rest keep the scene's values), or taken out with `remove`.
    LuminaireEntry, "an object {id, position, aim, c0, photometry | ies | ldt, lumens, cct | color, group, watts, remove}" {
        /// Luminaire id: a new one, or one of the scene's.
        #[schema(min_length = 1)]
        id: String,
        /// Photometric centre, metres; inside the scene's bounds.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        position: Option<Position>,
        /// Photometric axis (default straight down, −Y).
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        aim: Option<Direction>,
        /// Direction of C = 0°.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        c0: Option<Direction>,
        /// An IES or EULUMDAT (.ldt) file of the scene folder.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, min_length = 1)]
        photometry: Option<String>,
        /// Inline IES LM-63 text, at most 1 MB.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        ies: Option<String>,
        /// Inline EULUMDAT text, at most 1 MB.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        ldt: Option<String>,
        /// Total flux, lm, in [0, 1e9].
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        lumens: Option<f64>,
        /// Colour temperature, K, in [1000, 40000] (or `color`).
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        cct: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        color: Option<Color>,
        /// Light group whose setting scales it (default: a new one counts at 1, a scene
        /// luminaire keeps its group).
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, min_length = 1)]
        group: Option<String>,
        /// Electrical power, W, in [0, 1e7].
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        watts: Option<f64>,
        /// Take the scene's luminaire out.
        #[serde(default)]
        #[schema(default = false)]
        remove: bool,
    }
}

impl LuminaireEntry {
    /// The entry in the model's terms (numbers checked by [`place`]).
    fn placement(&self) -> LuminairePlacement {
        let photometry = match (&self.photometry, &self.ies, &self.ldt) {
            (Some(f), _, _) => Some(Photometry::File(f.clone())),
            (None, Some(t), _) => Some(Photometry::Ies(t.clone())),
            (None, None, Some(t)) => Some(Photometry::Ldt(t.clone())),
            (None, None, None) => None,
        };
        LuminairePlacement {
            id: self.id.clone(),
            position: self.position.map(|p| p.0 .0),
            aim: self.aim.map(|p| p.0 .0),
            c0: self.c0.map(|p| p.0 .0),
            photometry,
            lumens: self.lumens,
            cct: self.cct,
            color: self.color.map(|c| c.0 .0),
            group: self.group.clone(),
            watts: self.watts,
            remove: self.remove,
            several_photometries: [&self.photometry, &self.ies, &self.ldt]
                .iter()
                .filter(|x| x.is_some())
                .count()
                > 1,
        }
    }
}
