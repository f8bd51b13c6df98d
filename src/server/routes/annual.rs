//! `POST /api/scenes/{id}/annual`: climate-based daylight metrics over a year of weather.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use axum::Json;

use super::ApiResult;
use crate::model::annual::{AnnualAnswer, AnnualQuery};
use crate::model::QueryError;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::{begin, SceneId};
use crate::server::requests::daylight::Weather;
use crate::server::requests::AnnualRequest;
use crate::server::AppState;

#[utoipa::path(post, path = "/api/scenes/{id}/annual", operation_id = "annual", tag = "scenes",
    summary = "Annual climate-based metrics per grid from an EPW weather file (a file in the scene's folder, or its text): sDA300/50 %, ASE1000,250h, useful daylight illuminance bands, EN 17037's minimum level, and per point the occupied hours with at least 300 lx. Every hour is a Perez sky; the sun's direct light is traced per point and hour.",
    params(SceneIdParam),
    request_body(content = AnnualRequest, content_type = "application/json",
        example = json!({"weather": "mannheim.epw", "grids": ["workplane"], "occupied": ["08:00", "18:00"]})),
    responses((status = 200, description = "Annual metrics per grid.", body = AnnualAnswer), PostErrors))]
pub(crate) async fn annual(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body): (_, AnnualRequest) = begin(&state, &id, &headers, body).await?;
    let (grids, occupied, weather) = body.parts(&ready)?;
    let points: usize = grids.iter().map(|&g| ready.grids[g].len()).sum();
    // Sized for a leap year, before the file is read.
    let bytes = ready.annual_bytes(&grids, 8784);
    let what = format!("annual metrics for {points} grid points");
    let r = ready.clone();
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            let weather = match weather {
                Weather::File(name) => r.weather_file(&name)?,
                Weather::Text(text) => crate::daylight::epw::parse(&text)
                    .map_err(|m| QueryError::Invalid(format!("weather: {m}")))?,
            };
            let q = AnnualQuery {
                weather: Arc::new(weather),
                grids,
                occupied,
            };
            Ok(r.annual(&q, cancel)?)
        })
        .await?;
    Ok(Json(answer).into_response())
}
