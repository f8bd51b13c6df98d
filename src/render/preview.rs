//! The preview mesh: a coarser shading mesh for clients that draw large scenes themselves.
//!
//! Software WebGL draws a few hundred thousand triangles at a handful of frames per second,
//! and what limits it is the triangle count, not the pixels. A scene with more than
//! [`PREVIEW_ABOVE`] patches therefore also has a preview: the same scene meshed again
//! with a longer edge, to about [`PREVIEW_TRIANGLES`] triangles, that a client draws while
//! the camera moves. Its vertex values blend the **fine** patches: each preview vertex
//! lies on a fine patch of the same surface and side, and takes the fine shading's
//! Gouraud value at that point (the barycentric blend of that patch's three shading
//! vertices). So it uses the same per-patch radiosity as the full mesh, and agrees with
//! it exactly at its own vertices.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::shading::{Shading, CREASE_DEG};
use crate::geometry::barycentric;
use crate::geometry::mesh::Mesh;
use crate::scene::Scene;

/// Scenes with more patches than this get a preview mesh.
pub const PREVIEW_ABOVE: usize = 60_000;
/// About this many triangles in a preview mesh.
pub const PREVIEW_TRIANGLES: usize = 30_000;

/// The preview mesh of `fine` (meshed from `scene`) with its shading, or None when the
/// scene is small enough to draw whole.
pub fn preview_mesh(scene: &Scene, fine: &Mesh) -> Option<(Mesh, Shading)> {
    let triangles = fine.elements.len();
    if triangles <= PREVIEW_ABOVE {
        return None;
    }
    let longest = (0..triangles)
        .map(|e| {
            let c = fine.element_corners(e);
            (c[1] - c[0])
                .length()
                .max((c[2] - c[1]).length())
                .max((c[0] - c[2]).length())
        })
        .fold(0.0, f64::max);
    // Patch count scales with 1 / edge²; bisection meshes overshoot, so aim a bit low.
    let mut edge = longest * (triangles as f64 / PREVIEW_TRIANGLES as f64).sqrt();
    let mut last = triangles;
    for _ in 0..8 {
        let coarse = Mesh::build_with(scene, edge);
        let count = coarse.elements.len();
        if count <= 2 * PREVIEW_TRIANGLES {
            let shading = Shading::new(&coarse);
            return Some((coarse, shading));
        }
        // A model's own small triangles stay whatever the edge (cluster patches keep
        // them): no coarser mesh to draw.
        if count as f64 > 0.9 * last as f64 {
            return None;
        }
        last = count;
        edge *= 1.4;
    }
    None
}

/// Per preview shading vertex: the fine patches it blends and their weights (sum 1).
pub fn preview_weights(
    fine: &Mesh,
    fine_shading: &Shading,
    coarse: &Mesh,
    coarse_shading: &Shading,
) -> Vec<Vec<(u32, f32)>> {
    let locate = Locator::new(fine);
    let cos_crease = CREASE_DEG.to_radians().cos();
    (0..coarse_shading.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|sv| {
            let (ce, corner) = coarse_shading.anchor(coarse, sv);
            let elem = coarse.elements[ce as usize];
            let p = coarse.vertices[elem.v[corner] as usize];
            let patch = &coarse.patches[elem.patch as usize];
            let normal = coarse.facet(ce as usize).normal;
            let Some((t, l)) = locate.find(fine, p, patch.surface, normal, cos_crease) else {
                return vec![];
            };
            let mut acc: Vec<(u32, f32)> = Vec::new();
            for (k, &lk) in l.iter().enumerate() {
                for (q, w) in fine_shading.blend(fine_shading.corner[t as usize][k]) {
                    let w = lk as f32 * w;
                    match acc.iter_mut().find(|(pq, _)| *pq == q) {
                        Some(e) => e.1 += w,
                        None => acc.push((q, w)),
                    }
                }
            }
            acc.retain(|&(_, w)| w > 0.0);
            acc
        })
        .collect()
}

/// Fine elements by surface and grid cell (each element in every cell its box touches).
struct Locator {
    cell: f64,
    cells: HashMap<(u32, [i64; 3]), Vec<u32>>,
}

impl Locator {
    fn new(fine: &Mesh) -> Locator {
        let mean_area =
            fine.patches.iter().map(|p| p.area).sum::<f64>() / fine.elements.len().max(1) as f64;
        let cell = (4.0 * mean_area).sqrt().max(1e-9);
        let at = |x: f64| (x / cell).floor() as i64;
        let mut cells: HashMap<(u32, [i64; 3]), Vec<u32>> = HashMap::new();
        for (i, e) in fine.elements.iter().enumerate() {
            let p = &fine.patches[e.patch as usize];
            let c = fine.element_corners(i);
            let lo = c[0].min(c[1]).min(c[2]);
            let hi = c[0].max(c[1]).max(c[2]);
            for x in at(lo.x)..=at(hi.x) {
                for y in at(lo.y)..=at(hi.y) {
                    for z in at(lo.z)..=at(hi.z) {
                        cells
                            .entry((p.surface, [x, y, z]))
                            .or_default()
                            .push(i as u32);
                    }
                }
            }
        }
        Locator { cell, cells }
    }

    /// The fine element of `surface`, facing within the crease angle of `n`, that contains
    /// `p` (or comes nearest to containing it), and p's barycentric coordinates in it.
    fn find(
        &self,
        fine: &Mesh,
        p: DVec3,
        surface: u32,
        n: DVec3,
        cos_crease: f64,
    ) -> Option<(u32, [f64; 3])> {
        let key = [p.x, p.y, p.z].map(|x| (x / self.cell).floor() as i64);
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        for &t in self.cells.get(&(surface, key))? {
            if fine.facet(t as usize).normal.dot(n) < cos_crease {
                continue;
            }
            let l = barycentric(&fine.element_corners(t as usize), p);
            let score = l[0].min(l[1]).min(l[2]);
            if best.is_none_or(|b| score > b.0) {
                best = Some((score, t, l));
            }
        }
        let (_, t, l) = best?;
        // Clamp to the triangle (a point just outside blends its nearest edge).
        let c = l.map(|x| x.max(0.0));
        let s = c[0] + c[1] + c[2];
        Some((
            t,
            if s > 0.0 {
                c.map(|x| x / s)
            } else {
                [1.0 / 3.0; 3]
            },
        ))
    }
}
