//! The body of `POST …/daylight`: a sky, optional electric light, and where to report.

use super::illuminance::report_request;
use super::Resolve;
use crate::model::query::IlluminanceQuery;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::{Lighting, Model};
use crate::server::AppError;

report_request! {
    lit_request! {
        /// A sky, electric light added if `lights`, `emission` or `luminaires` is given
        /// (any lighting state; without them, daylight alone), and where to report
        /// illuminance.
        DaylightRequest, "a JSON object {sky, ...}" {
            sky: SkySpec,
        } {}
    }
}

/// A daylight request in the model's terms.
pub(crate) struct DaylightAsk {
    pub sky: SkyState,
    /// The electric light's state, when it is added.
    pub electric: Option<Lighting>,
    pub query: IlluminanceQuery,
}

impl Resolve for DaylightRequest {
    type Resolved = DaylightAsk;

    /// The resolved sky, the electric light's state, and the query; nothing asked for
    /// means every surface.
    fn resolve(&self, model: &Model) -> Result<DaylightAsk, AppError> {
        let site = model.site()?;
        let sky = self.sky.resolve(site)?;
        let electric =
            if self.lights.is_none() && self.emission.is_none() && self.luminaires.is_none() {
                None
            } else {
                Some(self.lighting(model)?)
            };
        let query = self.report_query(model)?;
        Ok(DaylightAsk {
            sky,
            electric,
            query,
        })
    }
}
