//! Geometry: which patch a ray meets, found on the scene triangles.
//!
//! A ray is traced on the scene BVH (a few thousand input triangles, which stay in cache)
//! rather than on a BVH over the patches (hundreds of thousands), and the patch under the
//! hit is then looked up in the hit triangle's own plane: every triangle keeps, per side,
//! a uniform grid over its barycentric square whose cells list the patches overlapping
//! them, so a lookup tests a few patches in 2D. On office-floor (1,916 triangles, 177,222
//! patches) a nearest hit on the scene BVH is about 3× as fast as on the patches'
//! (`cargo run --release --example ray_throughput`).
//!
//! The patches of a triangle tile it (meshing only subdivides), a side at a time: the
//! front patches (normal along the triangle's winding) and, for a two-sided surface, the
//! back ones.

use glam::{DVec3, Vec3A};

use super::bvh::Bvh;
use super::mesh::Mesh;
use crate::scene::Triangle;

/// One side of a triangle: its grid of cells, each a run of patch ids.
#[derive(Clone, Copy, Debug, Default)]
struct Side {
    /// Cells per axis of the barycentric square (0: the side has no patches).
    grid: u32,
    /// The side's first cell in [`PatchLocator::cell_start`].
    first_cell: u32,
}

/// A triangle's barycentric frame and its sides.
#[derive(Clone, Copy, Debug)]
struct Frame {
    origin: DVec3,
    /// `u = (x − origin)·to_u`, `v = (x − origin)·to_v`: the weights of the second and
    /// third corners.
    to_u: DVec3,
    to_v: DVec3,
    /// The winding normal (not normalised): the front side faces along it.
    normal: Vec3A,
    /// Front (along the normal) and back.
    sides: [Side; 2],
}

/// Finds the patch under a point of a scene triangle, and the patch a ray meets.
pub struct PatchLocator {
    frames: Vec<Frame>,
    /// Per cell, where its run of patch ids starts in `entries` (one more at the end).
    cell_start: Vec<u32>,
    entries: Vec<u32>,
    /// Per patch, its corners' barycentric coordinates in its triangle, `[u0, v0, u1, v1,
    /// u2, v2]`.
    uv: Vec<[f32; 6]>,
}

/// Bytes per patch a [`PatchLocator`] holds, at most, besides [`LOCATOR_BYTES_PER_TRIANGLE`]
/// per scene triangle: its coordinates (24), grid entries (about four per patch) and cells
/// (two per patch).
pub const LOCATOR_BYTES_PER_PATCH: u64 = 24 + 4 * 6 + 4 * 3;
/// Bytes per scene triangle a [`PatchLocator`] holds.
pub const LOCATOR_BYTES_PER_TRIANGLE: u64 = std::mem::size_of::<Frame>() as u64 + 8;

/// A patch is taken as containing a point whose barycentric weights in it are all above
/// this (a seam between neighbours, or rounding, leaves a point just outside both).
const INSIDE: f32 = -1e-4;

impl PatchLocator {
    /// Indexes `mesh`'s patches by the scene triangle each was cut from (`triangles`, the
    /// scene's, as in [`crate::geometry::mesh::Patch::source`]).
    pub fn new(mesh: &Mesh, triangles: &[Triangle]) -> PatchLocator {
        let mut frames: Vec<Frame> = triangles.iter().map(|t| frame(&t.p)).collect();
        // Patches per (triangle, side).
        let mut by_side: Vec<Vec<u32>> = vec![Vec::new(); 2 * triangles.len()];
        let mut uv = vec![[0f32; 6]; mesh.len()];
        for (j, p) in mesh.patches.iter().enumerate() {
            let s = p.source as usize;
            let Some(f) = frames.get(s) else { continue };
            let back = p.normal.dot(f.normal.as_dvec3()) < 0.0;
            by_side[2 * s + usize::from(back)].push(j as u32);
            for (k, c) in mesh.corners(j).iter().enumerate() {
                let (u, v) = f.coords(*c);
                uv[j][2 * k] = u as f32;
                uv[j][2 * k + 1] = v as f32;
            }
        }
        let mut cell_start = Vec::new();
        let mut entries = Vec::new();
        for (s, f) in frames.iter_mut().enumerate() {
            for (k, side) in f.sides.iter_mut().enumerate() {
                let ids = &by_side[2 * s + k];
                if ids.is_empty() {
                    continue;
                }
                // About one patch per cell of the triangle's half of the square.
                let grid = ((2.0 * ids.len() as f64).sqrt().ceil() as u32).clamp(1, 1024);
                *side = Side {
                    grid,
                    first_cell: cell_start.len() as u32,
                };
                let g = grid as usize;
                let mut cells: Vec<Vec<u32>> = vec![Vec::new(); g * g];
                for &j in ids {
                    let c = &uv[j as usize];
                    let (lo, hi) = (
                        [c[0].min(c[2]).min(c[4]), c[1].min(c[3]).min(c[5])],
                        [c[0].max(c[2]).max(c[4]), c[1].max(c[3]).max(c[5])],
                    );
                    let (x0, y0) = (cell_of(lo[0], g), cell_of(lo[1], g));
                    let (x1, y1) = (cell_of(hi[0], g), cell_of(hi[1], g));
                    for y in y0..=y1 {
                        for x in x0..=x1 {
                            cells[y * g + x].push(j);
                        }
                    }
                }
                for cell in cells {
                    cell_start.push(entries.len() as u32);
                    entries.extend(cell);
                }
            }
        }
        cell_start.push(entries.len() as u32);
        PatchLocator {
            frames,
            cell_start,
            entries,
            uv,
        }
    }

    /// The patch of triangle `tri` on side `back` under the point `x` (on or next to the
    /// triangle's plane): the patch containing it, or when rounding leaves it in none,
    /// the one it lies least outside of. None when that side has no patches.
    pub fn locate(&self, tri: u32, back: bool, x: DVec3) -> Option<u32> {
        self.locate_weighted(tri, back, x).map(|(j, _)| j)
    }

    /// As [`Self::locate`], with the point's barycentric weights on the patch's corners
    /// (clamped to the patch, summing to 1).
    pub fn locate_weighted(&self, tri: u32, back: bool, x: DVec3) -> Option<(u32, [f32; 3])> {
        let f = self.frames.get(tri as usize)?;
        let side = f.sides[usize::from(back)];
        if side.grid == 0 {
            return None;
        }
        let (u, v) = f.coords(x);
        let (u, v) = (u as f32, v as f32);
        let g = side.grid as usize;
        let cell = side.first_cell as usize + cell_of(v, g) * g + cell_of(u, g);
        let run = self.cell_start[cell] as usize..self.cell_start[cell + 1] as usize;
        let best = self.best_of(&self.entries[run], u, v).or_else(|| {
            // An empty cell (a point beside the triangle, past rounding): every patch of
            // the side.
            let all = side.first_cell as usize..side.first_cell as usize + g * g;
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

    /// The nearest patch the ray `o + t·d` (t > 0) meets, with its distance parameter,
    /// traced on `bvh` (the scene BVH: ids are scene triangles). Of the two sides of a
    /// triangle the one facing the ray is met; the side facing away is met where the
    /// triangle has no facing side (a one-sided surface seen from behind), unless
    /// `cull_back`. `own`, the triangle the ray leaves, is passed through. At equal
    /// distances a facing side wins over a side facing away.
    pub fn nearest(
        &self,
        bvh: &Bvh,
        o: DVec3,
        d: DVec3,
        own: Option<u32>,
        cull_back: bool,
    ) -> Option<(f32, u32)> {
        self.nearest_weighted(bvh, o, d, own, cull_back)
            .map(|(t, j, _)| (t, j))
    }

    /// As [`Self::nearest`], with the hit's barycentric weights on the patch's corners
    /// ([`Self::locate_weighted`]).
    pub fn nearest_weighted(
        &self,
        bvh: &Bvh,
        o: DVec3,
        d: DVec3,
        own: Option<u32>,
        cull_back: bool,
    ) -> Option<(f32, u32, [f32; 3])> {
        let d32 = Vec3A::from(d.as_vec3());
        let rank = |s: u32| -> u8 {
            if Some(s) == own {
                return 0;
            }
            let Some(f) = self.frames.get(s as usize) else {
                return 0;
            };
            let back = f.normal.dot(d32) >= 0.0;
            if f.sides[usize::from(back)].grid > 0 {
                2
            } else if !cull_back && f.sides[usize::from(!back)].grid > 0 {
                1
            } else {
                0
            }
        };
        let (t, s) = bvh.nearest_ranked(Vec3A::from(o.as_vec3()), d32, 0.0, f32::INFINITY, rank)?;
        let f = &self.frames[s as usize];
        let facing_back = f.normal.dot(d32) >= 0.0;
        let back = if f.sides[usize::from(facing_back)].grid > 0 {
            facing_back
        } else {
            !facing_back
        };
        self.locate_weighted(s, back, o + d * t as f64)
            .map(|(j, w)| (t, j, w))
    }
}

impl Frame {
    /// The barycentric weights (u, v) of the second and third corners at `x`.
    #[inline]
    fn coords(&self, x: DVec3) -> (f64, f64) {
        let r = x - self.origin;
        (r.dot(self.to_u), r.dot(self.to_v))
    }
}

/// A triangle's barycentric frame (no sides yet). A degenerate triangle gets a zero frame:
/// every point maps to its first corner.
fn frame(p: &[DVec3; 3]) -> Frame {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d11 * d22 - d12 * d12;
    let (to_u, to_v) = if den.abs() > 1e-300 {
        ((d22 * e1 - d12 * e2) / den, (d11 * e2 - d12 * e1) / den)
    } else {
        (DVec3::ZERO, DVec3::ZERO)
    };
    Frame {
        origin: p[0],
        to_u,
        to_v,
        normal: Vec3A::from(e1.cross(e2).as_vec3()),
        sides: [Side::default(); 2],
    }
}

/// The cell (0..g) of coordinate `x` on a `g`-cell axis over 0..1, clamped.
#[inline]
fn cell_of(x: f32, g: usize) -> usize {
    ((x * g as f32).max(0.0) as usize).min(g - 1)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// On a bundled scene, the patch found through the scene triangles is the one the
    /// patch BVH finds, for random rays from random patches, and its distance is the same.
    #[test]
    fn the_located_patch_is_the_one_a_bvh_over_the_patches_meets() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
        let scene = Scene::load(&dir).unwrap();
        let mesh = Mesh::build(&scene);
        let bvh = crate::bake::scene_bvh(&scene);
        let loc = PatchLocator::new(&mesh, &scene.triangles);
        let tris: Vec<[Vec3A; 3]> = (0..mesh.len())
            .map(|j| mesh.corners(j).map(|p| Vec3A::from(p.as_vec3())))
            .collect();
        let patches = Bvh::new(&tris);
        let mut rng = crate::transport::formfactor::Rng::new(1, 2);
        let (mut same, mut hits, n) = (0, 0, 20_000);
        for _ in 0..n {
            let p = ((rng.next_f64() * mesh.len() as f64) as usize).min(mesh.len() - 1);
            let c = mesh.corners(p);
            let (a, b) = (rng.next_f64(), rng.next_f64());
            let (a, b) = if a + b > 1.0 {
                (1.0 - a, 1.0 - b)
            } else {
                (a, b)
            };
            let x = c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * b;
            let nrm = mesh.patches[p].normal;
            let d = (nrm + DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) - 0.5)
                .normalize();
            if d.dot(nrm) <= 0.01 {
                continue;
            }
            let o = x + nrm * 1e-6 * (1.0 + x.abs().max_element());
            let want = patches.nearest_ranked(
                Vec3A::from(o.as_vec3()),
                Vec3A::from(d.as_vec3()),
                0.0,
                f32::INFINITY,
                |q| {
                    if q as usize == p {
                        0
                    } else if mesh.patches[q as usize].normal.dot(d) < 0.0 {
                        2
                    } else {
                        1
                    }
                },
            );
            let got = loc.nearest_weighted(&bvh, o, d, Some(mesh.patches[p].source), false);
            assert_eq!(got.is_some(), want.is_some(), "from patch {p} along {d}");
            if let (Some((tg, jg, w)), Some((tw, jw))) = (got, want) {
                hits += 1;
                // The weights put the point where the ray met the patch.
                let c = mesh.corners(jg as usize);
                let at = c[0] * w[0] as f64 + c[1] * w[1] as f64 + c[2] * w[2] as f64;
                let x = o + d * tg as f64;
                assert!(
                    (at - x).length() < 1e-4 * (1.0 + tg as f64),
                    "{at} against {x}"
                );
                assert!((tg - tw).abs() <= 1e-4 * tw.max(1.0), "{tg} against {tw}");
                // On a shared edge either neighbour is right.
                same += usize::from(jg == jw);
            }
        }
        assert!(hits > n / 2, "{hits} hits");
        assert!(
            same as f64 > 0.999 * hits as f64,
            "{same} of {hits} the same patch"
        );
    }
}
