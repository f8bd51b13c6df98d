//! The scenes: `GET /api/scenes` (every slot and its status), `GET /api/scenes/{id}`
//! (units, bounds, lights, cameras, luminaires, grids, surfaces), `…/patches` (per-patch
//! geometry, JSON or binary) and `…/mesh` (the shading mesh for the page's 3D view).

use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::{json, Value};

use super::{binary, wants_binary, ApiResult};
use crate::server::openapi::{
    MeshBinary, Patches, PatchesBinary, SceneDetails, SceneErrors, SceneIdParam, SceneList,
    SizedGetErrors,
};
use crate::server::parse::SceneId;
use crate::server::{AppState, Ready, SceneSlot};

pub(super) fn scene_summary(slot: &SceneSlot) -> Value {
    let (status, ready, error) = slot.status();
    let mut v = json!({
        "id": slot.id,
        "name": ready.as_ref().map_or(slot.id.clone(), |r| r.baked.scene.name.clone()),
        "status": status,
        "progress": slot.progress(),
    });
    if let Some(r) = ready {
        v["patches"] = json!(r.baked.transfer.n);
        v["lights"] = json!(r.groups);
        v["transfer"] = json!(r.baked.transfer.mode);
    }
    if let Some(e) = error {
        v["error"] = json!(e);
    }
    v
}

#[utoipa::path(get, path = "/api/scenes", operation_id = "listScenes", tag = "scenes",
    summary = "All scenes with status (queued, baking with progress 0..1, ready, failed with error), patch count and light groups.",
    responses((status = 200, description = "Scene list.", body = SceneList)))]
pub(crate) async fn list_scenes(State(state): State<Arc<AppState>>) -> Json<Value> {
    Json(json!({
        "scenes": state.slots.iter().map(|s| scene_summary(s)).collect::<Vec<_>>()
    }))
}

#[utoipa::path(get, path = "/api/scenes/{id}", operation_id = "sceneDetails", tag = "scenes",
    summary = "Light groups, cameras, luminaires, calculation grids, surfaces (with patch ranges), bounds, units and transfer mode of a scene.",
    params(SceneIdParam),
    responses((status = 200, description = "Scene details.", body = SceneDetails), SceneErrors))]
pub(crate) async fn scene_details(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
) -> ApiResult {
    let r = state.slot(&id)?.ready()?;
    let b = &r.baked;
    let (lo, hi) = b.scene.bounds();
    let surfaces: Vec<Value> = b
        .scene
        .surfaces
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let range = &b.mesh.surface_patches[k];
            let area: f64 = range.clone().map(|i| b.mesh.patches[i as usize].area).sum();
            json!({
                "id": s.name, "index": k, "area": area,
                "patches": {"start": range.start, "end": range.end, "count": range.len()},
                "two_sided": s.two_sided,
            })
        })
        .collect();
    Ok(Json(json!({
        "id": b.scene.id,
        "name": b.scene.name,
        "status": "ready",
        "patches": b.transfer.n,
        "transfer": b.transfer.mode,
        "units": {"length": "m", "source_units": b.scene.units, "scale_to_m": b.scene.scale,
                  "radiosity": "lm/m2", "illuminance": "lx", "flux": "lm"},
        "bounds": {"min": lo.to_array(), "max": hi.to_array()},
        "lights": r.groups,
        "cameras": b.scene.cameras,
        "luminaires": b.scene.lights.iter().flat_map(|g| g.luminaires.iter().map(move |l| json!({
            "id": l.id, "group": g.id, "position": l.position.to_array(), "aim": l.aim.to_array(),
            "lumens": l.lumens, "watts": l.watts,
            "distribution": match &l.distribution {
                crate::photometry::Distribution::Isotropic => "isotropic",
                crate::photometry::Distribution::Spot { .. } => "spot",
                crate::photometry::Distribution::Ies(_) => "ies",
            },
        }))).collect::<Vec<_>>(),
        "grids": r.grids.iter().map(|g| json!({
            "id": g.grid.id, "name": g.grid.name, "count": g.len(), "layout": g.grid.layout,
            "normal": g.grid.normal, "points": g.grid.points,
        })).collect::<Vec<_>>(),
        "surfaces": surfaces,
        "bake": {"seconds": r.bake_seconds, "from_cache": b.stats.from_cache, "residual": b.transfer.info.residual},
    }))
    .into_response())
}

#[utoipa::path(get, path = "/api/scenes/{id}/patches", operation_id = "patches", tag = "scenes",
    summary = "Per patch: surface, area (m²), centroid and normal (m). JSON, or binary with `Accept: application/octet-stream`.",
    params(SceneIdParam),
    responses(
        (status = 200, description = "Patches in patch order.",
            headers(
                ("X-Relight-Patches" = u64, description = "Binary answer: the number of patches."),
                ("X-Relight-Layout" = String, description = "Binary answer: the layout of the bytes."),
            ),
            content((Patches = "application/json"), (PatchesBinary = "application/octet-stream"))),
        SizedGetErrors,
    ))]
pub(crate) async fn patches(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
) -> ApiResult {
    let r = state.slot(&id)?.ready()?;
    let binary_out = wants_binary(&headers);
    let n = r.baked.mesh.len() as u64;
    let bytes = if binary_out { 64 * n } else { 800 * n };
    let what = format!("the list of {n} patches");
    state
        .heavy(bytes, &what, move |_| Ok(patch_list(&r, binary_out)))
        .await
}

fn patch_list(r: &Ready, binary_out: bool) -> Response {
    let m = &r.baked.mesh;
    if binary_out {
        let mut out = Vec::with_capacity(8 * m.len());
        for p in &m.patches {
            out.push(f32::from_bits(p.surface));
            out.push(p.area as f32);
            out.extend(p.centroid.as_vec3().to_array());
            out.extend(p.normal.as_vec3().to_array());
        }
        return binary(
            out,
            m.len(),
            "per patch 32 bytes LE: u32 surface, f32 area m2, f32x3 centroid m, f32x3 normal",
        );
    }
    let names = &r.baked.scene.surfaces;
    let list: Vec<Value> = m
        .patches
        .iter()
        .map(|p| {
            json!({
                "surface": names[p.surface as usize].name,
                "area": p.area,
                "centroid": p.centroid.to_array(),
                "normal": p.normal.to_array(),
            })
        })
        .collect();
    Json(json!({ "patches": list })).into_response()
}

/// The shading mesh (layout in [`crate::render::Shading::mesh_bytes`]).
#[utoipa::path(get, path = "/api/scenes/{id}/mesh", operation_id = "mesh", tag = "scenes",
    summary = "The shading mesh for client-side drawing: vertices, triangles (one per patch), surface per triangle, and per-vertex patch weights (vertex colour = Σ weight · B[patch]).",
    params(SceneIdParam),
    responses(
        (status = 200, description = "One binary buffer.",
            headers(("X-Relight-Layout" = String, description = "The layout of the bytes.")),
            content((MeshBinary = "application/octet-stream"))),
        SizedGetErrors,
    ))]
pub(crate) async fn mesh(State(state): State<Arc<AppState>>, SceneId(id): SceneId) -> ApiResult {
    let r = state.slot(&id)?.ready()?;
    // Built once per scene, off the runtime; then a cheap clone of shared bytes.
    let n = r.baked.mesh.len() as u64;
    let bytes = state
        .heavy(200 * n, "the shading mesh", move |_| Ok(r.mesh_bytes()))
        .await?;
    Ok((
        [
            (header::CONTENT_TYPE, "application/octet-stream".to_string()),
            (
                header::HeaderName::from_static("x-relight-layout"),
                "RLMESH01: u32 nv nt nw; f32 pos[nv][3]; u32 tri[nt][3]; u32 surface[nt]; u32 start[nv+1]; u32 patch[nw]; f32 weight[nw]".to_string(),
            ),
            (header::CACHE_CONTROL, "no-cache".to_string()),
        ],
        bytes,
    )
        .into_response())
}
