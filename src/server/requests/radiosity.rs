//! The body of `POST …/radiosity`: a lighting state, an optional sky, and what to answer
//! per patch.

use super::lighting::sky_state;
use super::{choice_impls, lit_request, some, Choice};
use crate::model::query::Quantity;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::Model;
use crate::server::json::FIELD;
use crate::server::AppError;

/// `quantity`: what a radiosity request answers per patch.
#[derive(Debug, Clone, Copy)]
pub(crate) struct QuantityName(pub Quantity);

impl Default for QuantityName {
    fn default() -> Self {
        QuantityName(Quantity::Radiosity)
    }
}

impl Choice for QuantityName {
    const NAMES: &'static [&'static str] = &["radiosity", "illuminance"];
    fn pick(s: &str) -> Option<Self> {
        match s {
            "radiosity" => Some(QuantityName(Quantity::Radiosity)),
            "illuminance" => Some(QuantityName(Quantity::Illuminance)),
            _ => None,
        }
    }
    fn refuse(got: &str) -> String {
        format!("'{FIELD}' must be \"radiosity\" (lm/m2, leaving) or \"illuminance\" (lux, arriving), got \"{got}\"")
    }
}

choice_impls!(
    QuantityName,
    "radiosity: B, lm/m² leaving each patch; illuminance: H, lux arriving at each patch."
);

lit_request! {
    /// A lighting state and what to return.
    RadiosityRequest, "a JSON object" {
        /// Also return per-surface area-weighted averages.
        #[serde(default)]
        #[schema(default = false)]
        pub surfaces: bool,
        #[serde(default)]
        #[schema(inline)]
        pub quantity: QuantityName,
        /// Daylight from this sky (a scene with a [site]) added to the light groups' light.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        sky: Option<SkySpec>,
    }
}

impl RadiosityRequest {
    /// The sky, resolved for the scene's site.
    pub(crate) fn sky(&self, model: &Model) -> Result<Option<SkyState>, AppError> {
        sky_state(self.sky.as_ref(), model)
    }
}
