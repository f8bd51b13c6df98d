//! `GET /api/scenes/{id}/export.glb`: the relit scene as a glTF binary
//! ([`crate::render::export`]), on the blocking pool.

use std::time::Instant;

use axum::extract::Query;
use axum::http::header;
use axum::response::Response;

use super::{made, put};
use crate::budget::human_bytes;
use crate::render;
use crate::server::openapi::{GlbFile, QueryErrors, SceneIdParam};
use crate::server::parse::{ReadyScene, SceneId};
use crate::server::requests::export::{ExportQuery, ExportRequest};
use crate::server::requests::Resolve;
use crate::server::AppError;

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
    let req = ExportRequest::from_query(&q)?;
    let ask = req.resolve(&ready.model)?;
    // The working set is about twice the file.
    let what = format!("a glTF export (up to {})", human_bytes(ask.bytes));
    let r = state
        .heavy(2 * ask.bytes, &what, move |_| {
            let (m, shading) = (&ready.model, ready.shading());
            Ok(render::export_glb(m, shading, &ask.weights, &ask.options))
        })
        .await?;
    let timing = ("x-relight-export-ms", t0);
    let mut resp = made("model/gltf-binary", r.bytes, timing, Some(r.exposure));
    let disposition = format!("attachment; filename=\"{id}.glb\"");
    put(&mut resp, header::CONTENT_DISPOSITION, disposition);
    Ok(resp)
}
