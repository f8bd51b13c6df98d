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
    /// The harmonic mean distance of the first sample's gather hits, metres: the scale
    /// over which its indirect light changes (small in corners and at contacts).
    pub(super) reach: f32,
}

impl Guide {
    /// Whether two samples saw the same surface, facing alike, at about the same depth:
    /// both missed, or both hit one surface with normals within about 8° and depths
    /// within 5 %.
    pub(super) fn alike(&self, o: &Guide) -> bool {
        if self.depth <= 0.0 || o.depth <= 0.0 {
            return (self.depth <= 0.0) == (o.depth <= 0.0);
        }
        let dot: f32 = (0..3).map(|k| self.normal[k] * o.normal[k]).sum();
        self.surface == o.surface
            && dot > 0.99
            && (self.depth - o.depth).abs() <= 0.05 * self.depth.max(o.depth)
    }
}

/// The layout of the images the filter runs on: `[pixel][group][rgb]`, row by row.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    pub(super) width: usize,
    pub(super) height: usize,
    /// Light groups per pixel.
    pub(super) groups: usize,
}

impl Layout {
    /// Values per pixel.
    fn stride(&self) -> usize {
        3 * self.groups
    }
}

/// One tap of an output pixel's kernel.
#[derive(Debug, Clone, Copy, Default)]
struct Tap {
    /// Its pixel's index.
    pixel: usize,
    weight: f32,
    /// Its offset from the centre, in steps, along x and y.
    u: f32,
    v: f32,
}

/// Normal weight exponent: `max(0, n·n')^NORMAL_POWER`.
const NORMAL_POWER: i32 = 64;
/// Plane distance, in pixel footprints at the centre's depth × the pass step, that
/// halves a tap's weight (roughly).
const PLANE_FOOTPRINTS: f32 = 1.0;

/// The B3 spline kernel's taps.
const KERNEL: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// Filters `indirect` (radiance laid out as `layout` says) in place with `passes`
/// passes; `footprint` is a pixel's size per metre of depth.
pub(super) fn denoise(
    indirect: &mut [f32],
    albedo: &[Rgb],
    guides: &[Guide],
    layout: Layout,
    footprint: f32,
    passes: u32,
) {
    let (w, g) = (layout.width, layout.groups);
    if passes == 0 || g == 0 {
        return;
    }
    let stride = layout.stride();
    // Radiance → irradiance-like values: divide by the reflectance.
    let inv = |a: f32| {
        if a > 1e-6 {
            std::f32::consts::PI / a
        } else {
            0.0
        }
    };
    scale_by(indirect, albedo, g, inv);
    let mut next = vec![0f32; indirect.len()];
    for pass in 0..passes {
        let step = 1usize << pass;
        let src: &[f32] = indirect;
        next.par_chunks_mut(stride * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let out = &mut row[stride * x..stride * (x + 1)];
                    tap_sum(src, guides, (x, y), layout, step, footprint, out);
                }
            });
        indirect.copy_from_slice(&next);
    }
    scale_by(indirect, albedo, g, |a| a * std::f32::consts::FRAC_1_PI);
}

/// Multiplies every group's RGB of each pixel by `f` of the pixel's reflectance.
fn scale_by(values: &mut [f32], albedo: &[Rgb], g: usize, f: impl Fn(f32) -> f32 + Sync) {
    values
        .par_chunks_mut(3 * g)
        .zip(albedo)
        .for_each(|(px, a)| {
            let m = a.map(&f);
            for rgb in Rgb::column_mut(px) {
                *rgb *= m;
            }
        });
}

/// One output pixel of one pass: the value at the centre of a plane fitted by weighted
/// least squares to its 25 taps (in image coordinates). A plain weighted mean would be
/// biased wherever the light has a gradient and the taps lie on one side: along every
/// edge between surfaces, where only the taps of the centre's surface count. The fit is
/// exact for linear gradients, and its effective weights depend on the guides alone, so
/// the filter stays one linear map.
fn tap_sum(
    src: &[f32],
    guides: &[Guide],
    (x, y): (usize, usize),
    layout: Layout,
    step: usize,
    footprint: f32,
    out: &mut [f32],
) {
    let (w, h, stride) = (layout.width, layout.height, layout.stride());
    let i = y * w + x;
    let c = &guides[i];
    if c.depth <= 0.0 {
        out.copy_from_slice(&src[stride * i..stride * (i + 1)]);
        return;
    }
    let scale = 1.0 / (PLANE_FOOTPRINTS * footprint * c.depth * step as f32).max(1e-9);
    let mut taps = [Tap::default(); 25];
    let mut n = 0;
    for (ky, wy) in KERNEL.iter().enumerate() {
        let Some(yy) = mirror(y as isize + (ky as isize - 2) * step as isize, h) else {
            continue;
        };
        for (kx, wx) in KERNEL.iter().enumerate() {
            let Some(xx) = mirror(x as isize + (kx as isize - 2) * step as isize, w) else {
                continue;
            };
            let j = yy * w + xx;
            let wt = wx * wy * likeness(c, &guides[j], scale);
            if wt > 0.0 {
                taps[n] = Tap {
                    pixel: j,
                    weight: wt,
                    u: kx as f32 - 2.0,
                    v: ky as f32 - 2.0,
                };
                n += 1;
            }
        }
    }
    let taps = &mut taps[..n];
    fit_weights(taps);
    out.iter_mut().for_each(|v| *v = 0.0);
    for t in taps.iter() {
        let j = t.pixel;
        for (o, v) in out.iter_mut().zip(&src[stride * j..stride * (j + 1)]) {
            *o += t.weight * v;
        }
    }
}

/// A tap's row or column `i` in an image `n` pixels across, mirrored at the image's border:
/// the taps stay symmetric about the centre there (at their nominal offsets), so the
/// fitted plane is not extrapolated from taps on one side, which amplified the noise in
/// the outermost pixels. None beyond a mirror's reach.
fn mirror(i: isize, n: usize) -> Option<usize> {
    let n = n as isize;
    let m = if i < 0 {
        -i
    } else if i >= n {
        2 * (n - 1) - i
    } else {
        i
    };
    (0..n).contains(&m).then_some(m as usize)
}

/// How alike tap `q`'s geometry is to the centre `c`'s, 0..1: the same surface, normals
/// alike, `q` near `c`'s tangent plane (`scale`: 1 / the plane distance that weighs about
/// e⁻¹) and within about the centre's reach.
fn likeness(c: &Guide, q: &Guide, scale: f32) -> f32 {
    if q.depth <= 0.0 || q.surface != c.surface {
        return 0.0;
    }
    let dot: f32 = (0..3).map(|k| c.normal[k] * q.normal[k]).sum();
    if dot <= 0.0 {
        return 0.0;
    }
    let plane: f32 = (0..3)
        .map(|k| c.normal[k] * (q.position[k] - c.position[k]))
        .sum();
    let a = plane.abs() * scale;
    // Taps farther than about the centre's reach see different surroundings: in a corner
    // the light changes over centimetres, in the open over metres.
    let d2: f32 = (0..3)
        .map(|k| (q.position[k] - c.position[k]).powi(2))
        .sum();
    let r = d2.sqrt() / (REACH_SCALE * c.reach);
    dot.powi(NORMAL_POWER) * falloff(a) * falloff(r)
}

/// The share of a tap's weight kept at a distance of one reach, as a multiple of the reach.
const REACH_SCALE: f32 = 1.0;

/// A smooth falloff from 1 at 0 to about e⁻ˣ (`1 / (1 + x + x²/2 + x³/6)`): glibc's `expf`
/// is slower here than the whole rest of a tap.
fn falloff(x: f32) -> f32 {
    1.0 / (1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0))))
}

/// Replaces the taps' weights `w` (with offsets `(u, v)`) by the effective weights of a
/// weighted least-squares plane evaluated at the centre: `w · (1, u, v) M⁻¹ e₀`, with
/// `M = Σ w (1, u, v)ᵀ (1, u, v)`. They sum to 1 and reproduce linear data exactly. Where
/// the taps do not span a plane (a line of taps, one tap), the fit falls back along the
/// missing direction to the weighted mean.
fn fit_weights(taps: &mut [Tap]) {
    let (mut s, mut su, mut sv, mut suu, mut suv, mut svv) = (0f64, 0f64, 0f64, 0f64, 0f64, 0f64);
    for t in taps.iter() {
        let (w, u, v) = (t.weight as f64, t.u as f64, t.v as f64);
        s += w;
        su += w * u;
        sv += w * v;
        suu += w * u * u;
        suv += w * u * v;
        svv += w * v * v;
    }
    if s <= 0.0 {
        return;
    }
    // Centred moments: the plane's slopes from the covariance of the offsets.
    let (mu, mv) = (su / s, sv / s);
    let (cuu, cuv, cvv) = (suu / s - mu * mu, suv / s - mu * mv, svv / s - mv * mv);
    let det = cuu * cvv - cuv * cuv;
    let tiny = 1e-6;
    // Value at the centre = mean − slope · (mean offset); slope = C⁻¹ cov(offset, value).
    // Effective weight of tap k: w_k / s · (1 − (d_k − m)ᵀ C⁻¹ m), with d_k its offset.
    let (iuu, iuv, ivv) = if det > tiny * (cuu + cvv).max(tiny) {
        (cvv / det, -cuv / det, cuu / det)
    } else if cuu > tiny {
        (1.0 / cuu, 0.0, 0.0)
    } else if cvv > tiny {
        (0.0, 0.0, 1.0 / cvv)
    } else {
        (0.0, 0.0, 0.0)
    };
    let (gu, gv) = (iuu * mu + iuv * mv, iuv * mu + ivv * mv);
    for t in taps.iter_mut() {
        let (du, dv) = (t.u as f64 - mu, t.v as f64 - mv);
        t.weight = (t.weight as f64 / s * (1.0 - (du * gu + dv * gv))) as f32;
    }
}
