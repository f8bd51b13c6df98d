//! The body of `POST …/daylight`: a sky, optional electric light, and where to report.

use serde::Deserialize;
use utoipa::ToSchema;

use super::illuminance::{points_schema, report_query, report_surfaces, Point};
use super::lighting::{lighting, Lights};
use super::{grid_ids, object_only, some};
use crate::color::Rgb;
use crate::model::query::IlluminanceQuery;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::{Lighting, Model};
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

impl DaylightRequest {
    /// The resolved sky, the electric light's group weights, and the query; nothing asked
    /// for means every surface.
    pub(crate) fn query(
        &self,
        model: &Model,
    ) -> Result<(SkyState, Option<Vec<Rgb>>, IlluminanceQuery), AppError> {
        let site = model.site()?;
        let sky = self.sky.resolve(site)?;
        let weights = match &self.lights {
            None => None,
            Some(l) => match lighting(Some(l), None, model)? {
                Lighting::Groups(w) => Some(w),
                Lighting::Emission(_) => None,
            },
        };
        let q = report_query(self.surfaces.as_deref(), &self.grids, &self.points, model)?;
        Ok((sky, weights, q))
    }
}
