//! The body of `POST …/annual`: a year of weather, the grids to rate and the occupied
//! hours.

use serde::Deserialize;
use utoipa::ToSchema;

use super::{grid_ids, object_only, some, Resolve};
use crate::model::annual::WeatherSource;
use crate::model::Model;
use crate::server::parse::grid_list;
use crate::server::AppError;

/// A year of weather and the grids to rate.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct AnnualRequest {
    /// The name of an EPW file in the scene's folder, or the text of an EPW file.
    #[schema(min_length = 1)]
    weather: String,
    /// Grid ids (default: every grid of the scene).
    #[serde(default)]
    #[schema(schema_with = grid_ids)]
    grids: Vec<String>,
    /// Occupied hours, local standard time, ["HH:MM", "HH:MM") (default 08:00 to 18:00).
    #[serde(default, deserialize_with = "some")]
    #[schema(nullable = false, value_type = Vec<String>, min_items = 2, max_items = 2)]
    occupied: Option<[String; 2]>,
}

object_only!(AnnualRequest, "a JSON object {weather, grids, occupied}");

/// `HH:MM` as hours.
fn clock(s: &str, what: &str) -> Result<f64, AppError> {
    let bad = || AppError::Invalid(format!("{what} = '{s}': use HH:MM, 00:00 … 24:00"));
    let (h, m) = s.split_once(':').ok_or_else(bad)?;
    let (h, m): (u32, u32) = (h.parse().map_err(|_| bad())?, m.parse().map_err(|_| bad())?);
    if h > 24 || m > 59 || (h == 24 && m > 0) || s.len() != 5 {
        return Err(bad());
    }
    Ok(h as f64 + m as f64 / 60.0)
}

impl Resolve for AnnualRequest {
    type Resolved = AnnualAsk;

    /// The grids and occupied hours, and where the weather comes from (a file name in the
    /// scene's folder, or EPW text), checked.
    fn resolve(&self, model: &Model) -> Result<AnnualAsk, AppError> {
        if self.weather.trim().is_empty() {
            return Err(AppError::Invalid(
                "weather is empty: name an EPW file in the scene's folder, or send its text".into(),
            ));
        }
        model.site()?;
        let grids = if self.grids.is_empty() {
            (0..model.grids.len()).collect()
        } else {
            grid_list(&self.grids, model)?
        };
        if grids.is_empty() {
            return Err(AppError::Invalid(
                "this scene has no calculation grids to rate".into(),
            ));
        }
        let occupied = match &self.occupied {
            None => (8.0, 18.0),
            Some([a, b]) => {
                let (a, b) = (clock(a, "occupied[0]")?, clock(b, "occupied[1]")?);
                if a >= b {
                    return Err(AppError::Invalid(format!(
                        "occupied: the start ({a} h) must come before the end ({b} h)"
                    )));
                }
                (a, b)
            }
        };
        let weather = if self.weather.contains('\n') {
            WeatherSource::Text(self.weather.clone())
        } else {
            WeatherSource::File(self.weather.clone())
        };
        Ok(AnnualAsk {
            grids,
            occupied,
            weather,
        })
    }
}

/// An annual request in the model's terms.
pub(crate) struct AnnualAsk {
    /// The grids to rate.
    pub grids: Vec<usize>,
    /// The occupied hours, from and to, local standard time.
    pub occupied: (f64, f64),
    pub weather: WeatherSource,
}
