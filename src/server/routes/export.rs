//! `GET` and `POST /api/scenes/{id}/export.glb`: the relit scene as a glTF binary
//! ([`crate::render::export`]), on the blocking pool.

use std::time::Instant;

use axum::extract::Query;
use axum::http::header;
use axum::response::Response;

use super::{made, put};
use crate::budget::human_bytes;
use crate::model::query::BYTES_PER_PATCH_ANSWER;
use crate::model::Lighting;
use crate::render;
use crate::server::openapi::{GlbFile, PostErrors, QueryErrors, SceneIdParam};
use crate::server::parse::{ReadyScene, SceneId, ScenePost};
use crate::server::requests::export::{ExportAsk, ExportBody, ExportQuery, ExportRequest};
use crate::server::requests::Resolve;
use crate::server::{AppError, AppState, Ready};

#[utoipa::path(get, path = "/api/scenes/{id}/export.glb", operation_id = "exportGlb", tags = ["scenes"],
    summary = "The meshed scene relit, as glTF 2.0 binary for any glTF viewer: vertex colours are the relit image's display values (COLOR_0, linear, after exposure and tone map) on an unlit material, and one `_LIGHT_<GROUP>` attribute per light group (radiance in cd/m² at intensity 1, white) lets a client remix the lights without the server. Takes `light.<group>=<intensity>` or `light.<group>=r,g,b` per light group besides the parameters below. A parameter given twice, an unknown parameter or a value that is not a number where one is expected is a 400; values out of range and unknown light groups are 422s.",
    params(SceneIdParam, ExportQuery),
    responses(GlbFile, QueryErrors))]
pub(crate) async fn export_glb(
    SceneId(id): SceneId,
    ReadyScene(ready, state): ReadyScene,
    Query(q): Query<Vec<(String, String)>>,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let ask = ExportRequest::from_query(&q)?.resolve(&ready.model)?;
    respond(state, ready, id, ask, t0).await
}

#[utoipa::path(post, path = "/api/scenes/{id}/export.glb", operation_id = "exportGlbPost", tags = ["scenes"],
    summary = "The meshed scene relit for any lighting state, as glTF 2.0 binary: as GET …/export.glb, with the state in a JSON body (light groups, luminaires placed per request, or a per-patch emission). The request's own light (placed luminaires, emission) is one more attribute, `_LIGHT_REQUEST`, so the groups' attributes at their weights plus it give the state.",
    params(SceneIdParam),
    request_body(content = ExportBody, content_type = "application/json",
        description = "An empty object exports the default state.",
        example = json!({"lights": {"ceiling": 0.5}, "tonemap": "filmic"})),
    responses(GlbFile, PostErrors))]
pub(crate) async fn export_glb_post(
    ScenePost(ready, state, req): ScenePost<ExportBody>,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let ask = req.resolve(&ready.model)?;
    let id = ready.model.baked.scene.id.clone();
    respond(state, ready, id, ask, t0).await
}

/// The file of `ask`, made on the blocking pool, with its timing, exposure and file name.
async fn respond(
    state: std::sync::Arc<AppState>,
    ready: std::sync::Arc<Ready>,
    id: String,
    ask: ExportAsk,
    t0: Instant,
) -> Result<Response, AppError> {
    // The working set is about twice the file, and a state's solve.
    let solve = match ask.lighting {
        Lighting::Groups(_) => 0,
        _ => BYTES_PER_PATCH_ANSWER * ready.model.patches() as u64,
    };
    let what = format!("a glTF export (up to {})", human_bytes(ask.bytes));
    let r = state
        .heavy(2 * ask.bytes + solve, &what, move |_| {
            let (m, shading) = (&ready.model, ready.shading());
            Ok(render::export_glb(m, shading, &ask.lighting, &ask.options)?)
        })
        .await?;
    let timing = ("x-relight-export-ms", t0);
    let mut resp = made("model/gltf-binary", r.bytes, timing, Some(r.exposure));
    let disposition = format!("attachment; filename=\"{id}.glb\"");
    put(&mut resp, header::CONTENT_DISPOSITION, disposition);
    Ok(resp)
}
