//! Request handlers: scenes, patches, mesh, radiosity, illuminance, batch, optimize,
//! health and metrics. Bodies are read by [`super::parse`], which gives every mistake a
//! precise 422 naming the field.

use std::collections::BTreeMap;
use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use glam::DVec3;
use serde_json::{json, Map, Value};

pub use super::parse::*;
use super::{AppError, AppState, Ready};
use crate::color::Rgb;
use crate::model::lighting::known_ids;
use crate::model::report::{
    surface_averages, surface_illuminance, Lux, PowerReport, SurfaceIlluminance,
};
use crate::transport::transfer::Solution;

type ApiResult = Result<Response, AppError>;

pub async fn healthz() -> &'static str {
    "ok"
}

pub async fn not_found() -> AppError {
    AppError::NotFound("no such endpoint; see /api/openapi.json".into())
}

pub async fn metrics(State(state): State<Arc<AppState>>) -> Response {
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        state.metrics.render() + &memory_metrics(&state),
    )
        .into_response()
}

/// Gauges of the memory budget and the view cache, bytes.
fn memory_metrics(state: &AppState) -> String {
    let b = &state.budget;
    let views = state.views.lock().map(|v| v.bytes()).unwrap_or(0);
    let mut out = String::new();
    for (name, help, v) in [
        (
            "relight_memory_budget_bytes",
            "The memory budget.",
            b.total(),
        ),
        (
            "relight_memory_pinned_bytes",
            "Bytes held by loaded scenes.",
            b.pinned(),
        ),
        (
            "relight_memory_reserved_bytes",
            "Bytes reserved by requests in flight.",
            b.used(),
        ),
        (
            "relight_view_cache_bytes",
            "Bytes held by cached view buffers and group images.",
            views as u64,
        ),
    ] {
        out += &format!("# HELP {name} {help}\n# TYPE {name} gauge\n{name} {v}\n");
    }
    out
}

pub async fn openapi() -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        super::openapi::spec().to_string(),
    )
        .into_response()
}

fn scene_summary(slot: &super::SceneSlot) -> Value {
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

pub async fn readyz(State(state): State<Arc<AppState>>) -> Response {
    let scenes: Vec<Value> = state.slots.iter().map(|s| scene_summary(s)).collect();
    let ready = state.settled();
    let status = if ready {
        StatusCode::OK
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    };
    (status, Json(json!({ "ready": ready, "scenes": scenes }))).into_response()
}

pub async fn list_scenes(State(state): State<Arc<AppState>>) -> Json<Value> {
    Json(json!({
        "scenes": state.slots.iter().map(|s| scene_summary(s)).collect::<Vec<_>>()
    }))
}

pub async fn scene_details(State(state): State<Arc<AppState>>, SceneId(id): SceneId) -> ApiResult {
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

fn wants_binary(headers: &HeaderMap) -> bool {
    headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|a| a.contains("application/octet-stream"))
}

fn binary(floats: Vec<f32>, n: usize, layout: &'static str) -> Response {
    let bytes: Vec<u8> = bytemuck::cast_slice(&floats).to_vec();
    (
        [
            (header::CONTENT_TYPE, "application/octet-stream".to_string()),
            (
                header::HeaderName::from_static("x-relight-patches"),
                n.to_string(),
            ),
            (
                header::HeaderName::from_static("x-relight-layout"),
                layout.to_string(),
            ),
        ],
        bytes,
    )
        .into_response()
}

pub async fn patches(
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
pub async fn mesh(State(state): State<Arc<AppState>>, SceneId(id): SceneId) -> ApiResult {
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

use super::json::kind;

/// The full solution for a lighting request.
pub fn solve_for(ready: &Ready, l: &Lighting) -> Result<Solution, AppError> {
    match l {
        Lighting::Groups(w) => Ok(ready.baked.transfer.relight(w)),
        Lighting::Emission(e) => ready
            .baked
            .transfer
            .solve(e)
            .ok_or_else(|| AppError::Internal("factored data missing".into())),
    }
}

fn surface_stats(
    ready: &Ready,
    surfaces: &[usize],
    h: &[f32],
) -> BTreeMap<String, SurfaceIlluminance> {
    surfaces
        .iter()
        .map(|&s| {
            (
                ready.baked.scene.surfaces[s].name.clone(),
                surface_illuminance(&ready.baked.mesh, s, h),
            )
        })
        .collect()
}

// ---------------------------------------------------------------------------- endpoints

pub async fn radiosity(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &["lights", "emission", "surfaces", "quantity"],
    )
    .await?;
    let want_surfaces = flag(&body, "surfaces")?;
    // Per patch: radiosity B (lm/m², leaving) or incident illuminance H (lux, arriving).
    let illuminance = match body.get("quantity") {
        None => false,
        Some(Value::String(q)) if q == "radiosity" => false,
        Some(Value::String(q)) if q == "illuminance" => true,
        Some(v) => {
            return Err(AppError::Invalid(format!(
                "'quantity' must be \"radiosity\" (lm/m2, leaving) or \"illuminance\" (lux, arriving), got {}", shown(v)
            )))
        }
    };
    let (key, unit, layout) = if illuminance {
        (
            "illuminance",
            "lx",
            "f32 LE [patch][r,g,b] incident illuminance, lx",
        )
    } else {
        (
            "radiosity",
            "lm/m2",
            "f32 LE [patch][r,g,b] radiosity, lm/m2",
        )
    };
    let lighting = parse_lighting(&body, &ready)?;
    let n = ready.baked.transfer.n;
    let binary_out = wants_binary(&headers);
    // The hot path: group weights and binary out, no surfaces: one weighted sum (a memory
    // stream of n × groups floats), answered inline.
    if let (Lighting::Groups(w), true, false) = (&lighting, binary_out, want_surfaces) {
        let mut out = vec![0f32; 3 * n];
        if illuminance {
            ready.baked.transfer.illuminance_into(w, &mut out);
        } else {
            ready.baked.transfer.relight_into(w, &mut out);
        }
        return Ok(binary(out, n, layout));
    }
    // Everything else (exact solves, JSON text of n triples) runs off the runtime.
    let bytes = BYTES_PER_PATCH_ANSWER * n as u64;
    let what = format!("the radiosity answer for {n} patches");
    state
        .heavy(bytes, &what, move |_| {
            let b = &ready.baked;
            let sol = solve_for(&ready, &lighting)?;
            let surfaces = want_surfaces.then(|| surface_averages(&b.scene, &b.mesh, &sol));
            let values = if illuminance { sol.h } else { sol.b };
            if binary_out {
                return Ok(binary(values, n, layout));
            }
            Ok(radiosity_json(&b.scene.id, unit, key, &values, surfaces))
        })
        .await
}

/// Bytes a per-patch answer may hold per patch: the solution (b, h, e: 36), the values
/// copied out (12) and JSON text (3 numbers of up to 16 characters, 50).
pub const BYTES_PER_PATCH_ANSWER: u64 = 100;

/// Written by hand: the float array dominates, and ryu into one buffer is ~2x faster
/// than going through serde for 30,000 numbers.
fn radiosity_json(
    scene: &str,
    unit: &str,
    key: &str,
    values: &[f32],
    surfaces: Option<BTreeMap<String, crate::model::report::SurfaceAverage>>,
) -> Response {
    let n = values.len() / 3;
    let mut out = String::with_capacity(40 * n + 256);
    out.push_str(&format!(
        "{{\"scene\":{},\"patches\":{n},\"unit\":\"{unit}\",\"{key}\":[",
        Value::from(scene)
    ));
    let mut fb = ryu::Buffer::new();
    for (i, t) in values.chunks_exact(3).enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push('[');
        for (c, v) in t.iter().enumerate() {
            if c > 0 {
                out.push(',');
            }
            out.push_str(if v.is_finite() {
                fb.format_finite(*v)
            } else {
                "null"
            });
        }
        out.push(']');
    }
    out.push(']');
    if let Some(s) = surfaces {
        out.push_str(",\"surfaces\":");
        match serde_json::to_string(&s) {
            Ok(text) => out.push_str(&text),
            Err(e) => return AppError::Internal(e.to_string()).into_response(),
        }
    }
    out.push('}');
    ([(header::CONTENT_TYPE, "application/json")], out).into_response()
}

pub async fn illuminance(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &["lights", "emission", "surfaces", "points", "grids"],
    )
    .await?;
    let lighting = parse_lighting(&body, &ready)?;
    let mut surfaces = surface_list(body.get("surfaces"), &ready)?;
    let grids = grid_list(body.get("grids"), &ready)?;
    let points = body
        .get("points")
        .map(parse_points)
        .transpose()?
        .unwrap_or_default();
    if surfaces.is_empty()
        && points.is_empty()
        && grids.is_empty()
        && body.get("surfaces").is_none()
    {
        surfaces = (0..ready.baked.scene.surfaces.len()).collect();
    }
    // Group lighting and no points: everything is a weighted sum of precomputed columns.
    if let (Lighting::Groups(w), true) = (&lighting, points.is_empty()) {
        let mut h = vec![0f32; 3 * ready.baked.transfer.n];
        ready.baked.transfer.illuminance_into(w, &mut h);
        let stats = surface_stats(&ready, &surfaces, &h);
        let g = grid_answers(&ready, &grids, w);
        return Ok(Json(json!({
            "unit": "lx", "points": [], "surfaces": stats, "grids": g,
            "power": luminaire_power(&ready, w),
        }))
        .into_response());
    }
    let n = ready.baked.transfer.n as u64;
    let grid_points: u64 = grids.iter().map(|&g| ready.grids[g].len() as u64).sum();
    let bytes = BYTES_PER_PATCH_ANSWER * n + 400 * (points.len() as u64 + grid_points);
    let what = format!(
        "illuminance at {} points and {grid_points} grid points",
        points.len()
    );
    let work = move |ready: Arc<Ready>,
                     cancel: &super::limits::Cancel|
          -> Result<Value, AppError> {
        let sol = solve_for(&ready, &lighting)?;
        let stats = surface_stats(&ready, &surfaces, &sol.h);
        let b = &ready.baked;
        let weights = match &lighting {
            Lighting::Groups(w) => Some(w.as_slice()),
            Lighting::Emission(_) => None,
        };
        let at = |x: DVec3, n: DVec3| -> [f64; 3] {
            let mut e = crate::transport::probe::illuminance_at(&b.mesh, &b.bvh, &sol.b, x, n);
            // Direct light of point luminaires, exact per point.
            for (g, w) in b.scene.lights.iter().zip(weights.unwrap_or(&[])) {
                if g.luminaires.is_empty() || w.iter().all(|&c| c == 0.0) {
                    continue;
                }
                let d = crate::transport::direct::point_illuminance(&b.bvh, &g.luminaires, x, n);
                for c in 0..3 {
                    e[c] += w[c] as f64 * d[c];
                }
            }
            e
        };
        // Points in parallel; each checks whether the client is still there.
        use rayon::prelude::*;
        let at_checked = |x: DVec3, n: DVec3| -> [f64; 3] {
            if cancel.is_cancelled() {
                [0.0; 3]
            } else {
                at(x, n)
            }
        };
        let pts: Vec<Lux> = points
            .par_iter()
            .map(|(x, n)| Lux::new(at_checked(*x, *n)))
            .collect();
        cancel.check()?;
        let grids: Map<String, Value> = match weights {
            Some(w) => grid_answers(&ready, &grids, w),
            None => grids
                .iter()
                .map(|&gi| {
                    let g = &ready.grids[gi].grid;
                    let n = DVec3::from_array(g.normal);
                    let values: Vec<f32> = g
                        .points
                        .par_iter()
                        .map(|p| {
                            crate::color::luminance64(at_checked(DVec3::from_array(*p), n)) as f32
                        })
                        .collect();
                    (
                        g.id.clone(),
                        grid_json(g, crate::model::grid::stats(values)),
                    )
                })
                .collect(),
        };
        cancel.check()?;
        let power = weights.map(|w| luminaire_power(&ready, w));
        Ok(
            json!({ "unit": "lx", "points": pts, "surfaces": stats, "grids": grids, "power": power }),
        )
    };
    let r = ready.clone();
    let v = state.heavy(bytes, &what, move |c| work(r, c)).await?;
    Ok(Json(v).into_response())
}

pub async fn optimize(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &["targets", "groups", "lights"],
    )
    .await?;
    let base = parse_lights(body.get("lights"), &ready)?;
    let scene = &ready.baked.scene;
    // Free groups: the listed ones, else every group.
    let free: Vec<usize> = match body.get("groups") {
        None => (0..scene.lights.len()).collect(),
        Some(Value::Array(a)) if !a.is_empty() => {
            let mut free = Vec::with_capacity(a.len().min(scene.lights.len()));
            for v in a {
                let id = v.as_str().ok_or_else(|| {
                    AppError::Invalid(format!("'groups' holds light group ids, got {}", kind(v)))
                })?;
                let g = scene.light_index(id).ok_or_else(|| {
                    AppError::Invalid(format!(
                        "unknown light group '{}' (known: {})",
                        shorten(id),
                        known_ids(scene)
                    ))
                })?;
                if free.contains(&g) {
                    return Err(AppError::Invalid(format!(
                        "light group '{id}' is listed twice in 'groups'"
                    )));
                }
                free.push(g);
            }
            free
        }
        Some(v) => {
            return Err(AppError::Invalid(format!(
                "'groups' must be a non-empty array of light group ids, got {}",
                shown(v)
            )))
        }
    };
    let targets = body
        .get("targets")
        .and_then(Value::as_array)
        .filter(|a| !a.is_empty())
        .ok_or_else(|| {
            AppError::Invalid(
                "'targets' must be a non-empty array like [{\"grid\": \"desk\", \"eavg_min\": 500, \"u0_min\": 0.6}]".into(),
            )
        })?;
    let mut parsed = Vec::new();
    let mut grid_ix = Vec::new();
    for (k, t) in targets.iter().enumerate() {
        let o = t
            .as_object()
            .ok_or_else(|| AppError::Invalid(format!("targets[{k}] must be an object")))?;
        check_keys(o, &["grid", "eavg_min", "emin_min", "u0_min"])
            .map_err(|e| AppError::Invalid(format!("targets[{k}]: {e}")))?;
        let gi = grid_index(o.get("grid").unwrap_or(&Value::Null), &ready)?;
        if grid_ix.contains(&gi) {
            return Err(AppError::Invalid(format!(
                "targets[{k}]: grid '{}' already has a target; give one target per grid with all its bounds",
                ready.grids[gi].grid.id
            )));
        }
        let bound = |key: &str, max: f64| -> Result<Option<f64>, AppError> {
            o.get(key)
                .map(|v| {
                    let x = number(v, &format!("targets[{k}].{key}"))?;
                    if !(0.0..=max).contains(&x) {
                        return Err(AppError::Invalid(format!(
                            "targets[{k}].{key} = {x}: must be in 0..{max}"
                        )));
                    }
                    Ok(x)
                })
                .transpose()
        };
        let t = crate::model::optimize::Target {
            grid: ready.grids[gi].grid.id.clone(),
            eavg_min: bound("eavg_min", 1e6)?,
            emin_min: bound("emin_min", 1e6)?,
            u0_min: bound("u0_min", 1.0)?,
        };
        if t.eavg_min.is_none() && t.emin_min.is_none() && t.u0_min.is_none() {
            return Err(AppError::Invalid(format!(
                "targets[{k}] sets no bound: give eavg_min, emin_min or u0_min"
            )));
        }
        if t.u0_min.is_some() && !(t.eavg_min > Some(0.0) || t.emin_min > Some(0.0)) {
            return Err(AppError::Invalid(format!(
                "targets[{k}]: u0_min needs a positive eavg_min or emin_min as well: a ratio alone sets no light level, and all lights off would use the least flux"
            )));
        }
        parsed.push(t);
        grid_ix.push(gi);
    }
    let rows: u64 = grid_ix.iter().map(|&g| ready.grids[g].len() as u64).sum();
    let bytes = 2 * rows * (free.len() as u64 + 2) * 64 + (1 << 20);
    let what = format!("optimizing {} groups over {rows} grid points", free.len());
    let r = ready.clone();
    state.heavy(bytes, &what, move |_| {
        let t0 = std::time::Instant::now();
        let scene = &r.baked.scene;
        let is_free = |g: usize| free.contains(&g);
        // Fixed groups keep the given state; free ones are 0 in the fixed part.
        let fixed_w: Vec<Rgb> = (0..scene.lights.len())
            .map(|g| if is_free(g) { [0.0; 3] } else { base[g] })
            .collect();
        let terms: Vec<_> = grid_ix
            .iter()
            .map(|&gi| {
                let gr = &r.grids[gi];
                crate::model::optimize::GridTerms {
                    free: free
                        .iter()
                        .map(|&g| gr.group_values(g, scene.lights[g].color))
                        .collect(),
                    fixed: gr.values(&fixed_w).iter().map(|&v| v as f64).collect(),
                }
            })
            .collect();
        let flux: Vec<f64> = free
            .iter()
            .map(|&g| r.groups[g].lumens * crate::color::luminance(scene.lights[g].color) as f64)
            .collect();
        let levels = crate::model::optimize::optimize(&flux, &parsed, &terms)
            .map_err(|e| AppError::Invalid(e.to_string()))?;
        let mut w = fixed_w.clone();
        for (&g, &x) in free.iter().zip(&levels) {
            w[g] = scene.lights[g].color.map(|c| c * x as f32);
        }
        let solve_ms = t0.elapsed().as_secs_f64() * 1e3;
        let grids = grid_answers(&r, &grid_ix, &w);
        let lights: Map<String, Value> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(g, l)| {
                let wt = w[g];
                let intensity = if is_free(g) {
                    levels[free.iter().position(|&f| f == g).unwrap_or(0)]
                } else {
                    let y = crate::color::luminance(l.color) as f64;
                    if y > 0.0 { crate::color::luminance(wt) as f64 / y } else { 0.0 }
                };
                (l.id.clone(), json!({"intensity": intensity, "color": l.color, "free": is_free(g)}))
            })
            .collect();
        let targets: Vec<Value> = parsed
            .iter()
            .map(|t| {
                let s = &grids[&t.grid];
                let (avg, min, u0) = (s["avg"].as_f64().unwrap_or(0.0), s["min"].as_f64().unwrap_or(0.0), s["u0"].as_f64().unwrap_or(0.0));
                let tol = 1e-6;
                let met = t.eavg_min.is_none_or(|e| avg >= e * (1.0 - tol))
                    && t.emin_min.is_none_or(|e| min >= e * (1.0 - tol))
                    && t.u0_min.is_none_or(|u| u0 >= u - tol);
                json!({"grid": t.grid, "eavg_min": t.eavg_min, "emin_min": t.emin_min, "u0_min": t.u0_min,
                       "achieved": {"avg": avg, "min": min, "u0": u0}, "met": met})
            })
            .collect();
        let total: f64 = (0..scene.lights.len())
            .map(|g| crate::color::luminance64([0, 1, 2].map(|c| w[g][c] as f64))
                * r.groups[g].lumens)
            .sum();
        Ok(Json(json!({
            "lights": lights,
            "lumens": total,
            "power": luminaire_power(&r, &w),
            "targets": targets,
            "grids": grids,
            "solve_ms": solve_ms,
        }))
        .into_response())
    })
    .await
}

fn grid_json(g: &crate::scene::Grid, s: crate::model::grid::GridStats) -> Value {
    json!({
        "name": g.name, "unit": "lx", "count": g.points.len(), "layout": g.layout,
        "avg": s.avg, "min": s.min, "max": s.max, "u0": s.u0, "min_max": s.min_max,
        "values": s.values,
    })
}

/// Grid statistics for group weights, keyed by grid id.
pub fn grid_answers(ready: &Ready, grids: &[usize], w: &[Rgb]) -> Map<String, Value> {
    grids
        .iter()
        .map(|&gi| {
            let g = &ready.grids[gi];
            (g.grid.id.clone(), grid_json(&g.grid, g.stats(w)))
        })
        .collect()
}

/// Flux (lm) and power (W) of the point luminaires in a lighting state. Watts scale with
/// the luminous level of each group (dimming assumed proportional).
pub fn luminaire_power(ready: &Ready, w: &[Rgb]) -> Value {
    let mut lumens = 0.0;
    let mut watts = 0.0;
    let mut watts_known = true;
    for ((g, info), wt) in ready.baked.transfer.groups.iter().zip(&ready.groups).zip(w) {
        if info.luminaires == 0 {
            continue;
        }
        let lm = crate::color::luminance64([0, 1, 2].map(|c| wt[c] as f64 * g.flux[c]));
        lumens += lm;
        match info.watts {
            Some(full) if info.lumens > 0.0 => {
                watts += full * lm / crate::color::luminance64(g.flux)
            }
            _ => watts_known = false,
        }
    }
    json!({"luminaire_lumens": lumens, "luminaire_watts": if watts_known { Some(watts) } else { None }})
}

pub async fn batch(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &["states", "surfaces", "radiosity", "grids"],
    )
    .await?;
    let grids = grid_list(body.get("grids"), &ready)?;
    let states = body
        .get("states")
        .and_then(Value::as_array)
        .ok_or_else(|| AppError::Invalid("'states' must be an array of lighting states".into()))?;
    if states.is_empty() || states.len() > MAX_BATCH {
        return Err(AppError::Invalid(format!(
            "'states' has {} entries; give 1 to {MAX_BATCH}",
            states.len()
        )));
    }
    let with_radiosity = flag(&body, "radiosity")?;
    let mut surfaces = surface_list(body.get("surfaces"), &ready)?;
    if body.get("surfaces").is_none() {
        surfaces = (0..ready.baked.scene.surfaces.len()).collect();
    }
    // Memory: every emission state holds a per-patch vector; every answer holds its
    // surfaces, grids and (when asked) radiosity as JSON values, then as text.
    let n = ready.baked.transfer.n as u64;
    let emission_states = states
        .iter()
        .filter(|s| s.get("emission").is_some())
        .count() as u64;
    let grid_points: u64 = grids.iter().map(|&g| ready.grids[g].len() as u64).sum();
    let per_state =
        400 * surfaces.len() as u64 + 48 * grid_points + if with_radiosity { 150 * n } else { 0 };
    let bytes =
        2 * states.len() as u64 * per_state + emission_states * 12 * n + BYTES_PER_PATCH_ANSWER * n;
    let what = format!("a batch of {} states", states.len());
    let r = ready.clone();
    let results = state
        .heavy(bytes, &what, move |cancel| {
            let states = body.get("states").and_then(Value::as_array).map_or(&[][..], |v| v);
            let mut results = Vec::with_capacity(states.len());
            for (k, s) in states.iter().enumerate() {
                cancel.check()?;
                let at = |e: AppError| AppError::Invalid(format!("states[{k}]: {e}"));
                let obj = s
                    .as_object()
                    .ok_or_else(|| AppError::Invalid(format!("states[{k}] must be an object")))?;
                check_keys(obj, &["lights", "emission"]).map_err(at)?;
                let l = parse_lighting(obj, &r).map_err(at)?;
                let sol = solve_for(&r, &l)?;
                let mut v = json!({
                    "surfaces": surface_stats(&r, &surfaces, &sol.h),
                    "power": PowerReport::new(r.baked.transfer.power(&sol)),
                });
                if with_radiosity {
                    let rgb: &[[f32; 3]] = bytemuck::cast_slice(&sol.b);
                    v["radiosity"] = json!(rgb);
                }
                if !grids.is_empty() {
                    let Lighting::Groups(w) = l else {
                        return Err(at(AppError::Invalid(
                            "grids need light-group states (per-patch emission has no grid columns)".into(),
                        )));
                    };
                    v["grids"] = Value::Object(grid_answers(&r, &grids, &w));
                }
                results.push(v);
            }
            Ok(results)
        })
        .await?;
    Ok(Json(json!({ "unit": {"illuminance": "lx", "radiosity": "lm/m2", "power": "lm"}, "results": results })).into_response())
}
