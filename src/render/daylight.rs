//! Daylight per pixel: what a view adds to its patch shading under a sky.
//!
//! Patches carry the sky's light and every interreflection (smooth at patch scale); the
//! sun's direct light is traced here per pixel instead, so the edge of a sun patch is as
//! sharp as the image. Through each pixel's centre, the patch the view buffer saw there is
//! intersected exactly and one shadow ray goes to the sun. Pixels that see no patch look
//! out of the scene: they show the sky's luminance (the ground's below the horizon) and
//! the sun's disc.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::{Camera, ViewBuffer};
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::glazing::Glazing;
use crate::geometry::lifted;
use crate::geometry::mesh::Mesh;

/// The sun seen by a view: unit scene direction and normal illuminance (lux).
#[derive(Debug, Clone, Copy)]
pub struct SunView {
    pub direction: DVec3,
    pub normal_illuminance: f64,
}

/// What the daylight tracer reads of a scene: its patches, their BVH, the glazing, the
/// patches' reflectances, and `reach`, a length beyond the scene (metres).
pub struct DaylightScene<'a> {
    pub mesh: &'a Mesh,
    pub bvh: &'a Bvh,
    pub glazing: &'a Glazing,
    pub rho: &'a [Rgb],
    pub reach: f64,
}

/// Per pixel (row 0 at the top): the traced daylight's radiance (cd/m², for shaded
/// images) and illuminance (lux, for false colour). `sky(d)` is the luminance (cd/m²)
/// towards unit scene direction `d`, the ground's below the horizon.
pub fn daylight_pixels(
    scene: &DaylightScene<'_>,
    view: &ViewBuffer,
    cam: &Camera,
    sun: Option<SunView>,
    sky: &(dyn Fn(DVec3) -> f64 + Sync),
) -> (Vec<Rgb>, Vec<Rgb>) {
    let DaylightScene {
        mesh,
        bvh,
        glazing,
        rho,
        reach,
    } = *scene;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let tracer = PixelTracer {
        mesh,
        bvh,
        glazing,
        rho,
        sun,
        sky,
        reach,
        rays: CameraRays::new(cam),
        sun_radius_cos: (crate::daylight::sky_luminance::SUN_DIAMETER_DEG / 2.0)
            .to_radians()
            .cos(),
        disc: crate::daylight::sky_luminance::Sun::solid_angle(),
    };
    let rows: Vec<(Vec<Rgb>, Vec<Rgb>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut rad = Vec::with_capacity(w);
            let mut lux = Vec::with_capacity(w);
            for x in 0..w {
                let (r, l) = tracer.pixel(x, y, view.center_patch[y * w + x]);
                rad.push(r);
                lux.push(l);
            }
            (rad, lux)
        })
        .collect();
    let mut rad = Vec::with_capacity(w * h);
    let mut lux = Vec::with_capacity(w * h);
    for (r, l) in rows {
        rad.extend(r);
        lux.extend(l);
    }
    (rad, lux)
}

/// The rays of a camera through points of its image.
pub(super) struct CameraRays {
    pos: DVec3,
    fwd: DVec3,
    right: DVec3,
    up: DVec3,
    /// tan(fov / 2).
    tan: f64,
    aspect: f64,
    w: usize,
    h: usize,
}

impl CameraRays {
    pub(super) fn new(cam: &Camera) -> CameraRays {
        let (w, h) = (cam.width as usize, cam.height as usize);
        let fwd = (cam.target - cam.position).normalize().as_dvec3();
        let right = fwd.cross(cam.up.as_dvec3()).normalize();
        let tan = (cam.fov_deg as f64).to_radians() * 0.5;
        CameraRays {
            pos: cam.position.as_dvec3(),
            fwd,
            right,
            up: right.cross(fwd),
            tan: tan.tan(),
            aspect: w as f64 / h as f64,
            w,
            h,
        }
    }

    /// Unit direction through the centre of pixel (x, y).
    #[inline]
    fn dir(&self, x: usize, y: usize) -> DVec3 {
        self.dir_at(x as f64 + 0.5, y as f64 + 0.5)
    }

    /// Unit direction through image point (x, y), in pixels from the top left corner.
    #[inline]
    pub(super) fn dir_at(&self, x: f64, y: f64) -> DVec3 {
        let sx = (x / self.w as f64) * 2.0 - 1.0;
        let sy = 1.0 - (y / self.h as f64) * 2.0;
        (self.fwd + self.right * (sx * self.tan * self.aspect) + self.up * (sy * self.tan))
            .normalize()
    }

    /// The camera's position.
    pub(super) fn origin(&self) -> DVec3 {
        self.pos
    }

    /// Image width, pixels.
    pub(super) fn width(&self) -> usize {
        self.w
    }
}

/// What [`daylight_pixels`] traces against.
struct PixelTracer<'a> {
    mesh: &'a Mesh,
    bvh: &'a Bvh,
    glazing: &'a Glazing,
    rho: &'a [Rgb],
    sun: Option<SunView>,
    sky: &'a (dyn Fn(DVec3) -> f64 + Sync),
    reach: f64,
    rays: CameraRays,
    /// Cosine of the sun's angular radius.
    sun_radius_cos: f64,
    /// The sun disc's solid angle, sr.
    disc: f64,
}

impl PixelTracer<'_> {
    /// Radiance and illuminance of pixel (x, y), which sees patch `p` (`u32::MAX`: none).
    #[inline]
    fn pixel(&self, x: usize, y: usize, p: u32) -> (Rgb, Rgb) {
        let d = self.rays.dir(x, y);
        if p == u32::MAX {
            return (Rgb::splat(self.outside(d) as f32), Rgb::ZERO);
        }
        let Some(s) = self.sun else {
            return (Rgb::ZERO, Rgb::ZERO);
        };
        match self.sunlight(p, d, s) {
            Some(e) => {
                let r = self.rho[p as usize];
                let k = std::f32::consts::FRAC_1_PI * e;
                (r * k, Rgb::splat(e))
            }
            None => (Rgb::ZERO, Rgb::ZERO),
        }
    }

    /// The luminance seen out of the scene along `d`: the sky's (the ground's below the
    /// horizon) and the sun's disc, dimmed by the glazing on the way.
    #[inline]
    fn outside(&self, d: DVec3) -> f64 {
        let mut l = (self.sky)(d);
        if let Some(s) = self.sun {
            if d.dot(s.direction) >= self.sun_radius_cos {
                l += s.normal_illuminance / self.disc;
            }
        }
        // Seen through glazing, dimmed by it.
        let pos = self.rays.pos;
        l * self.glazing.transmittance(pos, pos + d * self.reach)
    }

    /// The sun's illuminance (lux) where the ray along `d` meets patch `p`; None where the
    /// patch faces away or the sun is blocked.
    #[inline]
    fn sunlight(&self, p: u32, d: DVec3, s: SunView) -> Option<f32> {
        let pos = self.rays.pos;
        let patch = &self.mesh.patches[p as usize];
        let n = patch.normal;
        let cos = n.dot(s.direction);
        let denom = n.dot(d);
        if cos <= 0.0 || denom.abs() < 1e-12 {
            return None;
        }
        let t = n.dot(patch.centroid - pos) / denom;
        let hit = pos + d * t;
        let o = lifted(hit, n);
        let far = o + s.direction * self.reach;
        let free = !self.bvh.occluded(
            Vec3A::from(o.as_vec3()),
            Vec3A::from(far.as_vec3()),
            [patch.source, u32::MAX],
        );
        free.then(|| (s.normal_illuminance * cos * self.glazing.transmittance(o, far)) as f32)
    }
}
