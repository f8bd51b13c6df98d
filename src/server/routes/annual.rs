//! `POST /api/scenes/{id}/annual`: climate-based daylight metrics over a year of weather.

use std::sync::Arc;

use axum::Json;

use super::grid_points;
use crate::model::annual::{AnnualAnswer, AnnualQuery};
use crate::model::QueryError;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::annual::{AnnualAsk, Weather};
use crate::server::requests::{AnnualRequest, Resolve};
use crate::server::AppError;

#[utoipa::path(post, path = "/api/scenes/{id}/annual", operation_id = "annual", tags = ["scenes"],
    summary = "Annual climate-based metrics per grid from an EPW weather file (a file in the scene's folder, or its text): sDA300/50 %, ASE1000,250h, useful daylight illuminance bands, EN 17037's minimum level, and per point the occupied hours with at least 300 lx. Every hour is a Perez sky; the sun's direct light is traced per point and hour.",
    params(SceneIdParam),
    request_body(content = AnnualRequest, content_type = "application/json",
        example = json!({"weather": "mannheim.epw", "grids": ["workplane"], "occupied": ["08:00", "18:00"]})),
    responses((status = 200, description = "Annual metrics per grid.", body = AnnualAnswer), PostErrors))]
pub(crate) async fn annual(
    ScenePost(ready, state, req): ScenePost<AnnualRequest>,
) -> Result<Json<AnnualAnswer>, AppError> {
    let AnnualAsk {
        grids,
        occupied,
        weather,
    } = req.resolve(&ready.model)?;
    let points = grid_points(&ready.model, &grids);
    // Sized for a leap year, before the file is read.
    let bytes = ready.model.annual_bytes(&grids, 8784);
    let what = format!("annual metrics for {points} grid points");
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            let m = &ready.model;
            let weather = match weather {
                Weather::File(name) => m.weather_file(&name)?,
                Weather::Text(text) => crate::daylight::epw::parse(&text)
                    .map_err(|m| QueryError::Invalid(format!("weather: {m}")))?,
            };
            let q = AnnualQuery {
                weather: Arc::new(weather),
                grids,
                occupied,
            };
            Ok(m.annual(&q, cancel)?)
        })
        .await?;
    Ok(Json(answer))
}
