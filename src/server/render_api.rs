//! `POST /api/scenes/{id}/render` and `GET /api/scenes/{id}/render.png`: relit images.
//!
//! View buffers are built once per (scene, camera, size) and kept in a bounded LRU
//! ([`ViewCache`]); a relit image is then a gather over the buffer plus encoding. All of
//! it runs on the blocking pool.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Query, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde_json::{Map, Value};

use super::api::{
    bounded, bounded_triple, direction, number, parse_lighting, shown, solve_for, Lighting,
    SceneId, MAX_COORDINATE,
};
use crate::budget::human_bytes;

/// Lowest and highest ends of a false-colour range, lux.
pub const MIN_RANGE_LUX: f64 = 1e-6;
pub const MAX_RANGE_LUX: f64 = 1e12;

/// Narrowest and widest vertical field of view accepted, degrees.
pub const MIN_FOV_DEG: f64 = 1.0;
pub const MAX_FOV_DEG: f64 = 170.0;
use super::{AppError, AppState, Ready};
use crate::render::{self, Camera, Format, GroupImages, ToneMap, ViewBuffer, MAX_SIDE};

type ViewKey = (String, [u32; 12]);

/// One cached view: its buffer and, made on first use when they are smaller than the
/// buffer, per-light-group images.
pub struct View {
    pub buffer: ViewBuffer,
    groups: OnceLock<Option<GroupImages>>,
}

impl View {
    /// Bytes this entry holds now: the buffer, plus its group images once made.
    fn bytes(&self) -> usize {
        self.buffer.bytes()
            + self
                .groups
                .get()
                .and_then(|g| g.as_ref())
                .map_or(0, GroupImages::bytes)
    }

    /// Whether group images for `groups` light groups would still have to be made.
    fn group_images_pending(&self, groups: usize) -> bool {
        self.groups.get().is_none() && GroupImages::worthwhile(&self.buffer, groups)
    }

    /// Per-group images for `ready`'s light groups, or None when a gather reads less.
    fn group_images(&self, ready: &Ready) -> Option<&GroupImages> {
        self.groups
            .get_or_init(|| {
                let t = &ready.baked.transfer;
                if !GroupImages::worthwhile(&self.buffer, t.group_count()) {
                    return None;
                }
                Some(GroupImages::radiance(&self.buffer, ready.shading(), t))
            })
            .as_ref()
    }
}

/// A cache slot: filled once by the first request for its key; concurrent requests for
/// the same key wait for that build instead of building their own.
#[derive(Default)]
struct Slot {
    view: OnceLock<Arc<View>>,
    building: Mutex<()>,
}

/// A least-recently-used cache of views, bounded by the bytes its entries really hold
/// (buffers and group images, measured by allocated capacity).
pub struct ViewCache {
    map: HashMap<ViewKey, Arc<Slot>>,
    order: VecDeque<ViewKey>,
    max_bytes: usize,
}

impl ViewCache {
    pub fn new(max_bytes: u64) -> ViewCache {
        ViewCache {
            map: HashMap::new(),
            order: VecDeque::new(),
            max_bytes: max_bytes.min(usize::MAX as u64) as usize,
        }
    }

    /// The slot for `k`, made empty if new; marks it most recently used.
    fn slot(&mut self, k: &ViewKey) -> Arc<Slot> {
        self.order.retain(|x| x != k);
        self.order.push_back(k.clone());
        self.map.entry(k.clone()).or_default().clone()
    }

    /// The finished view for `k`, if cached.
    fn peek(&self, k: &ViewKey) -> Option<Arc<View>> {
        self.map.get(k).and_then(|s| s.view.get().cloned())
    }

    /// Bytes held by finished entries.
    pub fn bytes(&self) -> usize {
        self.map
            .values()
            .filter_map(|s| s.view.get())
            .map(|v| v.bytes())
            .sum()
    }

    /// Evicts least recently used finished entries until the cache fits its bound.
    /// Entries still being built are left alone (their builders hold a reservation).
    fn trim(&mut self) {
        let mut total = self.bytes();
        let mut k = 0;
        while total > self.max_bytes && k < self.order.len() {
            let key = self.order[k].clone();
            let done = self
                .map
                .get(&key)
                .and_then(|s| s.view.get().map(|v| v.bytes()));
            match done {
                Some(b) => {
                    self.map.remove(&key);
                    self.order.remove(k);
                    total -= b;
                }
                None => k += 1,
            }
        }
    }

    /// Drops a slot whose build failed, so that the next request tries again.
    fn forget_empty(&mut self, k: &ViewKey) {
        if self.map.get(k).is_some_and(|s| s.view.get().is_none()) {
            self.map.remove(k);
            self.order.retain(|x| x != k);
        }
    }

    /// Finished views cached.
    pub fn len(&self) -> usize {
        self.map.values().filter(|s| s.view.get().is_some()).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// What to draw and how.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub camera: Camera,
    /// Stops; None = auto exposure.
    pub exposure: Option<f32>,
    pub format: Format,
    pub falsecolor: bool,
    pub tonemap: ToneMap,
    /// False-colour range in lux (default: max/100 .. max).
    pub range: Option<(f32, f32)>,
}

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

fn view_key(ready: &Ready, cam: &Camera) -> ViewKey {
    (ready.baked.scene.id.clone(), cam.key())
}

/// The view buffer for this scene and camera, from the cache or built now. Concurrent
/// requests for the same view wait for one build. The caller has reserved the build's
/// memory (see [`render_estimate`]).
pub fn view_for(state: &AppState, ready: &Ready, cam: &Camera) -> Arc<View> {
    let key = view_key(ready, cam);
    let slot = lock(&state.views).slot(&key);
    if let Some(v) = slot.view.get() {
        return v.clone();
    }
    let _building = lock(&slot.building);
    if let Some(v) = slot.view.get() {
        return v.clone();
    }
    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        Arc::new(View {
            buffer: ViewBuffer::build(&ready.baked.mesh, ready.shading(), cam),
            groups: OnceLock::new(),
        })
    }));
    match built {
        Ok(v) => {
            let v = slot.view.get_or_init(|| v).clone();
            lock(&state.views).trim();
            v
        }
        Err(p) => {
            lock(&state.views).forget_empty(&key);
            std::panic::resume_unwind(p)
        }
    }
}

/// Peak bytes a render may allocate beyond what is cached: the view buffer and group
/// images when not cached yet, the linear and 8-bit images, and the encoded file.
pub fn render_estimate(state: &AppState, ready: &Ready, o: &RenderOptions) -> u64 {
    let px = o.camera.width as u64 * o.camera.height as u64;
    let groups = ready.baked.transfer.group_count();
    let n = ready.baked.transfer.n as u64;
    let images = px * (12 + 3 + 4) + 12 * n * 3;
    let view = match lock(&state.views).peek(&view_key(ready, &o.camera)) {
        Some(v) if v.group_images_pending(groups) => GroupImages::estimate_bytes(&v.buffer, groups),
        Some(_) => 0,
        None => {
            ViewBuffer::estimate_bytes(&o.camera)
                // Group images are at most the size of the buffer (else not made).
                + 2 * (ViewBuffer::estimate_bytes(&o.camera)).min(24 * groups as u64 * px)
        }
    };
    images + view
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// An encoded image and the settings it was made with.
pub struct Rendered {
    pub bytes: Vec<u8>,
    /// False-colour range in lux, when in false colour.
    pub range: Option<(f32, f32)>,
    /// Exposure used, stops (shaded 8-bit images).
    pub exposure: Option<f32>,
}

/// Renders and encodes.
pub fn render_image(
    state: &AppState,
    ready: &Ready,
    lighting: &Lighting,
    o: &RenderOptions,
) -> Result<Rendered, AppError> {
    let entry = view_for(state, ready, &o.camera);
    let view = &entry.buffer;
    let shading = ready.shading();
    let (w, h) = (o.camera.width, o.camera.height);
    let per_patch = |want_h: bool| -> Result<Vec<f32>, AppError> {
        Ok(match lighting {
            Lighting::Groups(wts) => {
                let mut out = vec![0f32; 3 * ready.baked.transfer.n];
                if want_h {
                    ready.baked.transfer.illuminance_into(wts, &mut out);
                } else {
                    ready.baked.transfer.relight_into(wts, &mut out);
                }
                out
            }
            l => {
                let s = solve_for(ready, l)?;
                if want_h {
                    s.h
                } else {
                    s.b
                }
            }
        })
    };
    if o.falsecolor {
        let img = view.gather(&shading.vertex_values(&per_patch(true)?), 1.0);
        let (lo, hi) = o.range.unwrap_or_else(|| {
            let max = img
                .iter()
                .map(|p| crate::color::luminance(*p))
                .fold(0.0, f32::max);
            let max = if max > 0.0 { max } else { 1.0 };
            (max / 100.0, max)
        });
        let rgb = render::false_color(&img, w, h, lo, hi);
        let bytes = render::encode_8bit(&rgb, w, h, o.format).map_err(AppError::Internal)?;
        return Ok(Rendered {
            bytes,
            range: Some((lo, hi)),
            exposure: None,
        });
    }
    if let (Lighting::Groups(wts), Some(gi)) = (lighting, entry.group_images(ready)) {
        // The entry may have grown by its group images: keep the cache within bounds.
        lock(&state.views).trim();
        return finish(
            o,
            |exposure| gi.tonemapped(wts, exposure, o.tonemap),
            || gi.linear(wts),
        );
    }
    let values = shading.vertex_values(&per_patch(false)?);
    let scale = std::f32::consts::FRAC_1_PI;
    finish(
        o,
        |exposure| view.gather_tonemapped(&values, scale, exposure, o.tonemap),
        || view.gather(&values, scale),
    )
}

/// Encodes a shaded image: linear EXR from `linear`, else 8-bit from `tonemapped`.
fn finish(
    o: &RenderOptions,
    tonemapped: impl FnOnce(Option<f32>) -> (Vec<u8>, f32),
    linear: impl FnOnce() -> Vec<crate::color::Rgb>,
) -> Result<Rendered, AppError> {
    let (w, h) = (o.camera.width, o.camera.height);
    if o.format == Format::Exr {
        let bytes = render::encode_exr(&linear(), w, h).map_err(AppError::Internal)?;
        return Ok(Rendered {
            bytes,
            range: None,
            exposure: None,
        });
    }
    let (px, ev) = tonemapped(o.exposure);
    let bytes = render::encode_8bit(&px, w, h, o.format).map_err(AppError::Internal)?;
    Ok(Rendered {
        bytes,
        range: None,
        exposure: Some(ev),
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
    let (ready, body) = super::api::begin(
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
                super::api::shorten(k),
                super::api::shorten(v)
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
                super::api::shorten(k)
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
                        "unknown query parameter '{}' (camera, w, h, exposure, mode, tonemap, light.<group>)", super::api::shorten(k)
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
