//! Denoising the gathered light with weights that depend on geometry only.
//!
//! An edge-avoiding à-trous wavelet filter (Dammertz et al. 2010): passes of a 5×5 B3
//! spline kernel with holes (steps 1, 2, 4, …), each tap weighted by how alike the two
//! pixels' geometry is: the angle between their normals, the distance of the tap's point
//! from the centre pixel's tangent plane (in pixel footprints), and whether both lie on
//! the same surface. No weight looks at the light itself, so the filter is one fixed
//! linear map for the whole view: it commutes with relighting, and every group image can
//! be filtered alone. It runs on irradiance (radiance divided by the pixel's reflectance),
//! so texture and colour edges stay sharp, and multiplies the reflectance back after.

use rayon::prelude::*;

use crate::color::Rgb;

/// What the filter knows of a pixel: the first camera sample's point, normal, surface
/// and distance. `depth == 0` marks a pixel that saw no surface.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Guide {
    pub(super) position: [f32; 3],
    pub(super) normal: [f32; 3],
    pub(super) surface: u32,
    pub(super) depth: f32,
}

/// Normal weight exponent: `max(0, n·n')^NORMAL_POWER`.
const NORMAL_POWER: i32 = 64;
/// Plane distance, in pixel footprints at the centre's depth × the pass step, that
/// halves a tap's weight (roughly).
const PLANE_FOOTPRINTS: f32 = 1.0;

/// The B3 spline kernel's taps.
const KERNEL: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// Filters `indirect` (`[pixel][group][rgb]` radiance, (w, h, groups)) in place with
/// `passes` passes; `footprint` is a pixel's size per metre of depth.
pub(super) fn denoise(
    indirect: &mut [f32],
    albedo: &[Rgb],
    guides: &[Guide],
    (w, h, g): (usize, usize, usize),
    footprint: f32,
    passes: u32,
) {
    if passes == 0 || g == 0 {
        return;
    }
    let stride = 3 * g;
    // Radiance → irradiance-like values: divide by the reflectance.
    let inv = |a: f32| {
        if a > 1e-6 {
            std::f32::consts::PI / a
        } else {
            0.0
        }
    };
    indirect
        .par_chunks_mut(stride)
        .zip(albedo)
        .for_each(|(px, a)| {
            for k in 0..g {
                for c in 0..3 {
                    px[3 * k + c] *= inv(a[c]);
                }
            }
        });
    let mut next = vec![0f32; indirect.len()];
    for pass in 0..passes {
        let step = 1usize << pass;
        let src: &[f32] = indirect;
        next.par_chunks_mut(stride * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let out = &mut row[stride * x..stride * (x + 1)];
                    tap_sum(src, guides, (x, y), (w, h, stride), step, footprint, out);
                }
            });
        indirect.copy_from_slice(&next);
    }
    indirect
        .par_chunks_mut(stride)
        .zip(albedo)
        .for_each(|(px, a)| {
            for k in 0..g {
                for c in 0..3 {
                    px[3 * k + c] *= a[c] * std::f32::consts::FRAC_1_PI;
                }
            }
        });
}

/// One output pixel of one pass: the weighted mean of its 25 taps.
fn tap_sum(
    src: &[f32],
    guides: &[Guide],
    (x, y): (usize, usize),
    (w, h, stride): (usize, usize, usize),
    step: usize,
    footprint: f32,
    out: &mut [f32],
) {
    let i = y * w + x;
    let c = &guides[i];
    if c.depth <= 0.0 {
        out.copy_from_slice(&src[stride * i..stride * (i + 1)]);
        return;
    }
    out.iter_mut().for_each(|v| *v = 0.0);
    let scale = 1.0 / (PLANE_FOOTPRINTS * footprint * c.depth * step as f32).max(1e-9);
    let mut total = 0.0;
    for (ky, wy) in KERNEL.iter().enumerate() {
        let yy = y as isize + (ky as isize - 2) * step as isize;
        if yy < 0 || yy >= h as isize {
            continue;
        }
        for (kx, wx) in KERNEL.iter().enumerate() {
            let xx = x as isize + (kx as isize - 2) * step as isize;
            if xx < 0 || xx >= w as isize {
                continue;
            }
            let j = yy as usize * w + xx as usize;
            let q = &guides[j];
            if q.depth <= 0.0 || q.surface != c.surface {
                continue;
            }
            let dot: f32 = (0..3).map(|k| c.normal[k] * q.normal[k]).sum();
            if dot <= 0.0 {
                continue;
            }
            let plane: f32 = (0..3)
                .map(|k| c.normal[k] * (q.position[k] - c.position[k]))
                .sum();
            let wp = (-(plane.abs() * scale)).exp();
            let wt = wx * wy * dot.powi(NORMAL_POWER) * wp;
            if wt <= 0.0 {
                continue;
            }
            total += wt;
            for (o, v) in out.iter_mut().zip(&src[stride * j..stride * (j + 1)]) {
                *o += wt * v;
            }
        }
    }
    if total > 0.0 {
        out.iter_mut().for_each(|v| *v /= total);
    }
}
