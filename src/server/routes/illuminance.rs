//! `POST /api/scenes/{id}/illuminance`: illuminance in lux on surfaces (statistics), at
//! points and on calculation grids, with the luminaires' flux and power.

use axum::Json;

use super::at_points;
use crate::model::query::IlluminanceAnswer;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::illuminance::IlluminanceAsk;
use crate::server::requests::{IlluminanceRequest, Resolve};
use crate::server::AppError;

#[utoipa::path(post, path = "/api/scenes/{id}/illuminance", operation_id = "illuminance", tags = ["scenes"],
    summary = "Illuminance per surface (avg, min, max, uniformity), at points (direct light of the luminaires plus light gathered from the solved patches, with occlusion), and on calculation grids (Eavg, Emin, Emax, U0, Emin/Emax), with the luminaires' lumens and watts.",
    params(SceneIdParam),
    request_body(content = IlluminanceRequest, content_type = "application/json",
        description = "An empty body gives every surface in the default lighting state.",
        example = json!({"lights": {"ceiling": {"intensity": 0.8, "color": [1.0, 0.9, 0.8]}}, "surfaces": ["floor"]})),
    responses((status = 200, description = "Illuminance answers in lux.", body = IlluminanceAnswer), PostErrors))]
pub(crate) async fn illuminance(
    ScenePost(ready, state, req): ScenePost<IlluminanceRequest>,
) -> Result<Json<IlluminanceAnswer>, AppError> {
    let IlluminanceAsk { lighting, query: q } = req.resolve(&ready.model)?;
    // Group lighting and no points: a weighted sum of precomputed columns, inline.
    if ready.model.is_cheap(&lighting, &q) {
        let answer = ready
            .model
            .illuminance(&lighting, &q, &Default::default())?;
        return Ok(Json(answer));
    }
    let bytes = ready.model.illuminance_bytes(&q);
    let what = at_points("illuminance", &ready.model, &q);
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            Ok(ready.model.illuminance(&lighting, &q, cancel)?)
        })
        .await?;
    Ok(Json(answer))
}
