//! `POST /api/scenes/{id}/glare`: the CIE 117 Unified Glare Rating at observers, with
//! each luminaire's term and the background luminance.

use axum::Json;

use crate::model::glare::ObserverGlare;
use crate::model::query::BYTES_PER_PATCH_ANSWER;
use crate::model::Lighting;
use crate::server::openapi::{PostErrors, SceneIdParam};
use crate::server::parse::ScenePost;
use crate::server::requests::glare::GlareAsk;
use crate::server::requests::{GlareRequest, Resolve};
use crate::server::AppError;

/// The ratings, one per observer in the order asked.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub(crate) struct GlareAnswer {
    observers: Vec<ObserverGlare>,
}

#[utoipa::path(post, path = "/api/scenes/{id}/glare", operation_id = "glare", tags = ["scenes"],
    summary = "Discomfort glare (CIE 117 UGR) at observers for a lighting state: per observer the UGR, the background luminance L_b = E_ind/π (cd/m²) and each luminaire's luminance (cd/m²), solid angle (sr) and Guth position index. Luminaires need a luminous opening (the photometric file's dimensions); `luminaires` places, moves or removes them for this request.",
    params(SceneIdParam),
    request_body(content = GlareRequest, content_type = "application/json",
        description = "A lighting state and the observers.",
        example = json!({"observers": [{"position": [2.0, 0.0, 1.5], "direction": [1, 0, 0]}]})),
    responses((status = 200, description = "One rating per observer.", body = GlareAnswer), PostErrors))]
pub(crate) async fn glare(
    ScenePost(ready, state, req): ScenePost<GlareRequest>,
) -> Result<Json<GlareAnswer>, AppError> {
    let GlareAsk {
        lighting,
        observers,
    } = req.resolve(&ready.model)?;
    let mut bytes = ready.model.glare_bytes(observers.len());
    if let Lighting::Placed(_) = lighting {
        // The changes' solve: a solution and the radiosity a gather looks for.
        bytes += BYTES_PER_PATCH_ANSWER * ready.model.patches() as u64;
    }
    let what = format!("glare at {} observers", observers.len());
    let answer = state
        .heavy(bytes, &what, move |cancel| {
            Ok(ready.model.glare(&observers, &lighting, cancel)?)
        })
        .await?;
    Ok(Json(GlareAnswer { observers: answer }))
}
