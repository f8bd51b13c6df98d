//! `POST /api/scenes/{id}/daylight`: daylight (and optional electric light) in lux on
//! surfaces, at points and on grids, with daylight factors under the CIE overcast sky.

use axum::Json;

use super::at_points;
use crate::model::daylight::DaylightAnswer;
use crate::model::query::BYTES_PER_PATCH_ANSWER;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::{DaylightRequest, Resolve};
use crate::server::AppError;

#[utoipa::path(post, path = "/api/scenes/{id}/daylight", operation_id = "daylight", tags = ["scenes"],
    summary = "Daylight from a sky (uniform, CIE overcast, CIE clear with the sun, Perez from irradiance; the sun placed by position or local time at the scene's [site]): illuminance per surface, at points (the direct sky integrated over what each point sees, the sun by a shadow ray, interreflections gathered) and on grids, with daylight factors (percent) for the CIE overcast sky. Electric light is added: any lighting state (`lights`, `emission`, or `luminaires` placed for the request), with its maintained answers.",
    params(SceneIdParam),
    request_body(content = DaylightRequest, content_type = "application/json",
        example = json!({"sky": {"type": "cie_overcast", "horizontal_illuminance": 10000}, "points": [{"position": [2.0, 0.8, 2.0], "normal": [0, 1, 0]}]})),
    responses((status = 200, description = "Daylight answers in lux.", body = DaylightAnswer), PostErrors))]
pub(crate) async fn daylight(
    ScenePost(ready, state, req): ScenePost<DaylightRequest>,
) -> Result<Json<DaylightAnswer>, AppError> {
    let ask = req.resolve(&ready.model)?;
    let mut bytes = ready.model.daylight_bytes(&ask.query);
    if ask.electric.is_some() {
        // The state's solution and its maintained one ([`Model::daylight`]).
        bytes += 2 * BYTES_PER_PATCH_ANSWER * ready.model.patches() as u64;
    }
    let what = at_points("daylight", &ready.model, &ask.query);
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            Ok(ready
                .model
                .daylight(&ask.sky, ask.electric.as_ref(), &ask.query, cancel)?)
        })
        .await?;
    Ok(Json(answer))
}
