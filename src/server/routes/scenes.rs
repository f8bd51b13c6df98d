//! The scenes: `GET /api/scenes` (every slot and its status), `GET /api/scenes/{id}`
//! (units, bounds, lights, cameras, luminaires, grids, surfaces), `…/patches` (per-patch
//! geometry, JSON or binary) and `…/mesh` (the shading mesh for the page's 3D view).

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::State;
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::ToSchema;

use super::{binary, wants_binary};
use crate::model::info::{
    Bounds, GridInfo, LuminaireInfo, PatchInfo, SiteInfo, SurfaceInfo, Units,
};
use crate::model::GroupInfo;
use crate::model::Model;
use crate::scene::CameraDef;
use crate::schema::words;
use crate::server::openapi::{
    MeshBuffer, PatchesAnswer, SceneErrors, SceneIdParam, SizedGetErrors,
};
use crate::server::parse::ReadyScene;
use crate::server::{AppError, AppState, Ready, SceneSlot};
use crate::transport::transfer::TransferMode;

fn scene_status() -> RefOr<Schema> {
    words(&["queued", "baking", "ready", "failed"])
}

fn ready_status() -> RefOr<Schema> {
    words(&["ready"])
}

/// A scene's slot: its status and, once ready, its size and light groups.
#[derive(Serialize, ToSchema)]
pub(crate) struct SceneSummary {
    id: String,
    name: String,
    #[schema(schema_with = scene_status)]
    status: &'static str,
    /// Bake progress.
    #[schema(minimum = 0, maximum = 1)]
    progress: f64,
    /// Ready scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false)]
    patches: Option<usize>,
    /// Ready scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false)]
    lights: Option<Vec<GroupInfo>>,
    /// Ready scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false, inline)]
    transfer: Option<TransferMode>,
    /// Ready scenes: what loading fixed or left out (a `Kd` of 1 or more scaled down, a
    /// missing MTL file or texture, an unknown material made grey, degenerate triangles
    /// skipped, …), one line each. `strict = true` in scene.toml makes them errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false)]
    warnings: Option<Vec<String>>,
    /// Failed scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(nullable = false)]
    error: Option<String>,
}

impl SceneSummary {
    pub(super) fn of(slot: &SceneSlot) -> SceneSummary {
        let (status, ready, error) = slot.status();
        let model = ready.as_ref().map(|r| &r.model);
        SceneSummary {
            id: slot.id.clone(),
            name: model.map_or(slot.id.clone(), |m| m.baked.scene.name.clone()),
            status,
            progress: slot.progress(),
            patches: model.map(|m| m.baked.transfer.n),
            lights: model.map(|m| m.groups.clone()),
            transfer: model.map(|m| m.baked.transfer.mode),
            warnings: model.map(|m| m.baked.scene.warnings.clone()),
            error,
        }
    }

    /// Every slot's summary.
    pub(super) fn all(state: &AppState) -> Vec<SceneSummary> {
        state.slots().iter().map(|s| SceneSummary::of(s)).collect()
    }
}

/// Every scene.
#[derive(Serialize, ToSchema)]
pub(crate) struct SceneList {
    scenes: Vec<SceneSummary>,
}

#[utoipa::path(get, path = "/api/scenes", operation_id = "listScenes", tags = ["scenes"],
    summary = "All scenes with status (queued, baking with progress 0..1, ready, failed with error), patch count and light groups.",
    responses((status = 200, description = "Scene list.", body = SceneList)))]
pub(crate) async fn list_scenes(State(state): State<Arc<AppState>>) -> Json<SceneList> {
    Json(SceneList {
        scenes: SceneSummary::all(&state),
    })
}

/// How the scene was baked.
#[derive(Serialize, ToSchema)]
pub(crate) struct BakeInfo {
    /// Time to bake or load the scene, s.
    seconds: f64,
    /// Whether the transfer was read from the cache.
    from_cache: bool,
    /// Largest relative residual of the solve over the light groups' columns.
    residual: f64,
}

/// Light groups, cameras, luminaires, grids, surfaces, bounds, units and transfer mode.
#[derive(Serialize, ToSchema)]
pub(crate) struct SceneDetails {
    id: String,
    name: String,
    #[schema(schema_with = ready_status)]
    status: &'static str,
    /// Number of patches.
    patches: usize,
    #[schema(inline)]
    transfer: TransferMode,
    #[schema(inline)]
    units: Units,
    #[schema(inline)]
    bounds: Bounds,
    lights: Vec<GroupInfo>,
    #[schema(inline)]
    cameras: Vec<CameraDef>,
    #[schema(inline)]
    luminaires: Vec<LuminaireInfo>,
    /// The photometric files (`.ies`, `.ldt`) at the top of the scene folder, sorted (at
    /// most 256): what a luminaire placed per request may name as its `photometry`.
    photometric_files: Vec<String>,
    #[schema(inline)]
    grids: Vec<GridInfo>,
    #[schema(inline)]
    surfaces: Vec<SurfaceInfo>,
    #[schema(inline)]
    bake: BakeInfo,
    /// Where the scene stands, for daylight; null without a [site].
    #[schema(inline, required = true)]
    site: Option<SiteInfo>,
    /// What loading fixed or left out, one line each (see the scene list).
    warnings: Vec<String>,
}

impl SceneDetails {
    fn of(r: &Ready) -> SceneDetails {
        let (m, b) = (&r.model, &r.model.baked);
        SceneDetails {
            id: b.scene.id.clone(),
            name: b.scene.name.clone(),
            status: "ready",
            patches: b.transfer.n,
            transfer: b.transfer.mode,
            units: m.units(),
            bounds: m.bounds(),
            lights: m.groups.clone(),
            cameras: b.scene.cameras.clone(),
            luminaires: m.luminaires(),
            photometric_files: m.photometric_file_names(),
            grids: m.grid_infos(),
            site: m.site_info(),
            surfaces: m.surface_infos(),
            bake: BakeInfo {
                seconds: r.bake_seconds,
                from_cache: b.stats.from_cache,
                residual: b.transfer.info.residual,
            },
            warnings: b.scene.warnings.clone(),
        }
    }
}

#[utoipa::path(get, path = "/api/scenes/{id}", operation_id = "sceneDetails", tags = ["scenes"],
    summary = "Light groups, cameras, luminaires, calculation grids, surfaces (with patch ranges), bounds, units and transfer mode of a scene.",
    params(SceneIdParam),
    responses((status = 200, description = "Scene details.", body = SceneDetails), SceneErrors))]
pub(crate) async fn scene_details(ReadyScene(ready, _): ReadyScene) -> Json<SceneDetails> {
    Json(SceneDetails::of(&ready))
}

/// Per patch, in patch order.
#[derive(Serialize, ToSchema)]
pub(crate) struct Patches<'a> {
    #[schema(inline)]
    patches: Vec<PatchInfo<'a>>,
}

#[utoipa::path(get, path = "/api/scenes/{id}/patches", operation_id = "patches", tags = ["scenes"],
    summary = "Per patch: surface, area (m²), centroid and normal (m). JSON, or binary with `Accept: application/octet-stream`.",
    params(SceneIdParam),
    responses(PatchesAnswer, SizedGetErrors))]
pub(crate) async fn patches(
    ReadyScene(ready, state): ReadyScene,
    headers: HeaderMap,
) -> Result<Response, AppError> {
    let binary_out = wants_binary(&headers);
    let n = ready.model.baked.mesh.len() as u64;
    let bytes = if binary_out { 64 * n } else { 800 * n };
    let what = format!("the list of {n} patches");
    state
        .heavy(bytes, &what, move |_| {
            Ok(patch_list(&ready.model, binary_out))
        })
        .await
}

fn patch_list(model: &Model, binary_out: bool) -> Response {
    let m = &model.baked.mesh;
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
    Json(Patches {
        patches: model.patch_infos(),
    })
    .into_response()
}

/// The shading mesh (layout in [`crate::render::Shading::mesh_bytes`]).
#[utoipa::path(get, path = "/api/scenes/{id}/mesh", operation_id = "mesh", tags = ["scenes"],
    summary = "The shading mesh for client-side drawing: vertices, triangles (one per patch), surface per triangle, and per-vertex patch weights (vertex colour = Σ weight · B[patch]).",
    params(SceneIdParam),
    responses(MeshBuffer, SizedGetErrors))]
pub(crate) async fn mesh(ReadyScene(ready, state): ReadyScene) -> Result<Response, AppError> {
    mesh_answer(&state, ready, 200, "the shading mesh", Ready::mesh_bytes).await
}

/// The preview mesh (see [`crate::render::preview`]).
#[utoipa::path(get, path = "/api/scenes/{id}/mesh/preview", operation_id = "meshPreview", tags = ["scenes"],
    summary = "A coarser shading mesh (about 30,000 triangles) for drawing while the camera moves, in the layout of /mesh. Its vertex weights refer to the scene's patches, so the same per-patch radiosity colours it. Scenes of at most 60,000 patches answer their full mesh.",
    params(SceneIdParam),
    responses(MeshBuffer, SizedGetErrors))]
pub(crate) async fn mesh_preview(
    ReadyScene(ready, state): ReadyScene,
) -> Result<Response, AppError> {
    // Meshing again and locating every preview vertex.
    mesh_answer(&state, ready, 400, "the preview mesh", Ready::preview_bytes).await
}

/// A mesh buffer of `ready`'s, with its layout header: built once per scene off the
/// runtime (`per_patch` bytes a patch while it is built), then a cheap clone of shared
/// bytes.
async fn mesh_answer(
    state: &Arc<AppState>,
    ready: Arc<Ready>,
    per_patch: u64,
    what: &str,
    bytes: fn(&Ready) -> Bytes,
) -> Result<Response, AppError> {
    let n = ready.model.baked.mesh.len() as u64;
    let bytes = state
        .heavy(per_patch * n, what, move |_| Ok(bytes(&ready)))
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
