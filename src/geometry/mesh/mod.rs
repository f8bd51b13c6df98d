//! Meshing: scene triangles → patches.
//!
//! Per surface, vertices are welded by position, T-junctions already in the input are
//! repaired (a vertex lying inside another triangle's edge splits that triangle), and the
//! triangles are refined by Rivara's longest-edge bisection until no edge is longer than
//! `max_edge`. Longest-edge bisection keeps the mesh conforming: neighbouring patches of a
//! surface share their vertices, so per-vertex (Gouraud) interpolation has no cracks.
//!
//! **Patch order** (stable, part of the API): surfaces in the order of their first
//! appearance in the OBJ; within a surface, front-side patches in refinement order
//! (deterministic for a given input and `max_edge`), then, for two-sided surfaces, the
//! back-side patches in the same order. Each surface owns one contiguous range.

use std::ops::Range;

use glam::{DVec3, Vec3A};

use crate::geometry::bvh::Bvh;

use crate::scene::{is_two_sided, Scene};

mod contacts;
mod refine;

use contacts::Contacts;
pub use contacts::CONTACT_DIVISOR;
use refine::Refiner;

/// One patch: a triangle of constant radiosity.
#[derive(Debug, Clone)]
pub struct Patch {
    /// Vertex indices into [`Mesh::vertices`], counter-clockwise seen from the front.
    pub v: [u32; 3],
    pub surface: u32,
    pub material: u32,
    /// Light group of an emitting patch.
    pub group: Option<u32>,
    /// Area in m².
    pub area: f64,
    /// Centroid in metres.
    pub centroid: DVec3,
    /// Unit normal of the front (emitting, reflecting, receiving) side.
    pub normal: DVec3,
    /// Index of the scene triangle the patch was cut from.
    pub source: u32,
}

/// The patches of a scene and their shared vertices.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions in metres. Vertices are shared within a surface only.
    pub vertices: Vec<DVec3>,
    pub patches: Vec<Patch>,
    /// Patch range of each surface (indexed like `Scene::surfaces`).
    pub surface_patches: Vec<Range<u32>>,
}

impl Mesh {
    /// Meshes `scene` with its `max_edge`.
    pub fn build(scene: &Scene) -> Mesh {
        Self::build_with(scene, scene.mesh.max_edge)
    }

    /// Meshes `scene` with patches no longer than `max_edge` metres on any edge.
    pub fn build_with(scene: &Scene, max_edge: f64) -> Mesh {
        match Self::build_limited(scene, max_edge, usize::MAX) {
            Ok(m) => m,
            // A live count cannot exceed usize::MAX.
            Err(e) => unreachable!("unlimited meshing stopped: {e}"),
        }
    }

    /// Meshes `scene` like [`Mesh::build_with`], but refuses to produce more than
    /// `max_patches` patches. The refusal comes before any meshing when
    /// [`estimate_patches`] already exceeds the limit, else as soon as refinement passes it
    /// (so the work is bounded by the limit either way).
    pub fn try_build_with(
        scene: &Scene,
        max_edge: f64,
        max_patches: usize,
    ) -> Result<Mesh, TooManyPatches> {
        let at_least = estimate_patches(scene, max_edge);
        if at_least > max_patches as u64 {
            return Err(TooManyPatches {
                at_least,
                limit: max_patches,
                estimated: true,
            });
        }
        Self::build_limited(scene, max_edge, max_patches)
    }

    fn build_limited(
        scene: &Scene,
        max_edge: f64,
        max_patches: usize,
    ) -> Result<Mesh, TooManyPatches> {
        let too_many = |n: usize| TooManyPatches {
            at_least: n as u64,
            limit: max_patches,
            estimated: false,
        };
        let mut vertices = Vec::new();
        let mut patches = Vec::new();
        let mut surface_patches = Vec::with_capacity(scene.surfaces.len());
        let contacts = Contacts::new(scene);
        let found = std::cell::RefCell::new(Vec::new());
        // Triangles of each surface, in scene order.
        let mut by_surface: Vec<Vec<u32>> = vec![Vec::new(); scene.surfaces.len()];
        for (t, tri) in scene.triangles.iter().enumerate() {
            if let Some(list) = by_surface.get_mut(tri.surface as usize) {
                list.push(t as u32);
            }
        }
        for tris in &by_surface {
            let start = patches.len() as u32;
            if !tris.is_empty() {
                let budget = max_patches.saturating_sub(patches.len());
                let mut r = Refiner::new(scene, tris);
                r.fix_t_junctions(budget)
                    .map_err(|n| too_many(patches.len() + n))?;
                r.refine(max_edge, budget)
                    .map_err(|n| too_many(patches.len() + n))?;
                r.refine_where(max_edge / CONTACT_DIVISOR, budget, |r, t| {
                    contacts.cut(&r.corners(t), &mut found.borrow_mut())
                })
                .map_err(|n| too_many(patches.len() + n))?;
                let base = vertices.len() as u32;
                vertices.extend_from_slice(&r.pos);
                let front: Vec<usize> = (0..r.tris.len()).filter(|&t| r.alive[t]).collect();
                for &t in &front {
                    let src = r.src[t];
                    let tri = &scene.triangles[src as usize];
                    let v = r.tris[t].map(|k| k + base);
                    patches.push(make_patch(&vertices, v, tri, src));
                }
                let two: Vec<usize> = front
                    .iter()
                    .copied()
                    .filter(|&t| {
                        let tri = &scene.triangles[r.src[t] as usize];
                        is_two_sided(tri, &scene.materials, &scene.surfaces)
                    })
                    .collect();
                if patches.len().saturating_add(two.len()) > max_patches {
                    return Err(too_many(patches.len() + two.len()));
                }
                for t in two {
                    let src = r.src[t];
                    let tri = &scene.triangles[src as usize];
                    let [a, b, c] = r.tris[t].map(|k| k + base);
                    patches.push(make_patch(&vertices, [a, c, b], tri, src));
                }
            }
            surface_patches.push(start..patches.len() as u32);
        }
        Ok(Mesh {
            vertices,
            patches,
            surface_patches,
        })
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.patches.len()
    }

    /// True when the mesh has no patch.
    pub fn is_empty(&self) -> bool {
        self.patches.is_empty()
    }

    /// Corner positions of patch `i`.
    pub fn corners(&self, i: usize) -> [DVec3; 3] {
        self.patches[i].v.map(|k| self.vertices[k as usize])
    }

    /// A hash of the mesh geometry, stored in the cache to check that a transfer belongs
    /// to this exact patch set.
    pub fn fingerprint(&self) -> u64 {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        for p in &self.vertices {
            for c in p.to_array() {
                h.update(&c.to_le_bytes());
            }
        }
        for p in &self.patches {
            for k in p.v {
                h.update(&k.to_le_bytes());
            }
            h.update(&p.surface.to_le_bytes());
            h.update(&p.material.to_le_bytes());
            h.update(&p.group.map_or(u32::MAX, |g| g).to_le_bytes());
        }
        h.digest()
    }
}

/// Meshing would exceed a patch limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "meshing {} {at_least} patches, more than the limit of {limit}",
    if *estimated { "would give at least" } else { "stopped after" }
)]
pub struct TooManyPatches {
    /// A lower bound of the patch count ([`estimate_patches`]), or the count at which
    /// refinement stopped.
    pub at_least: u64,
    pub limit: usize,
    /// True when the refusal came from the estimate, before any meshing.
    pub estimated: bool,
}

/// A lower bound on the number of patches [`Mesh::build_with`] gives for `max_edge`
/// (metres), computed from the scene's triangles in O(triangles) without allocating.
///
/// Refinement stops when no edge is longer than `h = max_edge`, so every patch has area at
/// most `(√3/4)·h²` (the equilateral triangle is the largest with edges ≤ h), and an input
/// edge of length `l` ends up split into at least `⌈l/h⌉` pieces, each on a different patch.
/// Per input triangle of area `A` and longest edge `l`, that is at least
/// `max(⌈A / ((√3/4)·h²)⌉, ⌈l/h⌉, 1)` patches, doubled for two-sided triangles. T-junction
/// repair and the longest-edge propagation between neighbours only add patches. Longest-edge
/// bisection typically leaves triangles of about `h²/5` (right isosceles shapes), so the
/// real count is usually about 2× this bound; the bound never exceeds it, so a scene refused
/// on the estimate could never have been meshed within the limit.
///
/// Returns `u64::MAX` when `max_edge` is not a positive finite length.
pub fn estimate_patches(scene: &Scene, max_edge: f64) -> u64 {
    if !(max_edge.is_finite() && max_edge > 0.0) {
        return u64::MAX;
    }
    // The refinement tolerates edges up to h·√(1 + 1e-9).
    let h = max_edge * (1.0 + 1e-9);
    let tri_area = 3f64.sqrt() / 4.0 * h * h;
    let mut total = 0f64;
    for t in &scene.triangles {
        let [a, b, c] = t.p;
        let area = 0.5 * (b - a).cross(c - a).length();
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        let n = (area / tri_area).ceil().max((longest / h).ceil()).max(1.0);
        let sides = if is_two_sided(t, &scene.materials, &scene.surfaces) {
            2.0
        } else {
            1.0
        };
        total += if n.is_finite() {
            n * sides
        } else {
            f64::INFINITY
        };
    }
    if total >= u64::MAX as f64 || total.is_nan() {
        u64::MAX
    } else {
        total as u64
    }
}

fn make_patch(vertices: &[DVec3], v: [u32; 3], tri: &crate::scene::Triangle, src: u32) -> Patch {
    let [a, b, c] = v.map(|k| vertices[k as usize]);
    let cr = (b - a).cross(c - a);
    Patch {
        v,
        surface: tri.surface,
        material: tri.material,
        group: tri.group,
        area: 0.5 * cr.length(),
        centroid: (a + b + c) / 3.0,
        normal: cr.normalize(),
        source: src,
    }
}

#[cfg(test)]
mod tests {
    use super::contacts::cuts;
    use super::refine::key;
    use super::*;
    use std::collections::HashMap as Map;

    fn square_scene(extra_t_junction: bool) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let mut obj = String::from("mtllib m.mtl\no floor\nusemtl w\n");
        if extra_t_junction {
            // Left half is one quad, right half two quads: the middle vertex at (1,0,1)
            // lies on the left quad's edge.
            obj += "v 0 0 0\nv 1 0 0\nv 1 0 2\nv 0 0 2\nf 1 4 3 2\n";
            obj += "v 2 0 0\nv 2 0 1\nv 1 0 1\nf 2 7 6 5\n";
            obj += "v 2 0 2\nf 7 3 8 6\n";
        } else {
            obj += "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nf 1 4 3 2\n";
        }
        std::fs::write(dir.path().join("s.obj"), obj).unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl w\nKd 0.5 0.5 0.5\n").unwrap();
        let s = Scene::load(dir.path()).unwrap();
        std::mem::forget(dir);
        s
    }

    /// Every interior edge must be shared by exactly two patches: no hanging vertices
    /// (within a surface: surfaces do not share vertices).
    fn assert_conforming(m: &Mesh) {
        let mut count: Map<(u32, u32), usize> = Map::new();
        let mut surface = vec![u32::MAX; m.vertices.len()];
        for p in &m.patches {
            for k in 0..3 {
                *count.entry(key(p.v[k], p.v[(k + 1) % 3])).or_default() += 1;
                surface[p.v[k] as usize] = p.surface;
            }
        }
        // A vertex lying strictly inside some edge would be a hanging node.
        for &(a, b) in count.keys() {
            let (pa, pb) = (m.vertices[a as usize], m.vertices[b as usize]);
            for (i, &pv) in m.vertices.iter().enumerate() {
                if i as u32 == a || i as u32 == b || surface[i] != surface[a as usize] {
                    continue;
                }
                let d = pb - pa;
                let s = (pv - pa).dot(d) / d.length_squared();
                if s > 1e-6 && s < 1.0 - 1e-6 {
                    assert!(
                        (pa + d * s).distance(pv) > 1e-9,
                        "hanging vertex {i} on edge {a}-{b}"
                    );
                }
            }
        }
    }

    #[test]
    fn refinement_respects_max_edge_and_area() {
        let s = square_scene(false);
        let m = Mesh::build_with(&s, 0.3);
        let total: f64 = m.patches.iter().map(|p| p.area).sum();
        assert!((total - 4.0).abs() < 1e-9, "area {total}");
        for i in 0..m.len() {
            let c = m.corners(i);
            for k in 0..3 {
                assert!(c[k].distance(c[(k + 1) % 3]) <= 0.3 + 1e-9);
            }
            assert!((m.patches[i].normal - DVec3::Y).length() < 1e-9);
        }
        assert!(m.len() > 40);
        assert_conforming(&m);
    }

    #[test]
    fn input_t_junctions_are_repaired() {
        let s = square_scene(true);
        let m = Mesh::build_with(&s, 0.7);
        let total: f64 = m.patches.iter().map(|p| p.area).sum();
        assert!((total - 4.0).abs() < 1e-9);
        assert_conforming(&m);
    }

    #[test]
    fn patch_order_is_stable() {
        let s = square_scene(true);
        let a = Mesh::build_with(&s, 0.25);
        let b = Mesh::build_with(&s, 0.25);
        assert_eq!(a.fingerprint(), b.fingerprint());
    }

    /// The 2 × 2 m floor with a 0.4 m box standing on it (sides only, no bottom), whose
    /// walls cross the floor's interior along the footprint's outline.
    fn floor_with_box(x0: f64) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let mut obj = String::from("mtllib m.mtl\no floor\nusemtl w\n");
        obj += "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nf 1 4 3 2\n";
        obj += "o box\nusemtl w\n";
        let (a, b) = (x0, x0 + 0.4);
        for (x, z) in [(a, a), (b, a), (b, b), (a, b)] {
            obj += &format!("v {x} 0 {z}\nv {x} 0.4 {z}\n");
        }
        // Four sides, facing out (vertices 5..12: bottom/top pairs around the footprint).
        obj += "f 5 7 8 6\nf 7 9 10 8\nf 9 11 12 10\nf 11 5 6 12\n";
        std::fs::write(dir.path().join("s.obj"), obj).unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl w\nKd 0.5 0.5 0.5\n").unwrap();
        let s = Scene::load(dir.path()).unwrap();
        std::mem::forget(dir);
        s
    }

    #[test]
    fn a_box_on_the_floor_refines_the_patches_its_outline_crosses() {
        let s = floor_with_box(0.8);
        let h = 0.5;
        let m = Mesh::build_with(&s, h);
        assert_conforming(&m);
        let floor = m.surface_patches[0].clone();
        let (mut crossing, mut coarse) = (0, 0);
        for i in floor.clone() {
            let c = m.corners(i as usize);
            let longest = (0..3)
                .map(|k| c[k].distance(c[(k + 1) % 3]))
                .fold(0.0, f64::max);
            // A patch with corners strictly on both sides of the line x = 0.8 (within the
            // footprint's z range) straddles the box's wall.
            let z_in = c.iter().all(|p| p.z > 0.8 && p.z < 1.2);
            let sides = (
                c.iter().any(|p| p.x < 0.8 - 1e-9),
                c.iter().any(|p| p.x > 0.8 + 1e-9),
            );
            if z_in && sides.0 && sides.1 {
                crossing += 1;
                assert!(
                    longest <= h / CONTACT_DIVISOR + 1e-9,
                    "patch {i}: edge {longest}"
                );
            }
            coarse += usize::from(longest > h / 2.0);
        }
        assert!(crossing > 0);
        // Away from the box the floor keeps its coarse patches.
        assert!(coarse > 10, "{coarse} coarse patches");
        let plain = Mesh::build_with(&square_scene(false), h);
        assert!(m.surface_patches[0].len() > plain.len() + 20);
        let area: f64 = floor.map(|i| m.patches[i as usize].area).sum();
        assert!((area - 4.0).abs() < 1e-9);
    }

    #[test]
    fn walls_meeting_a_floor_at_its_edge_or_coplanar_faces_do_not_cut() {
        let p = [
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
        ];
        // A wall standing on the edge z = 0... of the triangle: touches its boundary only.
        let wall = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        assert!(!cuts(&p, &wall));
        // Coplanar and overlapping.
        let flat = [
            DVec3::new(0.1, 0.0, 0.1),
            DVec3::new(0.5, 0.0, 0.1),
            DVec3::new(0.1, 0.0, 0.5),
        ];
        assert!(!cuts(&p, &flat));
        // Wholly above.
        let above = wall.map(|v| v + DVec3::Y * 0.1);
        assert!(!cuts(&p, &above));
        // Standing inside: its bottom edge crosses the interior.
        let inside = wall.map(|v| v + DVec3::new(0.0, 0.0, 0.2));
        assert!(cuts(&p, &inside));
        // Piercing through the plane.
        let through = inside.map(|v| v - DVec3::Y * 0.5);
        assert!(cuts(&p, &through));
        // Touching at one corner only.
        let point = [
            DVec3::new(0.2, 0.0, 0.2),
            DVec3::new(0.2, 1.0, 0.2),
            DVec3::new(0.3, 1.0, 0.2),
        ];
        assert!(!cuts(&p, &point));
    }
}
