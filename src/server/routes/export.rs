//! `GET /api/scenes/{id}/export.glb`: the relit scene as a glTF binary
//! ([`crate::render::export`]), on the blocking pool.

use std::sync::Arc;
use std::time::Instant;

use axum::extract::{Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};

use crate::budget::human_bytes;
use crate::render::{self, export_bytes, MAX_EXPORT_BYTES};
use crate::server::openapi::{GlbModel, Millis, QueryErrors, SceneIdParam};
use crate::server::parse::SceneId;
use crate::server::requests::export::{ExportQuery, ExportRequest};
use crate::server::{AppError, AppState};

#[utoipa::path(get, path = "/api/scenes/{id}/export.glb", operation_id = "exportGlb", tag = "scenes",
    summary = "The meshed scene relit, as glTF 2.0 binary for any glTF viewer: vertex colours are the relit image's display values (COLOR_0, linear, after exposure and tone map) on an unlit material, and one `_LIGHT_<GROUP>` attribute per light group (radiance in cd/m² at intensity 1, white) lets a client remix the lights without the server. Takes `light.<group>=<intensity>` or `light.<group>=r,g,b` per light group besides the parameters below. A parameter given twice, an unknown parameter or a value that is not a number where one is expected is a 400; values out of range and unknown light groups are 422s.",
    params(SceneIdParam, ExportQuery),
    responses(
        (status = 200, description = "The .glb file.",
            headers(
                ("X-Relight-Export-Ms" = Millis, description = "Server time, ms."),
                ("X-Relight-Exposure" = f64, description = "The exposure used, stops."),
                ("Content-Disposition" = String, description = "`attachment; filename=\"<id>.glb\"`."),
                ("Cache-Control" = String, description = "`no-store`."),
            ),
            content((GlbModel = "model/gltf-binary"))),
        QueryErrors,
    ))]
pub(crate) async fn export_glb(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    Query(q): Query<Vec<(String, String)>>,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let ready = state.slot(&id)?.ready()?;
    let req = ExportRequest::from_query(&q)?;
    let (weights, o) = req.resolve(&ready)?;
    // Shading vertices are at most three per patch; the working set is about twice the file.
    let size = export_bytes(&ready, 3 * ready.baked.mesh.len(), o.relightable);
    if size > MAX_EXPORT_BYTES {
        return Err(AppError::Invalid(format!(
            "the export could take up to {} (limit {}): ask with relightable=false",
            human_bytes(size),
            human_bytes(MAX_EXPORT_BYTES)
        )));
    }
    let what = format!("a glTF export (up to {})", human_bytes(size));
    let r = state
        .heavy(2 * size, &what, move |_| {
            Ok(render::export_glb(&ready, ready.shading(), &weights, &o))
        })
        .await?;
    let mut resp = (
        [
            (header::CONTENT_TYPE, "model/gltf-binary".to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{id}.glb\""),
            ),
            (header::CACHE_CONTROL, "no-store".to_string()),
        ],
        r.bytes,
    )
        .into_response();
    let hd = resp.headers_mut();
    if let Ok(v) = format!("{:.3}", t0.elapsed().as_secs_f64() * 1e3).parse() {
        hd.insert("x-relight-export-ms", v);
    }
    if let Ok(v) = format!("{:.3}", r.exposure).parse() {
        hd.insert("x-relight-exposure", v);
    }
    Ok(resp)
}
