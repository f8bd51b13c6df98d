//! The body of `POST …/render` and the query of `GET …/render.png`, and their
//! conversion to [`RenderOptions`].

use serde::de::{MapAccess, SeqAccess};
use serde::Deserialize;
use serde_json::json;
use utoipa::openapi::schema::Schema;
use utoipa::openapi::RefOr;
use utoipa::{PartialSchema, ToSchema};

use super::lighting::{sky_state, Direction, Position};
use super::query::{read_query, Param};
use super::{
    choice_impls, deserialize_by, lit_request, object_only, raw, schema_ref, some, visit_numbers,
    Choice, Resolve,
};
use crate::input_limits::MAX_REQUEST_COORD_M;
use crate::model::sky_state::{SkySpec, SkyState};
use crate::model::{Lighting, Model};
use crate::render::final_gather::MAX_FINAL_PIXELS;
use crate::render::pipeline::{
    Quality, RenderOptions, MAX_FOV_DEG, MAX_RANGE_LUX, MIN_FOV_DEG, MIN_RANGE_LUX,
};
use crate::render::{Camera, Format, ToneMap, MAX_SIDE};
use crate::server::json::{numbers, FIELD};
use crate::server::parse::{bounded, bounded_triple, direction, number, shorten};
use crate::server::AppError;

/// Largest exposure, stops either way.
pub(super) const MAX_EXPOSURE: f64 = 40.0;

/// Declares a [`Choice`] over a render setting.
macro_rules! setting {
    ($name:ident($t:ty), [$($text:literal => $value:expr),+], $use:literal, $description:literal) => {
        #[derive(Debug, Clone, Copy)]
        pub(crate) struct $name(pub $t);

        impl Choice for $name {
            const NAMES: &'static [&'static str] = &[$($text),+];
            fn pick(s: &str) -> Option<Self> {
                match s {
                    $($text => Some($name($value)),)+
                    _ => None,
                }
            }
            fn refuse(got: &str) -> String {
                format!("{FIELD} '{got}': use {}", $use)
            }
        }

        impl Default for $name {
            fn default() -> Self {
                Self::pick(Self::NAMES[0]).expect("the default is a name")
            }
        }

        choice_impls!($name, $description);
    };
}

setting!(FormatName(Format),     ["png" => Format::Png, "jpeg" => Format::Jpeg, "jpg" => Format::Jpeg, "exr" => Format::Exr],
    "png, jpeg or exr", "The image format.");
setting!(ModeName(bool), ["shaded" => false, "falsecolor" => true],
    "shaded or falsecolor",
    "falsecolor maps illuminance (lux) on a log scale, with a legend bar labelled in lux at the right edge; the range is in the X-Relight-Falsecolor-Lux header. It is an 8-bit image: not with format exr.");
setting!(QualityName(Quality), ["fast" => Quality::Fast, "final" => Quality::Final],
    "fast or final",
    "fast blends the solved patches per pixel (milliseconds for a new camera). final traces the direct light per pixel, gathers the indirect light from the solved radiosity and shows the luminaires: seconds for a new camera, then as fast as fast for new light-group settings; a per-patch emission or luminaires placed per request are traced for their state, as a new camera is (the last such state is kept per view). False colour is the same in both.");
setting!(TonemapName(ToneMap), ["filmic" => ToneMap::Filmic, "clamp" => ToneMap::Clamp],
    "filmic or clamp", "The tone curve of shaded 8-bit images.");

/// A camera preset id, or a full camera.
#[derive(Debug, Clone)]
pub(crate) enum CameraSpec {
    Preset(String),
    Full(CameraFields),
}

/// A full camera. The target must differ from the position, and up must not be parallel
/// to the view direction.
#[derive(Debug, Clone, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields)]
pub(crate) struct CameraFields {
    position: Position,
    target: Position,
    #[serde(default, deserialize_with = "some")]
    up: Option<Direction>,
    fov_deg: f64,
}

object_only!(CameraFields, "an object {position, target, up, fov_deg}");

deserialize_by! {
    CameraSpec,
    "a preset id or an object {position, target, up, fov_deg}",
    deserialize_any,
    fn visit_str<E>(self, s: &str) -> Result<CameraSpec, E> {
        Ok(CameraSpec::Preset(s.to_string()))
    }
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<CameraSpec, A::Error> {
        let de = serde::de::value::MapAccessDeserializer::new(map);
        CameraFields::deserialize(de).map(CameraSpec::Full)
    }
}

impl PartialSchema for CameraSpec {
    fn schema() -> RefOr<Schema> {
        raw(json!({"oneOf": [
            {"type": "string", "minLength": 1, "description": "Preset id from scene.toml."},
            {"type": "object", "required": ["position", "target", "fov_deg"], "additionalProperties": false,
             "description": "A full camera. The target must differ from the position, and up must not be parallel to the view direction.",
             "properties": {"position": schema_ref("Position"), "target": schema_ref("Position"),
                "up": {"allOf": [schema_ref("Direction")], "default": [0, 1, 0]},
                "fov_deg": {"type": "number", "minimum": MIN_FOV_DEG, "maximum": MAX_FOV_DEG, "description": "Vertical field of view, degrees."}}}],
            "description": "Default: the scene's first preset."}))
    }
}
impl ToSchema for CameraSpec {}

/// Exposure in stops, or `"auto"`.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Exposure {
    Auto,
    Stops(f64),
}

deserialize_by! {
    Exposure,
    "a number of stops or \"auto\"",
    deserialize_any,
    visit_numbers!(Exposure::Stops);
    fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<Exposure, E> {
        match s {
            "auto" => Ok(Exposure::Auto),
            _ => Err(E::invalid_value(serde::de::Unexpected::Str(s), &self)),
        }
    }
}

impl PartialSchema for Exposure {
    fn schema() -> RefOr<Schema> {
        raw(json!({
            "description": "Stops (2^exposure scales radiance), within ±40, or \"auto\" (default): log-average luminance to middle grey.",
            "oneOf": [{"type": "number", "minimum": -MAX_EXPOSURE, "maximum": MAX_EXPOSURE},
                {"type": "string", "enum": ["auto"]}]}))
    }
}
impl ToSchema for Exposure {}

/// The false-colour range `[low, high]`, lux.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LuxRange(f64, f64);

deserialize_by! {
    LuxRange,
    "[low, high] in lux",
    deserialize_seq,
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<LuxRange, A::Error> {
        numbers(seq, &self).map(|[lo, hi]| LuxRange(lo, hi))
    }
}

fn side() -> RefOr<Schema> {
    raw(json!({"type": "integer", "minimum": 1, "maximum": MAX_SIDE, "default": 512}))
}

fn range_schema() -> RefOr<Schema> {
    raw(json!({"type": "array", "minItems": 2, "maxItems": 2,
        "items": {"type": "number", "minimum": MIN_RANGE_LUX, "maximum": MAX_RANGE_LUX},
        "description": "False-colour range [low, high] in lux, high ≥ 1.01 × low (default: max/100 to max)."}))
}

lit_request! {
    /// A lighting state, a camera and the image to make.
    #[derive(Default)]
    RenderRequest, "a JSON object" {
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, inline)]
        camera: Option<CameraSpec>,
        #[serde(default, deserialize_with = "some")]
        #[schema(schema_with = side)]
        width: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[schema(schema_with = side)]
        height: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        exposure: Option<Exposure>,
        #[serde(default)]
        #[schema(inline)]
        format: FormatName,
        #[serde(default)]
        #[schema(inline)]
        mode: ModeName,
        #[serde(default)]
        #[schema(inline)]
        tonemap: TonemapName,
        #[serde(default)]
        #[schema(inline)]
        quality: QualityName,
        #[serde(default, deserialize_with = "some")]
        #[schema(schema_with = range_schema, value_type = Vec<f64>)]
        range: Option<LuxRange>,
        /// Daylight from this sky (a scene with a [site]), added to the light groups' light;
        /// the sun's direct light is traced per pixel.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        sky: Option<SkySpec>,
    }
}

lit_request! {
    /// A design report of a lighting state (light groups, luminaires placed per request):
    /// its images as a render takes them, and the title block's words.
    #[derive(Default)]
    ReportBody, "a JSON object" {
        /// A camera preset's id: one image from it (default: one per preset).
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, min_length = 1)]
        camera: Option<String>,
        #[serde(default, deserialize_with = "some")]
        #[schema(schema_with = side)]
        width: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[schema(schema_with = side)]
        height: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        exposure: Option<Exposure>,
        #[serde(default)]
        #[schema(inline)]
        mode: ModeName,
        #[serde(default)]
        #[schema(inline)]
        tonemap: TonemapName,
        #[serde(default)]
        #[schema(inline)]
        quality: QualityName,
        /// The report's title (default "Lighting design report"); at most 200 characters.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, max_length = 200)]
        title: Option<String>,
        /// The project's name; at most 200 characters.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, max_length = 200)]
        project: Option<String>,
        /// Who made it; at most 200 characters.
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false, max_length = 200)]
        author: Option<String>,
    }
}

impl ReportBody {
    /// The title block's words (title, project, author) and the render request of the
    /// report's images.
    pub(crate) fn into_parts(self) -> ([Option<String>; 3], RenderRequest) {
        let words = [self.title, self.project, self.author];
        let req = RenderRequest {
            lights: self.lights,
            emission: self.emission,
            luminaires: self.luminaires,
            camera: self.camera.map(CameraSpec::Preset),
            width: self.width,
            height: self.height,
            exposure: self.exposure,
            mode: self.mode,
            tonemap: self.tonemap,
            quality: self.quality,
            ..Default::default()
        };
        (words, req)
    }
}

/// A render request in the model's terms.
pub(crate) struct RenderAsk {
    pub lighting: Lighting,
    /// The sky whose daylight is added (not with a per-patch emission).
    pub sky: Option<SkyState>,
    pub options: RenderOptions,
}

impl Resolve for RenderRequest {
    type Resolved = RenderAsk;

    /// The lighting state, the sky and the image's options, checked in that order.
    fn resolve(&self, model: &Model) -> Result<RenderAsk, AppError> {
        Ok(RenderAsk {
            lighting: self.lighting(model)?,
            sky: self.sky(model)?,
            options: self.options(model)?,
        })
    }
}

impl RenderRequest {
    /// The sky, resolved for the scene's site; a sky goes with light groups only.
    fn sky(&self, model: &Model) -> Result<Option<SkyState>, AppError> {
        if self.sky.is_some() && self.emission.is_some() {
            return Err(AppError::Invalid(
                "a render takes a sky with light groups (lights), not with a per-patch emission"
                    .into(),
            ));
        }
        sky_state(self.sky.as_ref(), model)
    }

    /// The camera, image size and look, checked.
    fn options(&self, model: &Model) -> Result<RenderOptions, AppError> {
        let w = size(self.width, "width")?;
        let h = size(self.height, "height")?;
        let camera = camera(self.camera.as_ref(), model, w, h)?;
        let exposure = match self.exposure {
            None | Some(Exposure::Auto) => None,
            Some(Exposure::Stops(e)) => {
                let e = number(e, "exposure")?;
                if e.abs() > MAX_EXPOSURE {
                    return Err(AppError::Invalid(format!(
                        "exposure {e} stops is outside ±40"
                    )));
                }
                Some(e as f32)
            }
        };
        let range = match self.range {
            None => None,
            Some(LuxRange(lo, hi)) => {
                let (min, max) = (MIN_RANGE_LUX, MAX_RANGE_LUX);
                let lo = bounded(lo, "range[0] (lux)", min, max)?;
                let hi = bounded(hi, "range[1] (lux)", min, max)?;
                if hi < lo * 1.01 {
                    return Err(AppError::Invalid(format!(
                        "range [{lo}, {hi}]: the high end must exceed the low end by at least 1 %"
                    )));
                }
                Some((lo as f32, hi as f32))
            }
        };
        let (format, falsecolor) = (self.format.0, self.mode.0);
        if falsecolor && format == Format::Exr {
            return Err(AppError::Invalid(
                "false colour is an 8-bit image: use png or jpeg".into(),
            ));
        }
        let px = w as u64 * h as u64;
        if self.quality.0 == Quality::Final && !falsecolor && px > MAX_FINAL_PIXELS {
            return Err(AppError::Invalid(format!(
                "a final-quality image has at most {MAX_FINAL_PIXELS} pixels (1024×1024); \
                 {w}×{h} is {px}: ask for a smaller image or quality fast"
            )));
        }
        Ok(RenderOptions {
            camera,
            quality: self.quality.0,
            exposure,
            format,
            falsecolor,
            tonemap: self.tonemap.0,
            range,
        })
    }

    /// `render.png?camera=front&w=512&h=512&light.ceiling=0.5&exposure=0&mode=falsecolor`:
    /// 400 for a parameter given twice, unknown, or not a number where one is expected.
    pub(crate) fn from_query(q: &[(String, String)]) -> Result<RenderRequest, AppError> {
        Self::from_query_and(q, |_| Ok(false))
    }

    /// [`Self::from_query`] for a route that takes parameters of its own besides these:
    /// `own` is offered each parameter first and answers true for one it took.
    pub(crate) fn from_query_and<'q>(
        q: &'q [(String, String)],
        mut own: impl FnMut(&Param<'q>) -> Result<bool, AppError>,
    ) -> Result<RenderRequest, AppError> {
        let mut r = RenderRequest::default();
        let lights = read_query(q, render_alias, RENDER_PARAMS, |p| {
            Ok(own(&p)? || r.take(p)?)
        })?;
        r.lights = Some(lights);
        Ok(r)
    }

    /// Takes query parameter `p` of `render.png`; false when it is not one.
    fn take(&mut self, p: Param<'_>) -> Result<bool, AppError> {
        match p.name {
            "camera" => self.camera = Some(CameraSpec::Preset(p.value.to_string())),
            "width" => self.width = Some(p.number()?),
            "height" => self.height = Some(p.number()?),
            "exposure" if p.value == "auto" => self.exposure = Some(Exposure::Auto),
            "exposure" => self.exposure = Some(Exposure::Stops(p.number()?)),
            "mode" => self.mode = p.choice()?,
            "tonemap" => self.tonemap = p.choice()?,
            "quality" => self.quality = p.choice()?,
            _ => return Ok(false),
        }
        Ok(true)
    }

    /// The camera preset the request names, if it names one.
    pub(crate) fn camera_preset(&self) -> Option<&str> {
        match &self.camera {
            Some(CameraSpec::Preset(id)) => Some(id),
            _ => None,
        }
    }

    /// Whether the request gives the image's width or height.
    pub(crate) fn has_size(&self) -> bool {
        self.width.is_some() || self.height.is_some()
    }
}

/// The parameters of `render.png` besides the lights, for the 400 of an unknown one.
const RENDER_PARAMS: &str = "camera, w, h, exposure, mode, tonemap, quality, light.<group>";

/// `render.png`'s short names of the image's size.
fn render_alias(k: &str) -> &str {
    match k {
        "w" => "width",
        "h" => "height",
        k => k,
    }
}

/// An image side, pixels (default 512).
fn size(v: Option<f64>, what: &str) -> Result<u32, AppError> {
    let Some(x) = v else { return Ok(512) };
    let x = number(x, what)?;
    if x.fract() != 0.0 || x < 1.0 || x > MAX_SIDE as f64 {
        return Err(AppError::Invalid(format!(
            "{what} = {x}: must be a whole number from 1 to {MAX_SIDE}"
        )));
    }
    Ok(x as u32)
}

fn camera(spec: Option<&CameraSpec>, model: &Model, w: u32, h: u32) -> Result<Camera, AppError> {
    let scene = &model.baked.scene;
    let cam = match spec {
        None => {
            let def = scene.cameras.first().ok_or_else(|| {
                AppError::Invalid("the scene has no camera preset; pass a full camera".into())
            })?;
            Camera::from_def(def, w, h)
        }
        Some(CameraSpec::Preset(id)) => {
            let def = scene.cameras.iter().find(|c| &c.id == id).ok_or_else(|| {
                let ids: Vec<&str> = scene.cameras.iter().map(|c| c.id.as_str()).collect();
                AppError::Invalid(format!(
                    "unknown camera '{}' (known: {})",
                    shorten(id),
                    ids.join(", ")
                ))
            })?;
            Camera::from_def(def, w, h)
        }
        Some(CameraSpec::Full(c)) => {
            let position = bounded_triple(c.position.0 .0, "camera.position", MAX_REQUEST_COORD_M)?;
            let target = bounded_triple(c.target.0 .0, "camera.target", MAX_REQUEST_COORD_M)?;
            let up = match c.up {
                Some(u) => direction(u.0 .0, "camera.up")?.to_array(),
                None => [0.0, 1.0, 0.0],
            };
            let fov = bounded(c.fov_deg, "camera.fov_deg", MIN_FOV_DEG, MAX_FOV_DEG)?;
            let v3 = |a: [f64; 3]| glam::Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
            Camera {
                position: v3(position),
                target: v3(target),
                up: v3(up),
                fov_deg: fov as f32,
                width: w,
                height: h,
            }
        }
    };
    cam.validate().map_err(AppError::Invalid)?;
    Ok(cam)
}

/// The query of `render.png` as documented (it is read as a list of pairs, to refuse
/// repeats; see [`RenderRequest::from_query`]).
#[derive(utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[allow(dead_code)]
pub(crate) struct RenderQuery {
    /// Camera preset id from scene.toml (default: the first).
    #[param(min_length = 1)]
    camera: Option<String>,
    /// Width, pixels.
    #[param(schema_with = side)]
    w: Option<u32>,
    /// Height, pixels.
    #[param(schema_with = side)]
    h: Option<u32>,
    /// Stops, or auto (default).
    #[param(value_type = Option<Exposure>)]
    exposure: Option<f64>,
    #[param(inline)]
    mode: Option<ModeName>,
    #[param(inline)]
    tonemap: Option<TonemapName>,
    #[param(inline)]
    quality: Option<QualityName>,
}
