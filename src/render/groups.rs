//! Linear images of one view per light group, summed with per-group weights.

use rayon::prelude::*;

use super::raster::ViewBuffer;
use super::shading::Shading;
use super::tonemap::{tonemap_pixels, ToneMap};
use crate::color::Rgb;

/// Linear images of one view, one per light group at unit weight (radiance,
/// lm/(m²·sr)), stored pixel-major. The image for group weights `w` is `Σ_g w_g ⊙ I_g`:
/// with few groups that streams far less memory than a gather over the view buffer.
pub struct GroupImages {
    width: u32,
    height: u32,
    groups: usize,
    /// `[pixel][group][rgb]`.
    data: Vec<f32>,
}

impl GroupImages {
    /// Whether per-group images are smaller than the view buffer they replace.
    pub fn worthwhile(view: &ViewBuffer, groups: usize) -> bool {
        groups > 0 && groups * 12 * view.pixels() <= view.bytes()
    }

    /// Radiance images (B/π) of every light group of `transfer` at unit weight.
    pub fn radiance(
        view: &ViewBuffer,
        shading: &Shading,
        transfer: &crate::transport::transfer::Transfer,
    ) -> GroupImages {
        let values: Vec<Vec<Rgb>> = transfer
            .groups
            .iter()
            .map(|g| shading.vertex_values(&g.b))
            .collect();
        GroupImages::build(view, &values, std::f32::consts::FRAC_1_PI)
    }

    /// Gathers one image per group from per-group shading-vertex values, times `scale`.
    pub(super) fn build(view: &ViewBuffer, vertex_values: &[Vec<Rgb>], scale: f32) -> GroupImages {
        let g = vertex_values.len();
        let images: Vec<Vec<Rgb>> = vertex_values
            .iter()
            .map(|v| view.gather(v, scale))
            .collect();
        let mut data = vec![0f32; 3 * g * view.pixels()];
        data.par_chunks_mut(3 * g).enumerate().for_each(|(i, px)| {
            for (p, img) in Rgb::column_mut(px).iter_mut().zip(&images) {
                *p = img[i];
            }
        });
        GroupImages {
            width: view.width,
            height: view.height,
            groups: g,
            data,
        }
    }

    /// Images from their interleaved data, `[pixel][group][rgb]`.
    pub(super) fn from_parts(
        width: u32,
        height: u32,
        groups: usize,
        data: Vec<f32>,
    ) -> GroupImages {
        debug_assert_eq!(data.len(), 3 * groups * width as usize * height as usize);
        GroupImages {
            width,
            height,
            groups,
            data,
        }
    }

    #[inline]
    fn pixel(&self, i: usize, weights: &[Rgb]) -> Rgb {
        let px = Rgb::column(&self.data[3 * self.groups * i..3 * self.groups * (i + 1)]);
        let mut acc = Rgb::ZERO;
        for (&v, &w) in px.iter().zip(weights) {
            acc += w * v;
        }
        acc
    }

    /// Linear image (row 0 at the top) for per-group RGB weights.
    pub fn linear(&self, weights: &[Rgb]) -> Vec<Rgb> {
        let n = self.width as usize * self.height as usize;
        (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| self.pixel(i, weights))
            .collect()
    }

    /// 8-bit sRGB image for per-group RGB weights, as [`ViewBuffer::gather_tonemapped`].
    pub fn tonemapped(
        &self,
        weights: &[Rgb],
        exposure: Option<f32>,
        tm: ToneMap,
    ) -> (Vec<u8>, f32) {
        let n = self.width as usize * self.height as usize;
        tonemap_pixels(n, |i| self.pixel(i, weights), exposure, tm)
    }

    /// Memory held, bytes (allocated capacity).
    pub fn bytes(&self) -> usize {
        4 * self.data.capacity()
    }

    /// Peak bytes [`GroupImages::build`] allocates for `groups` groups on `view`: one
    /// linear image per group, then the interleaved copy.
    pub fn estimate_bytes(view: &ViewBuffer, groups: usize) -> u64 {
        2 * 12 * groups as u64 * view.pixels() as u64
    }
}
