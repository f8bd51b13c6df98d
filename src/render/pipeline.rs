//! One render pipeline for every front end (`POST /render`, `GET /render.png`,
//! `relight render`): a view (buffer, optional per-group images) and a lighting state in,
//! an encoded image out.
//!
//! Shaded images show radiance L = B/π (cd/m², from radiosity B in lm/m²), exposed and
//! tone-mapped for 8-bit formats, linear in EXR/PFM. False colour shows incident
//! illuminance in lux on a logarithmic scale with a legend.

use super::{
    encode_8bit, encode_exr, encode_pfm, false_color, Camera, Format, GroupImages, Shading, ToneMap,
};
use super::{final_gather, ViewBuffer};
use crate::color::Rgb;
use crate::model::query::Quantity;
use crate::model::{Lighting, Model, QueryError};

/// Lowest and highest ends of a false-colour range, lux.
pub const MIN_RANGE_LUX: f64 = 1e-6;
pub const MAX_RANGE_LUX: f64 = 1e12;

/// Narrowest and widest vertical field of view accepted, degrees.
pub const MIN_FOV_DEG: f64 = 1.0;
pub const MAX_FOV_DEG: f64 = 170.0;

/// How an image is made from the solved scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quality {
    /// The solved patches, Gouraud-blended per pixel: a new camera costs milliseconds.
    #[default]
    Fast,
    /// Direct light traced per pixel, a final gather from the solved radiosity, the
    /// luminaires in view and glossy reflection on glTF materials
    /// ([`super::final_gather`]): a new camera costs seconds, a new
    /// lighting state of light groups as little as with `Fast`.
    Final,
}

/// What to draw and how.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub camera: Camera,
    /// `Final` needs a light-group state and, when per-group images are given in the
    /// [`Frame`], uses them; false colour always shows the patches' illuminance.
    pub quality: Quality,
    /// Stops; None = auto exposure (log-average luminance to middle grey).
    pub exposure: Option<f32>,
    pub format: Format,
    /// Illuminance (lux) in false colour instead of the shaded image.
    pub falsecolor: bool,
    pub tonemap: ToneMap,
    /// False-colour range in lux (default: max/100 .. max).
    pub range: Option<(f32, f32)>,
}

/// An encoded image and the settings it was made with.
pub struct Rendered {
    pub bytes: Vec<u8>,
    /// False-colour range in lux, when in false colour.
    pub range: Option<(f32, f32)>,
    /// Exposure used, stops (shaded 8-bit images).
    pub exposure: Option<f32>,
}

/// Why an image could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The lighting state cannot be answered (the asker's mistake).
    #[error(transparent)]
    Query(#[from] QueryError),
    /// The encoder failed (a bug, never bad input).
    #[error("encoding the image failed: {0}")]
    Encode(String),
}

/// A view of a scene: its rasterization, and per-light-group images when they exist.
pub struct Frame<'a> {
    pub view: &'a ViewBuffer,
    pub groups: Option<&'a GroupImages>,
    pub shading: &'a Shading,
}

/// Renders `lighting` through `frame` and encodes it.
pub fn render(
    model: &Model,
    frame: Frame<'_>,
    lighting: &Lighting,
    o: &RenderOptions,
) -> Result<Rendered, RenderError> {
    let Frame {
        view,
        groups,
        shading,
    } = frame;
    if o.falsecolor {
        let per_patch = model.per_patch(lighting, Quantity::Illuminance)?;
        let img = view.gather(&shading.vertex_values(&per_patch), 1.0);
        return finish_false_color(o, &img);
    }
    if let (Lighting::Groups(wts), Some(gi)) = (lighting, groups) {
        return finish(
            o,
            |exposure| gi.tonemapped(wts, exposure, o.tonemap),
            || gi.linear(wts),
        );
    }
    let values = shading.vertex_values(&model.per_patch(lighting, Quantity::Radiosity)?);
    let scale = std::f32::consts::FRAC_1_PI;
    finish(
        o,
        |exposure| view.gather_tonemapped(&values, scale, exposure, o.tonemap),
        || view.gather(&values, scale),
    )
}

/// Renders per-patch radiosity `b` (lm/m²) and illuminance `h` (lux), n × 3, through
/// `frame`, with per-pixel additions `extra`: radiance (cd/m²) for shaded images and
/// illuminance (lux) for false colour (the traced daylight of [`super::daylight`]).
pub fn render_values(
    frame: Frame<'_>,
    b: &[f32],
    h: &[f32],
    extra: (&[Rgb], &[Rgb]),
    o: &RenderOptions,
) -> Result<Rendered, RenderError> {
    let Frame { view, shading, .. } = frame;
    let add = |mut img: Vec<Rgb>, more: &[Rgb]| {
        for (p, &e) in img.iter_mut().zip(more) {
            *p += e;
        }
        img
    };
    if o.falsecolor {
        let img = add(view.gather(&shading.vertex_values(h), 1.0), extra.1);
        return finish_false_color(o, &img);
    }
    let values = shading.vertex_values(b);
    let scale = std::f32::consts::FRAC_1_PI;
    finish(
        o,
        |exposure| view.gather_tonemapped_plus(&values, scale, extra.0, exposure, o.tonemap),
        || add(view.gather(&values, scale), extra.0),
    )
}

/// Builds the view of `o.camera` (and its `final` images when asked, with `settings`) and
/// renders once (the command line; the server keeps views in a cache).
pub fn render_once(
    model: &Model,
    shading: &Shading,
    lighting: &Lighting,
    o: &RenderOptions,
    settings: &final_gather::FinalSettings,
) -> Result<Rendered, RenderError> {
    let view = ViewBuffer::build(&model.baked.mesh, shading, &o.camera);
    let finals = if o.quality == Quality::Final && !o.falsecolor {
        needs_groups(lighting)?;
        let patches = final_gather::patch_locator(&model.baked.mesh, &model.baked.scene.triangles);
        let cancel = crate::model::Cancel::default();
        Some(final_images(
            model, shading, &patches, &o.camera, settings, &cancel,
        )?)
    } else {
        None
    };
    let frame = Frame {
        view: &view,
        groups: finals.as_ref(),
        shading,
    };
    render(model, frame, lighting, o)
}

/// `Err` unless `lighting` is a light-group state (what `final` images are made of).
pub fn needs_groups(lighting: &Lighting) -> Result<(), QueryError> {
    match lighting {
        Lighting::Groups(_) => Ok(()),
        Lighting::Emission(_) => Err(QueryError::Invalid(
            "quality 'final' renders light-group states (lights); a per-patch emission renders \
             at quality 'fast'"
                .into(),
        )),
    }
}

/// The `final` images of every light group of `model` seen by `cam`, with the work per
/// pixel of `settings` ([`final_gather::build`]); `patches` is
/// [`final_gather::patch_locator`] of its mesh.
pub fn final_images(
    model: &Model,
    shading: &Shading,
    patches: &crate::geometry::patch_locator::PatchLocator,
    cam: &Camera,
    settings: &final_gather::FinalSettings,
    cancel: &crate::model::Cancel,
) -> Result<GroupImages, QueryError> {
    let scene = final_scene(model, shading, patches, None);
    final_gather::build(&scene, cam, settings, cancel)
}

/// The `final` image of `model`'s daylight under `sky` seen by `cam` with `settings`, at
/// unit weight (one group): the sun traced per pixel, the sky through openings and
/// glazing, the daylight's interreflection gathered ([`final_gather::FinalSky`]).
pub fn final_daylight_image(
    model: &Model,
    shading: &Shading,
    patches: &crate::geometry::patch_locator::PatchLocator,
    cam: &Camera,
    sky: &crate::model::sky_state::SkyState,
    settings: &final_gather::FinalSettings,
    cancel: &crate::model::Cancel,
) -> Result<GroupImages, QueryError> {
    let b = &model.baked;
    let site = model.site()?;
    let day = model.patch_daylight(sky)?;
    let luminance = |d: glam::DVec3| sky.luminance(site, d);
    let subdivision = crate::transport::sky_view::subdivision();
    let patch_luminance = sky.patch_luminances(&subdivision);
    let Some(columns) = b.transfer.sky.as_ref() else {
        return Err(QueryError::Invalid(
            "the scene has no daylight transfer".into(),
        ));
    };
    let final_sky = final_gather::FinalSky {
        reflected: &day.b,
        sun: sky
            .sun_direction(site)
            .map(|(direction, normal_illuminance)| super::daylight::SunView {
                direction,
                normal_illuminance,
            }),
        luminance: &luminance,
        glazing: &b.glazing,
        reach: model.reach_length(),
        coefficients: &columns.direct,
        patch_luminance: &patch_luminance,
        subdivision: &subdivision,
        site,
    };
    let scene = final_scene(model, shading, patches, Some(final_sky));
    final_gather::build(&scene, cam, settings, cancel)
}

/// What [`final_gather::build`] reads of `model`, with the daylight of `sky` when given.
fn final_scene<'a>(
    model: &'a Model,
    shading: &'a Shading,
    patches: &'a crate::geometry::patch_locator::PatchLocator,
    sky: Option<final_gather::FinalSky<'a>>,
) -> final_gather::FinalScene<'a> {
    let b = &model.baked;
    final_gather::FinalScene {
        mesh: &b.mesh,
        shading,
        patches,
        bvh: &b.bvh,
        triangles: &b.scene.triangles,
        materials: &b.scene.materials,
        rho: &b.transfer.rho,
        groups: &b.transfer.groups,
        lights: &b.scene.lights,
        sky,
    }
}

/// Encodes per-pixel radiance `rad` (cd/m², `o.camera`'s size, row 0 at the top) as a
/// shaded image: a `final` image under a sky, the groups' and the daylight's summed.
pub fn render_radiance(rad: &[Rgb], o: &RenderOptions) -> Result<Rendered, RenderError> {
    finish(
        o,
        |exposure| super::tonemap::tonemap_pixels(rad.len(), |i| rad[i], exposure, o.tonemap),
        || rad.to_vec(),
    )
}

/// max/100 .. max of an image's luminous values (lux); 0.01 .. 1 for a black image.
fn default_range(img: &[Rgb]) -> (f32, f32) {
    let max = img.iter().map(|p| p.luminance()).fold(0.0, f32::max);
    let max = if max > 0.0 { max } else { 1.0 };
    (max / 100.0, max)
}

/// Encodes an illuminance image `img` (lux) in false colour, over `o.range` or the
/// image's [`default_range`].
fn finish_false_color(o: &RenderOptions, img: &[Rgb]) -> Result<Rendered, RenderError> {
    let (w, h) = (o.camera.width, o.camera.height);
    let (lo, hi) = o.range.unwrap_or_else(|| default_range(img));
    let rgb = false_color(img, w, h, lo, hi);
    let bytes = encode_8bit(&rgb, w, h, o.format).map_err(RenderError::Encode)?;
    Ok(Rendered {
        bytes,
        range: Some((lo, hi)),
        exposure: None,
    })
}

/// Encodes a shaded image: linear EXR/PFM from `linear`, else 8-bit from `tonemapped`.
fn finish(
    o: &RenderOptions,
    tonemapped: impl FnOnce(Option<f32>) -> (Vec<u8>, f32),
    linear: impl FnOnce() -> Vec<Rgb>,
) -> Result<Rendered, RenderError> {
    let (w, h) = (o.camera.width, o.camera.height);
    let linear_bytes = match o.format {
        Format::Exr => Some(encode_exr(&linear(), w, h).map_err(RenderError::Encode)?),
        Format::Pfm => Some(encode_pfm(&linear(), w, h)),
        Format::Png | Format::Jpeg => None,
    };
    if let Some(bytes) = linear_bytes {
        return Ok(Rendered {
            bytes,
            range: None,
            exposure: None,
        });
    }
    let (px, ev) = tonemapped(o.exposure);
    let bytes = encode_8bit(&px, w, h, o.format).map_err(RenderError::Encode)?;
    Ok(Rendered {
        bytes,
        range: None,
        exposure: Some(ev),
    })
}
