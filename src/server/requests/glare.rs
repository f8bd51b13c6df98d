//! The body of `POST …/glare`: a lighting state and the observers to rate.

use glam::DVec3;
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::lighting::{lighting, Direction, Lights, LuminaireEntry, Position};
use super::{object_only, raw, schema_ref, some, Resolve};
use crate::input_limits::MAX_REQUEST_COORD_M;
use crate::model::glare::{MAX_OBSERVERS, SEATED_EYE_HEIGHT};
use crate::model::{Lighting, Model};
use crate::server::parse::{bounded_triple, direction, number};
use crate::server::AppError;

/// An observer: the eye, or where the observer is placed and the eye's height above it,
/// and the direction of view.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct Observer {
    /// The eye, metres. Give this or `position`.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    eye: Option<Position>,
    /// Where the observer sits or stands (a point on the floor), metres.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    position: Option<Position>,
    /// Eye height above `position`, metres (default 1.2, seated; 1.6 standing).
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, minimum = 0, maximum = 100)]
    height: Option<f64>,
    /// Direction of view (usually horizontal).
    direction: Direction,
}

object_only!(Observer, "an object {eye or position, height, direction}");

fn observers_schema() -> RefOr<Schema> {
    raw(
        json!({"type": "array", "minItems": 1, "maxItems": MAX_OBSERVERS, "items": schema_ref("Observer"),
        "description": "Observers, e.g. [{\"position\": [2.0, 0.0, 1.5], \"direction\": [1, 0, 0]}]."}),
    )
}

/// An observer's eye and unit direction of view, metres.
type Eye = (DVec3, DVec3);

/// A lighting state and the observers whose glare to rate.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct GlareRequest {
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    lights: Option<Lights>,
    /// Luminaires added, moved, re-aimed, swapped or removed for this request only (as in
    /// every lighting state; factored and hierarchical transfers), at most 1,000. A new
    /// luminaire glares by its photometry and luminous opening.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, max_items = 1000)]
    luminaires: Option<Vec<LuminaireEntry>>,
    #[schema(schema_with = observers_schema)]
    observers: Vec<Observer>,
}

object_only!(GlareRequest, "a JSON object");

/// A glare request in the model's terms.
pub(crate) struct GlareAsk {
    pub lighting: Lighting,
    pub observers: Vec<Eye>,
}

impl Resolve for GlareRequest {
    type Resolved = GlareAsk;

    /// The lighting state and each observer's eye and unit direction of view.
    fn resolve(&self, model: &Model) -> Result<GlareAsk, AppError> {
        let lit = lighting(
            self.lights.as_ref(),
            None,
            self.luminaires.as_deref(),
            model,
        )?;
        if self.observers.is_empty() || self.observers.len() > MAX_OBSERVERS {
            return Err(AppError::Invalid(format!(
                "{} observers; give 1 to {MAX_OBSERVERS}",
                self.observers.len()
            )));
        }
        let observers = self
            .observers
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let at = |p: &Position, what: &str| {
                    bounded_triple(
                        p.0 .0,
                        &format!("observers[{k}].{what}"),
                        MAX_REQUEST_COORD_M,
                    )
                    .map(DVec3::from_array)
                };
                let eye = match (&o.eye, &o.position, o.height) {
                    (Some(e), None, None) => at(e, "eye")?,
                    (None, Some(p), h) => {
                        let what = format!("observers[{k}].height");
                        let h = number(h.unwrap_or(SEATED_EYE_HEIGHT), &what)?;
                        if !(0.0..=100.0).contains(&h) {
                            return Err(AppError::Invalid(format!(
                                "{what} = {h}: must be in 0..=100 m"
                            )));
                        }
                        at(p, "position")? + DVec3::Y * h
                    }
                    (Some(_), _, _) => {
                        return Err(AppError::Invalid(format!(
                        "observers[{k}]: give eye, or position with an optional height, not both"
                    )))
                    }
                    (None, None, _) => {
                        return Err(AppError::Invalid(format!(
                            "observers[{k}] needs eye = [x, y, z] or position = [x, y, z]"
                        )))
                    }
                };
                let d = direction(o.direction.0 .0, &format!("observers[{k}].direction"))?;
                Ok((eye, d))
            })
            .collect::<Result<_, AppError>>()?;
        Ok(GlareAsk {
            lighting: lit,
            observers,
        })
    }
}
