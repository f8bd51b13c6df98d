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
use crate::geometry::mesh::Mesh;

/// The sun seen by a view: unit scene direction and normal illuminance (lux).
#[derive(Debug, Clone, Copy)]
pub struct SunView {
    pub direction: DVec3,
    pub normal_illuminance: f64,
}

/// Per pixel (row 0 at the top): the traced daylight's radiance (cd/m², for shaded
/// images) and illuminance (lux, for false colour). `sky(d)` is the luminance (cd/m²)
/// towards unit scene direction `d`, the ground's below the horizon; `rho` the patches'
/// reflectances; `reach` a length beyond the scene.
#[allow(clippy::too_many_arguments)]
pub fn daylight_pixels(
    mesh: &Mesh,
    (bvh, glazing): (&Bvh, &Glazing),
    rho: &[Rgb],
    view: &ViewBuffer,
    cam: &Camera,
    sun: Option<SunView>,
    sky: &(dyn Fn(DVec3) -> f64 + Sync),
    reach: f64,
) -> (Vec<Rgb>, Vec<Rgb>) {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let pos = cam.position.as_dvec3();
    let fwd = (cam.target - cam.position).normalize().as_dvec3();
    let right = fwd.cross(cam.up.as_dvec3()).normalize();
    let up = right.cross(fwd);
    let tan = (cam.fov_deg as f64).to_radians() * 0.5;
    let tan = tan.tan();
    let aspect = w as f64 / h as f64;
    let sun_radius_cos = (crate::daylight::sky_luminance::SUN_DIAMETER_DEG / 2.0)
        .to_radians()
        .cos();
    let disc = crate::daylight::sky_luminance::Sun::solid_angle();
    let rows: Vec<(Vec<Rgb>, Vec<Rgb>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut rad = Vec::with_capacity(w);
            let mut lux = Vec::with_capacity(w);
            for x in 0..w {
                let sx = ((x as f64 + 0.5) / w as f64) * 2.0 - 1.0;
                let sy = 1.0 - ((y as f64 + 0.5) / h as f64) * 2.0;
                let d = (fwd + right * (sx * tan * aspect) + up * (sy * tan)).normalize();
                let p = view.center_patch[y * w + x];
                if p == u32::MAX {
                    let mut l = sky(d);
                    if let Some(s) = sun {
                        if d.dot(s.direction) >= sun_radius_cos {
                            l += s.normal_illuminance / disc;
                        }
                    }
                    // Seen through glazing, dimmed by it.
                    l *= glazing.transmittance(pos, pos + d * reach);
                    rad.push([l as f32; 3]);
                    lux.push([0.0; 3]);
                    continue;
                }
                let Some(s) = sun else {
                    rad.push([0.0; 3]);
                    lux.push([0.0; 3]);
                    continue;
                };
                let patch = &mesh.patches[p as usize];
                let n = patch.normal;
                let cos = n.dot(s.direction);
                let denom = n.dot(d);
                if cos <= 0.0 || denom.abs() < 1e-12 {
                    rad.push([0.0; 3]);
                    lux.push([0.0; 3]);
                    continue;
                }
                let t = n.dot(patch.centroid - pos) / denom;
                let hit = pos + d * t;
                let o = hit + n * (1e-6 * (1.0 + hit.abs().max_element()));
                let far = o + s.direction * reach;
                let free = !bvh.occluded(
                    Vec3A::from(o.as_vec3()),
                    Vec3A::from(far.as_vec3()),
                    [patch.source, u32::MAX],
                );
                if !free {
                    rad.push([0.0; 3]);
                    lux.push([0.0; 3]);
                    continue;
                }
                let e = (s.normal_illuminance * cos * glazing.transmittance(o, far)) as f32;
                let r = rho[p as usize];
                let k = std::f32::consts::FRAC_1_PI * e;
                rad.push([r[0] * k, r[1] * k, r[2] * k]);
                lux.push([e; 3]);
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
