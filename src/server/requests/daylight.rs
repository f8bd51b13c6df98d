//! The body of `POST …/daylight`: a sky, optional electric light, and where to report.

use serde::Deserialize;
use utoipa::ToSchema;

use super::illuminance::{points_schema, report_query, report_surfaces, Point};
use super::lighting::{light_weights, Lights};
use super::{grid_ids, object_only, some, Resolve};
use crate::color::Rgb;
use crate::model::query::IlluminanceQuery;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::Model;
use crate::server::AppError;

/// A sky, electric light added if `lights` is given, and where to report illuminance.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct DaylightRequest {
    sky: SkySpec,
    /// Electric light added to the daylight (a group state; groups left out take their
    /// defaults). Without it, daylight alone.
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false)]
    lights: Option<Lights>,
    #[serde(default, deserialize_with = "some")]
    #[schema(schema_with = report_surfaces)]
    surfaces: Option<Vec<String>>,
    #[serde(default)]
    #[schema(schema_with = points_schema)]
    points: Vec<Point>,
    #[serde(default)]
    #[schema(schema_with = grid_ids)]
    grids: Vec<String>,
}

object_only!(DaylightRequest, "a JSON object {sky, ...}");

/// A daylight request in the model's terms.
pub(crate) struct DaylightAsk {
    pub sky: SkyState,
    /// The electric light's group weights, when it is added.
    pub weights: Option<Vec<Rgb>>,
    pub query: IlluminanceQuery,
}

impl Resolve for DaylightRequest {
    type Resolved = DaylightAsk;

    /// The resolved sky, the electric light's group weights, and the query; nothing asked
    /// for means every surface.
    fn resolve(&self, model: &Model) -> Result<DaylightAsk, AppError> {
        let site = model.site()?;
        let sky = self.sky.resolve(site)?;
        let weights = match &self.lights {
            None => None,
            Some(l) => Some(light_weights(Some(l), model)?),
        };
        let query = report_query(self.surfaces.as_deref(), &self.grids, &self.points, model)?;
        Ok(DaylightAsk {
            sky,
            weights,
            query,
        })
    }
}
