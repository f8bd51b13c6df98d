//! The body of `POST …/daylight`: a sky, optional electric light, and where to report.

use super::illuminance::report_request;
use super::lighting::{light_weights, Lights};
use super::{some, Resolve};
use crate::color::Rgb;
use crate::model::query::IlluminanceQuery;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::Model;
use crate::server::AppError;

report_request! {
    request! {
        /// A sky, electric light added if `lights` is given, and where to report illuminance.
        DaylightRequest, "a JSON object {sky, ...}" {
            sky: SkySpec,
            /// Electric light added to the daylight (a group state; groups left out take their
            /// defaults). Without it, daylight alone.
            #[serde(default, deserialize_with = "some")]
            #[schema(nullable = false)]
            lights: Option<Lights>,
        } {}
    }
}

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
        let query = self.report_query(model)?;
        Ok(DaylightAsk {
            sky,
            weights,
            query,
        })
    }
}
