//! The body of `POST …/radiosity`: a lighting state, an optional sky, and what to answer
//! per patch.

use super::lighting::sky_state;
use super::{choice_impls, lit_request, some, Choice, Resolve};
use crate::model::query::Quantity;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::{Lighting, Model};
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

/// A radiosity request in the model's terms.
pub(crate) struct RadiosityAsk {
    pub lighting: Lighting,
    /// The sky whose daylight is added.
    pub sky: Option<SkyState>,
    /// Whether per-surface averages are asked for too.
    pub surfaces: bool,
    pub quantity: Quantity,
}

lit_request! {
    /// A lighting state and what to return.
    RadiosityRequest, "a JSON object" {
        /// Also return per-surface area-weighted averages.
        #[serde(default)]
        #[schema(default = false)]
        surfaces: bool,
        #[serde(default)]
        #[schema(inline)]
        quantity: QuantityName,
        /// Daylight from this sky (a scene with a [site]) added to the light groups' light.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        sky: Option<SkySpec>,
    }
}

impl Resolve for RadiosityRequest {
    type Resolved = RadiosityAsk;

    /// The lighting state, and the sky resolved for the scene's site.
    fn resolve(&self, model: &Model) -> Result<RadiosityAsk, AppError> {
        let lighting = self.lighting(model)?;
        let sky = sky_state(self.sky.as_ref(), model)?;
        let (surfaces, quantity) = (self.surfaces, self.quantity.0);
        Ok(RadiosityAsk {
            lighting,
            sky,
            surfaces,
            quantity,
        })
    }
}
