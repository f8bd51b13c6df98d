//! `POST /api/scenes/{id}/render` and `GET /api/scenes/{id}/render.png`: relit images
//! through [`crate::render::pipeline`], with views from the server's cache
//! ([`super::super::views`]). All of it runs on the blocking pool.

use std::sync::Arc;
use std::time::Instant;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Query, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde_json::{Map, Value};

use crate::budget::human_bytes;
use crate::model::Lighting;
use crate::render::pipeline::{
    self, Frame, RenderError, RenderOptions, MAX_FOV_DEG, MAX_RANGE_LUX, MIN_FOV_DEG, MIN_RANGE_LUX,
};
use crate::render::{Camera, Format, ToneMap, ViewBuffer, MAX_SIDE};
use crate::server::parse::{
    begin, bounded, bounded_triple, direction, number, parse_lighting, shorten, shown, SceneId,
    MAX_COORDINATE,
};
use crate::server::views::{render_estimate, view_for};
use crate::server::{AppError, AppState, Ready};

fn camera_from(v: Option<&Value>, ready: &Ready, w: u32, h: u32) -> Result<Camera, AppError> {
    let scene = &ready.baked.scene;
    let cam = match v {
        None => {
            let def = scene.cameras.first().ok_or_else(|| {
                AppError::Invalid("the scene has no camera preset; pass a full camera".into())
            })?;
            Camera::from_def(def, w, h)
        }
        Some(Value::String(id)) => {
            let def = scene.cameras.iter().find(|c| &c.id == id).ok_or_else(|| {
                let ids: Vec<&str> = scene.cameras.iter().map(|c| c.id.as_str()).collect();
                AppError::Invalid(format!("unknown camera '{id}' (known: {})", ids.join(", ")))
            })?;
            Camera::from_def(def, w, h)
        }
        Some(Value::Object(o)) => {
            for k in o.keys() {
                if !["position", "target", "up", "fov_deg"].contains(&k.as_str()) {
                    return Err(AppError::Invalid(format!(
                        "camera: unknown field '{k}' (expected position, target, up, fov_deg)"
                    )));
                }
            }
            let get = |k: &str| -> Result<[f64; 3], AppError> {
                bounded_triple(
                    o.get(k).unwrap_or(&Value::Null),
                    &format!("camera.{k}"),
                    MAX_COORDINATE,
                )
            };
            let up = match o.get("up") {
                Some(u) => direction(u, "camera.up")?.to_array(),
                None => [0.0, 1.0, 0.0],
            };
            let fov = bounded(
                o.get("fov_deg").unwrap_or(&Value::Null),
                "camera.fov_deg",
                MIN_FOV_DEG,
                MAX_FOV_DEG,
            )?;
            let v3 = |a: [f64; 3]| glam::Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
            Camera {
                position: v3(get("position")?),
                target: v3(get("target")?),
                up: v3(up),
                fov_deg: fov as f32,
                width: w,
                height: h,
            }
        }
        Some(other) => {
            return Err(AppError::Invalid(format!(
                "camera must be a preset id or {{position, target, up, fov_deg}}, got {}",
                shown(other)
            )))
        }
    };
    cam.validate().map_err(AppError::Invalid)?;
    Ok(cam)
}

fn size(v: Option<&Value>, what: &str, default: u32) -> Result<u32, AppError> {
    match v {
        None => Ok(default),
        Some(v) => {
            let x = number(v, what)?;
            if x.fract() != 0.0 || x < 1.0 || x > MAX_SIDE as f64 {
                return Err(AppError::Invalid(format!(
                    "{what} = {x}: must be a whole number from 1 to {MAX_SIDE}"
                )));
            }
            Ok(x as u32)
        }
    }
}

fn options(body: &Map<String, Value>, ready: &Ready) -> Result<RenderOptions, AppError> {
    let w = size(body.get("width"), "width", 512)?;
    let h = size(body.get("height"), "height", 512)?;
    let camera = camera_from(body.get("camera"), ready, w, h)?;
    let exposure = match body.get("exposure") {
        None => None,
        Some(Value::String(a)) if a == "auto" => None,
        Some(v) => {
            let e = number(v, "exposure")?;
            if e.abs() > 40.0 {
                return Err(AppError::Invalid(format!(
                    "exposure {e} stops is outside ±40"
                )));
            }
            Some(e as f32)
        }
    };
    let pick = |k: &str, default: &str| -> Result<String, AppError> {
        match body.get(k) {
            None => Ok(default.into()),
            Some(Value::String(s)) => Ok(s.clone()),
            Some(v) => Err(AppError::Invalid(format!(
                "{k} must be a string, got {}",
                shown(v)
            ))),
        }
    };
    let format = match pick("format", "png")?.as_str() {
        "png" => Format::Png,
        "jpeg" | "jpg" => Format::Jpeg,
        "exr" => Format::Exr,
        f => {
            return Err(AppError::Invalid(format!(
                "format '{f}': use png, jpeg or exr"
            )))
        }
    };
    let falsecolor = match pick("mode", "shaded")?.as_str() {
        "shaded" => false,
        "falsecolor" => true,
        m => {
            return Err(AppError::Invalid(format!(
                "mode '{m}': use shaded or falsecolor"
            )))
        }
    };
    let tonemap = match pick("tonemap", "filmic")?.as_str() {
        "filmic" => ToneMap::Filmic,
        "clamp" => ToneMap::Clamp,
        t => {
            return Err(AppError::Invalid(format!(
                "tonemap '{t}': use filmic or clamp"
            )))
        }
    };
    let range = match body.get("range") {
        None => None,
        Some(v) => {
            let a = v
                .as_array()
                .filter(|a| a.len() == 2)
                .ok_or_else(|| AppError::Invalid("range must be [low, high] in lux".into()))?;
            let (min, max) = (MIN_RANGE_LUX, MAX_RANGE_LUX);
            let lo = bounded(&a[0], "range[0] (lux)", min, max)?;
            let hi = bounded(&a[1], "range[1] (lux)", min, max)?;
            if hi < lo * 1.01 {
                return Err(AppError::Invalid(format!(
                    "range [{lo}, {hi}]: the high end must exceed the low end by at least 1 %"
                )));
            }
            Some((lo as f32, hi as f32))
        }
    };
    if falsecolor && format == Format::Exr {
        return Err(AppError::Invalid(
            "false colour is an 8-bit image: use png or jpeg".into(),
        ));
    }
    Ok(RenderOptions {
        camera,
        exposure,
        format,
        falsecolor,
        tonemap,
        range,
    })
}

/// Renders and encodes through the view cache.
fn render_image(
    state: &AppState,
    ready: &Ready,
    lighting: &Lighting,
    o: &RenderOptions,
) -> Result<pipeline::Rendered, AppError> {
    let entry = view_for(state, ready, &o.camera);
    let groups = match lighting {
        Lighting::Groups(_) if !o.falsecolor => {
            let g = entry.group_images(ready);
            // The entry may have grown by its group images: keep the cache within bounds.
            super::super::views::trim(state);
            g
        }
        _ => None,
    };
    let frame = Frame {
        view: &entry.buffer,
        groups,
        shading: ready.shading(),
    };
    pipeline::render(&ready.model, frame, lighting, o).map_err(|e| match e {
        RenderError::Query(q) => q.into(),
        RenderError::Encode(m) => AppError::Internal(m),
    })
}

async fn respond(
    state: Arc<AppState>,
    ready: Arc<Ready>,
    lighting: Lighting,
    o: RenderOptions,
) -> Result<Response, AppError> {
    let t0 = Instant::now();
    let format = o.format;
    let bytes = render_estimate(&state, &ready, &o);
    let what = format!(
        "a {}×{} render (view buffer up to {})",
        o.camera.width,
        o.camera.height,
        human_bytes(ViewBuffer::estimate_bytes(&o.camera))
    );
    let st = state.clone();
    let r = state
        .heavy(bytes, &what, move |_| {
            render_image(&st, &ready, &lighting, &o)
        })
        .await?;
    let mut resp = ([(header::CONTENT_TYPE, format.content_type())], r.bytes).into_response();
    let hd = resp.headers_mut();
    if let Ok(v) = format!("{:.3}", t0.elapsed().as_secs_f64() * 1e3).parse() {
        hd.insert("x-relight-render-ms", v);
    }
    if let Some(ev) = r.exposure {
        if let Ok(v) = format!("{ev:.3}").parse() {
            hd.insert("x-relight-exposure", v);
        }
    }
    if let Some((lo, hi)) = r.range {
        if let Ok(v) = format!("{lo},{hi}").parse() {
            hd.insert("x-relight-falsecolor-lux", v);
        }
    }
    hd.insert(
        header::CACHE_CONTROL,
        "no-store".parse().expect("static header"),
    );
    Ok(resp)
}

pub async fn render_post(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, AppError> {
    let (ready, body) = begin(
        &state,
        &id,
        &headers,
        body,
        &[
            "lights", "emission", "camera", "width", "height", "exposure", "format", "mode",
            "tonemap", "range",
        ],
    )
    .await?;
    let lighting = parse_lighting(&body, &ready)?;
    let o = options(&body, &ready)?;
    respond(state, ready, lighting, o).await
}

/// `GET …/render.png?camera=front&w=512&h=512&light.ceiling=0.5&exposure=0&mode=falsecolor`
pub async fn render_get(
    State(state): State<Arc<AppState>>,
    SceneId(id): SceneId,
    Query(q): Query<Vec<(String, String)>>,
) -> Result<Response, AppError> {
    let ready = state.slot(&id)?.ready()?;
    let mut body = Map::new();
    let mut lights = Map::new();
    body.insert("format".into(), Value::from("png"));
    let num = |k: &str, v: &str| -> Result<Value, AppError> {
        v.parse::<f64>().map(Value::from).map_err(|_| {
            AppError::BadRequest(format!(
                "query parameter {}={}: not a number",
                shorten(k),
                shorten(v)
            ))
        })
    };
    let mut seen: Vec<&str> = Vec::with_capacity(q.len());
    for (k, v) in &q {
        let key = if k == "w" {
            "width"
        } else if k == "h" {
            "height"
        } else {
            k.as_str()
        };
        if seen.contains(&key) {
            return Err(AppError::BadRequest(format!(
                "query parameter '{}' is given twice",
                shorten(k)
            )));
        }
        seen.push(key);
        match k.as_str() {
            "camera" => {
                body.insert("camera".into(), Value::from(v.as_str()));
            }
            "w" | "width" => {
                body.insert("width".into(), num(k, v)?);
            }
            "h" | "height" => {
                body.insert("height".into(), num(k, v)?);
            }
            "exposure" if v == "auto" => {}
            "exposure" => {
                body.insert("exposure".into(), num(k, v)?);
            }
            "mode" | "tonemap" => {
                body.insert(k.clone(), Value::from(v.as_str()));
            }
            _ => match k.strip_prefix("light.") {
                Some(g) => {
                    // light.ID=0.5 or light.ID=r,g,b
                    let parts: Vec<&str> = v.split(',').collect();
                    let val = if parts.len() == 3 {
                        let c: Result<Vec<Value>, _> = parts.iter().map(|p| num(k, p)).collect();
                        serde_json::json!({"intensity": 1.0, "color": c?})
                    } else {
                        num(k, v)?
                    };
                    lights.insert(g.to_string(), val);
                }
                None => {
                    return Err(AppError::BadRequest(format!(
                        "unknown query parameter '{}' (camera, w, h, exposure, mode, tonemap, light.<group>)", shorten(k)
                    )))
                }
            },
        }
    }
    body.insert("lights".into(), Value::Object(lights));
    let lighting = parse_lighting(&body, &ready)?;
    let o = options(&body, &ready)?;
    respond(state, ready, lighting, o).await
}
