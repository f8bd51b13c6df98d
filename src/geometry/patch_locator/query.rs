//! Queries of a [`PatchLocator`]: the patch under a point of a triangle's side, in the
//! cells of its grid, and the nearest patch a ray meets, traced on the scene BVH.

use glam::{DVec3, Vec3A};

use super::{PatchLocator, Side};
use crate::geometry::bvh::Bvh;

/// A ray traced for the patch it meets ([`PatchLocator::nearest`]): `origin + t·dir`,
/// t > 0.
#[derive(Clone, Copy, Debug)]
pub struct PatchRay {
    pub origin: DVec3,
    pub dir: DVec3,
    /// The scene triangle the ray leaves, which it passes through.
    pub own: Option<u32>,
    /// Whether a side facing away from the ray is never met, even where its triangle has
    /// no facing side (a one-sided surface seen from behind is then passed through).
    pub cull_back: bool,
}

impl PatchRay {
    /// A ray leaving scene triangle `own`: it meets any other triangle's facing side, else
    /// its side facing away.
    pub fn leaving(own: u32, origin: DVec3, dir: DVec3) -> PatchRay {
        PatchRay {
            origin,
            dir,
            own: Some(own),
            cull_back: false,
        }
    }

    /// A camera ray: it meets facing sides only.
    pub fn camera(origin: DVec3, dir: DVec3) -> PatchRay {
        PatchRay {
            origin,
            dir,
            own: None,
            cull_back: true,
        }
    }

    /// The point at distance parameter `t`.
    pub fn at(&self, t: f32) -> DVec3 {
        self.origin + self.dir * t as f64
    }
}

/// A patch is taken as containing a point whose barycentric weights in it are all above
/// this (a seam between neighbours, or rounding, leaves a point just outside both).
const INSIDE: f32 = -1e-4;

impl PatchLocator {
    /// The patch of triangle `tri` on side `back` under the point `x` (on or next to the
    /// triangle's plane): the patch containing it, or when rounding leaves it in none,
    /// the one it lies least outside of. None when that side has no patches.
    pub fn locate(&self, tri: u32, back: bool, x: DVec3) -> Option<u32> {
        self.locate_weighted(tri, back, x)
            .map(|(j, _)| self.patch_of[j as usize])
    }

    /// The patch of element `e` (the ids [`Self::locate_weighted`],
    /// [`Self::locate_beside`] and [`Self::nearest_weighted`] give).
    pub fn patch_of(&self, e: u32) -> u32 {
        self.patch_of[e as usize]
    }

    /// As [`Self::locate`], naming the element (the patch's triangle) under the point,
    /// with the point's barycentric weights on its corners (clamped to it, summing to 1).
    pub fn locate_weighted(&self, tri: u32, back: bool, x: DVec3) -> Option<(u32, [f32; 3])> {
        let f = self.frames.get(tri as usize)?;
        let (u, v) = f.coords(x);
        self.locate_uv(f.sides[usize::from(back)], u as f32, v as f32)
    }

    /// As [`Self::locate_weighted`], for a point that may lie well beside the triangle
    /// (a grid corner): the patch under the triangle's point nearest to it, with that
    /// point's weights, so a field read there is the one at the triangle's edge and the
    /// cell searched is never an empty one far from the patches.
    pub fn locate_beside(&self, tri: u32, back: bool, x: DVec3) -> Option<(u32, [f32; 3])> {
        let f = self.frames.get(tri as usize)?;
        let (u, v) = f.coords(x);
        let (u, v) = f.nearest_in_triangle(u, v);
        self.locate_uv(f.sides[usize::from(back)], u as f32, v as f32)
    }

    /// The patch of `side` under the plane point (u, v), with its clamped weights there.
    fn locate_uv(&self, side: Side, u: f32, v: f32) -> Option<(u32, [f32; 3])> {
        if side.cells[0] == 0 {
            return None;
        }
        let cell = side.cell(u, v);
        let run = self.cell_start[cell] as usize..self.cell_start[cell + 1] as usize;
        let best = self.best_of(&self.entries[run], u, v).or_else(|| {
            // An empty cell (a point beside the triangle, past rounding): every patch of
            // the side.
            let all = side.first_cell as usize
                ..side.first_cell as usize + (side.cells[0] * side.cells[1]) as usize;
            let run = self.cell_start[all.start] as usize..self.cell_start[all.end] as usize;
            self.best_of(&self.entries[run], u, v)
        })?;
        let w = best.1.map(|w| w.max(0.0));
        let sum = w[0] + w[1] + w[2];
        Some(if sum > 0.0 {
            (best.0, w.map(|w| w / sum))
        } else {
            (best.0, [1.0 / 3.0; 3])
        })
    }

    /// Of `ids`, the first patch containing (u, v), else the one it lies least outside
    /// of (by its least barycentric weight), with the point's weights in it.
    fn best_of(&self, ids: &[u32], u: f32, v: f32) -> Option<(u32, [f32; 3])> {
        let mut best: Option<(u32, [f32; 3], f32)> = None;
        for &j in ids {
            let w = weights(&self.uv[j as usize], u, v);
            let m = w[0].min(w[1]).min(w[2]);
            if m >= INSIDE {
                return Some((j, w));
            }
            if best.is_none_or(|(_, _, b)| m > b) {
                best = Some((j, w, m));
            }
        }
        best.map(|(j, w, _)| (j, w))
    }

    /// The nearest patch `ray` meets, with its distance parameter, traced on `bvh` (the
    /// scene BVH: ids are scene triangles). Of the two sides of a triangle the one facing
    /// the ray is met; the side facing away is met where the triangle has no facing side
    /// (a one-sided surface seen from behind), unless [`PatchRay::cull_back`]. At equal
    /// distances a facing side wins over a side facing away.
    pub fn nearest(&self, bvh: &Bvh, ray: PatchRay) -> Option<(f32, u32)> {
        self.nearest_weighted(bvh, ray)
            .map(|(t, j, _)| (t, self.patch_of[j as usize]))
    }

    /// As [`Self::nearest`], naming the element met, with the hit's barycentric weights
    /// on its corners ([`Self::locate_weighted`]).
    pub fn nearest_weighted(&self, bvh: &Bvh, ray: PatchRay) -> Option<(f32, u32, [f32; 3])> {
        let (t, s, back) = self.nearest_side(bvh, ray)?;
        self.locate_weighted(s, back, ray.at(t))
            .map(|(j, w)| (t, j, w))
    }

    /// As [`Self::nearest`], naming the side met instead of its patch: (distance
    /// parameter, scene triangle, back side).
    pub fn nearest_side(&self, bvh: &Bvh, ray: PatchRay) -> Option<(f32, u32, bool)> {
        let PatchRay {
            origin: o,
            dir: d,
            own,
            cull_back,
        } = ray;
        let d32 = Vec3A::from(d.as_vec3());
        let rank = |s: u32| -> u8 {
            if Some(s) == own {
                return 0;
            }
            let Some(f) = self.frames.get(s as usize) else {
                return 0;
            };
            let back = f.normal.dot(d32) >= 0.0;
            if f.sides[usize::from(back)].cells[0] > 0 {
                2
            } else if !cull_back && f.sides[usize::from(!back)].cells[0] > 0 {
                1
            } else {
                0
            }
        };
        let (t, s) = bvh.nearest_ranked(Vec3A::from(o.as_vec3()), d32, 0.0, f32::INFINITY, rank)?;
        let f = &self.frames[s as usize];
        let facing_back = f.normal.dot(d32) >= 0.0;
        let back = if f.sides[usize::from(facing_back)].cells[0] > 0 {
            facing_back
        } else {
            !facing_back
        };
        Some((t, s, back))
    }
}

/// The barycentric weights of the point (u, v) on the corners of the 2D triangle `c`
/// (`[u0, v0, u1, v1, u2, v2]`, either winding): all ≥ 0 inside; −∞ for a degenerate
/// triangle.
#[inline]
fn weights(c: &[f32; 6], u: f32, v: f32) -> [f32; 3] {
    let edge = |a: usize, b: usize| {
        (c[2 * b] - c[2 * a]) * (v - c[2 * a + 1]) - (c[2 * b + 1] - c[2 * a + 1]) * (u - c[2 * a])
    };
    let (w0, w1, w2) = (edge(1, 2), edge(2, 0), edge(0, 1));
    let area = w0 + w1 + w2;
    if area == 0.0 {
        return [f32::NEG_INFINITY; 3];
    }
    [w0 / area, w1 / area, w2 / area]
}
