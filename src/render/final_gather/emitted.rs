//! What the camera sees emitted: emissive surfaces at their luminance `E/π`, the
//! luminaires' openings ([`super::openings`]), and under a sky the sky through openings.
//! Where an emitter's edge crosses a pixel, its coverage is measured on a fine grid of
//! primary rays, since a sliver of a bright emitter still shows.

use glam::DVec3;
use rayon::prelude::*;

use super::Tracer;
use crate::color::Rgb;

/// Primary rays per side of the grid that measures what a pixel sees of emitters where an
/// emitter's edge crosses it: some of its samples met an emitter and some did not, or none
/// did and a neighbour's did. The edge is antialiased to 1/1024 of the pixel, since a
/// sliver of a bright emitter still shows.
const EMITTER_GRID: usize = 32;

/// How a pixel's emitters were measured: none of its samples met one, some did (so its
/// coverage was measured on the fine grid), or all did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum Coverage {
    #[default]
    None,
    Measured,
    All,
}

impl Tracer<'_> {
    /// Adds what pixel (x, y) sees emitted, measured on an [`EMITTER_GRID`]² grid of
    /// primary rays (per group radiance, cd/m²).
    pub(super) fn emitted_in_pixel(&self, x: usize, y: usize, out: &mut [f32]) {
        let mut emitted = vec![0f32; out.len()];
        let n = EMITTER_GRID;
        for i in 0..n * n {
            let (sx, sy) = (
                ((i % n) as f64 + 0.5) / n as f64,
                ((i / n) as f64 + 0.5) / n as f64,
            );
            let d = self.rays.dir_at(x as f64 + sx, y as f64 + sy);
            self.emitted_along(d, self.primary(d), &mut emitted);
        }
        let m = (n * n) as f32;
        for (a, v) in out.iter_mut().zip(&emitted) {
            *a += v / m;
        }
    }

    /// The pixels whose samples all met an emitter or all missed, beside one whose samples
    /// did otherwise: an emitter's edge may cover a sliver of them that their few samples
    /// missed, or leave a sliver uncovered that they all missed, so their coverage is
    /// measured on the fine grid too ([`Self::emitted_in_pixel`]), replacing the samples'.
    pub(super) fn emitter_rims(
        &self,
        cov: &[Coverage],
        (w, h): (usize, usize),
        emitted: &mut [f32],
    ) {
        let differs = |x: usize, y: usize| {
            let c = cov[y * w + x];
            (y.saturating_sub(1)..=(y + 1).min(h - 1)).any(|yy| {
                (x.saturating_sub(1)..=(x + 1).min(w - 1)).any(|xx| cov[yy * w + xx] != c)
            })
        };
        let stride = 3 * self.groups;
        emitted
            .par_chunks_mut((stride * w).max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    if cov[y * w + x] != Coverage::Measured && differs(x, y) {
                        let px = &mut row[stride * x..stride * (x + 1)];
                        px.iter_mut().for_each(|v| *v = 0.0);
                        self.emitted_in_pixel(x, y, px);
                    }
                }
            });
    }

    /// Adds what the camera ray along `d` (meeting `hit`) sees emitted (per group radiance, cd/m²): an
    /// emissive surface's `E/π` or a luminaire's opening; whether it saw any.
    pub(super) fn emitted_along(&self, d: DVec3, hit: Option<(f32, u32)>, out: &mut [f32]) -> bool {
        let t_scene = hit.map_or(f64::INFINITY, |(t, _)| t as f64);
        if self.openings.seen(self.rays.origin(), d, t_scene, out) {
            return true;
        }
        let Some((_, p)) = hit else {
            if let Some(sky) = &self.scene.sky {
                let l = sky.outside(self.rays.origin(), d, true);
                Rgb::column_mut(out)[0] += Rgb::splat(l);
                return l > 0.0;
            }
            return false;
        };
        if self.scene.sky.is_some() {
            return false;
        }
        let mut any = false;
        for (o, col) in Rgb::column_mut(out).iter_mut().zip(self.scene.groups) {
            let e = Rgb::column(&col.e)[p as usize];
            *o += e * std::f32::consts::FRAC_1_PI;
            any |= e.iter().any(|&v| v > 0.0);
        }
        any
    }
}
