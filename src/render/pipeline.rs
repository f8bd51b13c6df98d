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
use crate::model::sky_state::SkyState;
use crate::model::{Cancel, Lighting, Model, QueryError};
use crate::scene::LightGroup;
use crate::transport::transfer::GroupColumns;

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
    /// lighting state of light groups as little as with `Fast`, any other state (an
    /// emission vector, luminaires placed per request) what a new camera costs.
    Final,
}

/// What to draw and how.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub camera: Camera,
    /// `Final` uses the `final` images given in the [`Frame`] (the groups', or one state's
    /// from [`final_state_image`]); false colour always shows the patches' illuminance.
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
/// renders once, under `sky` when given (the command line; the server keeps views in a
/// cache).
pub fn render_once(
    model: &Model,
    shading: &Shading,
    lighting: &Lighting,
    sky: Option<&SkyState>,
    o: &RenderOptions,
    settings: &final_gather::FinalSettings,
) -> Result<Rendered, RenderError> {
    let view = ViewBuffer::build(&model.baked.mesh, shading, &o.camera);
    let cancel = Cancel::default();
    let mut finals = None;
    let mut daylight = None;
    let state_weight = Lighting::Groups(vec![Rgb::ONE]);
    let mut lighting = lighting;
    if wants_finals(o) {
        let patches = final_gather::patch_locator(&model.baked.mesh, &model.baked.scene.triangles);
        let cam = &o.camera;
        finals = Some(if let Lighting::Groups(_) = lighting {
            final_images(model, shading, &patches, cam, settings, &cancel)?
        } else {
            let image =
                final_state_image(model, shading, &patches, cam, lighting, settings, &cancel)?;
            lighting = &state_weight;
            image
        });
        if let Some(sky) = sky {
            daylight = Some(final_daylight_image(
                model, shading, &patches, &o.camera, sky, settings, &cancel,
            )?);
        }
    }
    let frame = Frame {
        view: &view,
        groups: finals.as_ref(),
        shading,
    };
    match sky {
        Some(sky) => render_daylit(
            model,
            frame,
            lighting,
            Daylit {
                sky,
                final_image: daylight.as_ref(),
            },
            o,
        ),
        None => render(model, frame, lighting, o),
    }
}

/// Whether a render of `o` is made of `final` images (shaded, at quality `final`).
pub fn wants_finals(o: &RenderOptions) -> bool {
    o.quality == Quality::Final && !o.falsecolor
}

/// Daylight to add to an image: the sky, and at `final` quality its `final` image
/// ([`final_daylight_image`]).
#[derive(Clone, Copy)]
pub struct Daylit<'a> {
    pub sky: &'a SkyState,
    pub final_image: Option<&'a GroupImages>,
}

/// Renders `lighting` under `day.sky` through `frame` and encodes it. With the `final`
/// images (the groups' in `frame`, the daylight's in `day`) the two are summed per pixel,
/// nothing from the patches. Otherwise the daylight is the patches' plus the sun traced per
/// pixel (with shadows) and the sky seen out of the scene, and the light groups the
/// patches'.
pub fn render_daylit(
    model: &Model,
    frame: Frame<'_>,
    lighting: &Lighting,
    day: Daylit<'_>,
    o: &RenderOptions,
) -> Result<Rendered, RenderError> {
    if let (Some(f), Some(d), Lighting::Groups(w)) = (frame.groups, day.final_image, lighting) {
        let mut rad = d.linear(&[Rgb::ONE]);
        for (r, g) in rad.iter_mut().zip(f.linear(w)) {
            *r += g;
        }
        return render_radiance(&rad, o);
    }
    let sky = day.sky;
    let patches = model.patch_daylight_without_sun(sky)?;
    let (mut b, mut h) = (patches.b, patches.h);
    if let Lighting::Groups(w) = lighting {
        let t = &model.baked.transfer;
        let mut more = vec![0f32; b.len()];
        t.relight_into(w, &mut more);
        b.iter_mut().zip(&more).for_each(|(a, x)| *a += x);
        t.illuminance_into(w, &mut more);
        h.iter_mut().zip(&more).for_each(|(a, x)| *a += x);
    } else {
        // Emission or luminaires placed for the request: solved, then added the same way.
        let s = model.solve(lighting)?;
        b.iter_mut().zip(&s.b).for_each(|(a, x)| *a += x);
        h.iter_mut().zip(&s.h).for_each(|(a, x)| *a += x);
    }
    let site = model.site()?;
    let scene = super::daylight::DaylightScene {
        mesh: &model.baked.mesh,
        bvh: &model.baked.bvh,
        glazing: &model.baked.glazing,
        rho: &model.baked.transfer.rho,
        reach: model.reach_length(),
    };
    let (rad, lux) = super::daylight::daylight_pixels(
        &scene,
        frame.view,
        &o.camera,
        sun_view(sky, site),
        &|d| sky.luminance(site, d),
    );
    render_values(frame, &b, &h, (&rad, &lux), o)
}

/// The sun of `sky` at `site` as the tracers take it, when it shines.
fn sun_view(sky: &SkyState, site: &crate::daylight::Site) -> Option<super::daylight::SunView> {
    sky.sun_direction(site)
        .map(|(direction, normal_illuminance)| super::daylight::SunView {
            direction,
            normal_illuminance,
        })
}

/// What a render finds made before it starts: the server's cached view; nothing on the
/// command line ([`Made::default`], then every part is estimated).
#[derive(Debug, Clone, Copy, Default)]
pub struct Made {
    /// When the view buffer is built: the bytes its group images still take (0 once made,
    /// or when they are not worth making). None when the buffer is to be built.
    pub view: Option<u64>,
    /// Whether the `final` images are built.
    pub finals: bool,
    /// The points per group a `final` build gathers at ([`final_gather::gather_points`]).
    pub gather_points: u64,
    /// Bytes the patch lookup of `final` renders still takes (0 once built).
    pub patch_locator: u64,
    /// For a state that the groups' images cannot sum to, whether its `final` image
    /// ([`final_state_image`]) is made; None for a light-group state.
    pub state_image: Option<bool>,
}

/// Peak bytes a render of `o` (under a sky when `sky`) may allocate beyond what `made`
/// holds: the view buffer and group images when not made yet, the `final` images when
/// asked for and not made, the linear and 8-bit images and the encoded file; under a sky,
/// the per-pixel and per-patch daylight and its own `final` image.
pub fn estimate_bytes(model: &Model, o: &RenderOptions, sky: bool, made: &Made) -> u64 {
    let cam = &o.camera;
    let px = cam.width as u64 * cam.height as u64;
    let groups = model.baked.transfer.group_count();
    let n = model.baked.transfer.n as u64;
    let images = px * (12 + 3 + 4) + 12 * n * 3;
    let view = made.view.unwrap_or_else(|| {
        ViewBuffer::estimate_bytes(cam)
            // Group images are at most the size of the buffer (else not made).
            + 2 * ViewBuffer::estimate_bytes(cam).min(24 * groups as u64 * px)
    });
    let finals = match (wants_finals(o), made.state_image) {
        (false, _) | (true, Some(true)) => 0,
        (true, None) if made.finals => 0,
        (true, None) => {
            final_gather::estimate_bytes(cam, groups, made.gather_points) + made.patch_locator
        }
        // The state's solution (e, b, h) besides its image.
        (true, Some(false)) => {
            final_gather::estimate_bytes(cam, 1, made.gather_points) + made.patch_locator + 36 * n
        }
    };
    let mut bytes = images + view + finals;
    if sky {
        // Per-pixel daylight (two RGB images) and per-patch daylight (b, h and a column).
        bytes += 24 * px + 36 * model.patches() as u64;
        if wants_finals(o) {
            // The daylight's own `final` image, built per sky.
            bytes += final_gather::estimate_bytes(cam, 1, made.gather_points);
        }
    }
    bytes
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
    sky: &SkyState,
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
        sun: sun_view(sky, site),
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
        emitters: final_gather::EmitterLight::PerGroup,
    }
}

/// The `final` image of one lighting state seen by `cam`, traced whole for it as a single
/// group at unit weight (render it at weights `[1]`): for a per-patch emission and
/// luminaires placed per request, which the groups' images cannot sum to. The state is
/// solved, its luminaires (the scene's that shine, less those taken out, and those put
/// in, [`Placed::lit`]) light every pixel exactly as the groups' do, and so do an
/// emission vector's emitting patches ([`final_gather::EmitterLight::Patches`]).
/// It costs what a new camera's `final` images cost.
///
/// [`Placed::lit`]: crate::model::placed::Placed::lit
pub fn final_state_image(
    model: &Model,
    shading: &Shading,
    patches: &crate::geometry::patch_locator::PatchLocator,
    cam: &Camera,
    lighting: &Lighting,
    settings: &final_gather::FinalSettings,
    cancel: &Cancel,
) -> Result<GroupImages, QueryError> {
    use crate::model::placed::Placed;
    use final_gather::EmitterLight;
    let scene = &model.baked.scene;
    let (lit, emitters) = match lighting {
        Lighting::Groups(w) => {
            let p = Placed {
                weights: w.clone(),
                changes: vec![],
            };
            (p.lit(scene), EmitterLight::AnyPatch)
        }
        Lighting::Placed(p) => (p.lit(scene), EmitterLight::AnyPatch),
        Lighting::Emission(_) => (vec![], EmitterLight::Patches),
    };
    let s = model.solve(lighting)?;
    let column = GroupColumns {
        e: s.e,
        b: s.b,
        h: s.h,
        flux: s.luminaire_flux,
        landed: s.luminaire_flux - s.direct_escaped,
    };
    let mut group = LightGroup::plain("state");
    group.luminaires = lit;
    let (groups, lights) = ([column], [group]);
    let state = final_gather::FinalScene {
        groups: &groups,
        lights: &lights,
        emitters,
        ..final_scene(model, shading, patches, None)
    };
    final_gather::build(&state, cam, settings, cancel)
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
