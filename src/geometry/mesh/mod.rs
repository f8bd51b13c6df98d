//! Meshing: scene triangles → patches.
//!
//! Per surface, vertices are welded by position, T-junctions already in the input are
//! repaired (a vertex lying inside another triangle's edge splits that triangle), and the
//! triangles are refined by Rivara's longest-edge bisection until no edge is longer than
//! `max_edge`. Longest-edge bisection keeps the mesh conforming: neighbouring patches of a
//! surface share their vertices, so per-vertex (Gouraud) interpolation has no cracks.
//!
//! Small triangles (a model's furniture detail, far below `max_edge`) are then clustered
//! into patches of about `max_edge` ([`cluster`]): a patch is one or more triangles, its
//! *elements*, of one surface and material facing the same way. Rendering, sampling and
//! exports work on the elements; the transfer has one unknown per patch.
//!
//! **Patch order** (stable, part of the API): surfaces in the order of their first
//! appearance in the OBJ; within a surface, front-side patches in refinement order
//! (deterministic for a given input and `max_edge`), then, for two-sided surfaces, the
//! back-side patches in the same order. Each surface owns one contiguous range.

use std::ops::Range;

use glam::{DVec3, Vec3A};

use crate::geometry::bvh::Bvh;

use crate::scene::{is_two_sided, Scene};

mod cluster;
mod contacts;
mod refine;

use contacts::Contacts;
pub use contacts::CONTACT_DIVISOR;
use refine::Refiner;

pub use cluster::{MAX_CLUSTER_TURN_DEG, SMALL_AREA_SHARE};

/// One patch: a set of triangles (its elements, one for most patches) of constant
/// radiosity.
#[derive(Debug, Clone)]
pub struct Patch {
    /// Its elements, a range of [`Mesh::elements`].
    pub elements: Range<u32>,
    pub surface: u32,
    pub material: u32,
    /// Light group of an emitting patch.
    pub group: Option<u32>,
    /// Area in m² (the sum of its elements').
    pub area: f64,
    /// Centroid in metres (area-weighted over its elements).
    pub centroid: DVec3,
    /// Unit normal of the front (emitting, reflecting, receiving) side: the area-weighted
    /// mean of its elements' normals.
    pub normal: DVec3,
    /// Index of the scene triangle its first element was cut from.
    pub source: u32,
}

/// One element of a patch with its geometry, as samplers and integrators use it.
#[derive(Debug, Clone, Copy)]
pub struct Facet {
    pub corners: [DVec3; 3],
    /// Unit normal of the front side.
    pub normal: DVec3,
    pub centroid: DVec3,
    /// Area in m².
    pub area: f64,
    /// The scene triangle it was cut from (rays leaving it skip that triangle).
    pub source: u32,
}

impl Facet {
    /// The facet of a triangle given counter-clockwise from the front.
    pub fn new(corners: [DVec3; 3], source: u32) -> Facet {
        let [a, b, c] = corners;
        let cr = (b - a).cross(c - a);
        Facet {
            corners,
            normal: cr.normalize(),
            centroid: (a + b + c) / 3.0,
            area: 0.5 * cr.length(),
            source,
        }
    }
}

/// One triangle of a patch: what rendering, sampling and exports work on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Element {
    /// Vertex indices into [`Mesh::vertices`], counter-clockwise seen from the front.
    pub v: [u32; 3],
    /// The patch it belongs to.
    pub patch: u32,
    /// Index of the scene triangle it was cut from.
    pub source: u32,
}

/// The patches of a scene and their shared vertices.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions in metres. Vertices are shared within a surface only.
    pub vertices: Vec<DVec3>,
    pub patches: Vec<Patch>,
    /// The triangles of all patches, patch by patch (each patch owns a contiguous range).
    pub elements: Vec<Element>,
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
        let mut out = Builder::default();
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
            let start = out.patches.len() as u32;
            if !tris.is_empty() {
                // Refinement is bounded by the limit on its triangles: a patch has at
                // least one.
                let done = out.elements.len();
                let budget = max_patches.saturating_sub(done);
                let mut r = Refiner::new(scene, tris);
                r.fix_t_junctions(budget).map_err(|n| too_many(done + n))?;
                // Triangles from here on are cut by refinement: never clustered.
                let input = r.tris.len();
                r.refine(max_edge, budget).map_err(|n| too_many(done + n))?;
                r.refine_where(max_edge / CONTACT_DIVISOR, budget, |r, t| {
                    contacts.cut(&r.corners(t), &mut found.borrow_mut())
                })
                .map_err(|n| too_many(done + n))?;
                let front: Vec<usize> = (0..r.tris.len()).filter(|&t| r.alive[t]).collect();
                let groups = if scene.mesh.cluster {
                    cluster::clusters(&r, &front, input, scene, max_edge, |t| {
                        contacts.cut(&r.corners(t), &mut found.borrow_mut())
                    })
                } else {
                    front.iter().map(|&t| vec![t]).collect()
                };
                let base = out.vertices.len() as u32;
                out.vertices.extend_from_slice(&r.pos);
                let tri = |t: usize| &scene.triangles[r.src[t] as usize];
                let two: Vec<&Vec<usize>> = groups
                    .iter()
                    .filter(|g| is_two_sided(tri(g[0]), &scene.materials, &scene.surfaces))
                    .collect();
                if out.patches.len() + groups.len() + two.len() > max_patches {
                    return Err(too_many(out.patches.len() + groups.len() + two.len()));
                }
                for g in &groups {
                    out.push(
                        g.iter().map(|&t| (r.tris[t].map(|k| k + base), r.src[t])),
                        tri(g[0]),
                    );
                }
                for g in two {
                    let back = g.iter().map(|&t| {
                        let [a, b, c] = r.tris[t].map(|k| k + base);
                        ([a, c, b], r.src[t])
                    });
                    out.push(back, tri(g[0]));
                }
            }
            surface_patches.push(start..out.patches.len() as u32);
        }
        Ok(Mesh {
            vertices: out.vertices,
            patches: out.patches,
            elements: out.elements,
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

    /// Corner positions of element `e`.
    pub fn element_corners(&self, e: usize) -> [DVec3; 3] {
        self.elements[e].v.map(|k| self.vertices[k as usize])
    }

    /// The elements of patch `i`, as indices into [`Mesh::elements`].
    pub fn elements_of(&self, i: usize) -> Range<usize> {
        let r = &self.patches[i].elements;
        r.start as usize..r.end as usize
    }

    /// The corners of each element of patch `i`, with the scene triangle it was cut from.
    pub fn triangles_of(&self, i: usize) -> impl Iterator<Item = ([DVec3; 3], u32)> + '_ {
        self.elements_of(i)
            .map(|e| (self.element_corners(e), self.elements[e].source))
    }

    /// The elements of patch `i` as [`Facet`]s. A single-triangle patch gives one, with
    /// exactly the patch's own normal, centroid, area and source.
    pub fn facets(&self, i: usize) -> impl Iterator<Item = Facet> + '_ {
        let p = &self.patches[i];
        let single = p.elements.len() == 1;
        self.elements_of(i).map(move |e| {
            let corners = self.element_corners(e);
            if single {
                Facet {
                    corners,
                    normal: p.normal,
                    centroid: p.centroid,
                    area: p.area,
                    source: p.source,
                }
            } else {
                Facet::new(corners, self.elements[e].source)
            }
        })
    }

    /// The facet of patch `i` that `u` ∈ [0, 1) falls in when its elements are laid end to
    /// end by area, and `u` rescaled to [0, 1) within it: a sample of the patch by area.
    /// A single-triangle patch gives its facet and `u` unchanged.
    pub fn pick_facet(&self, i: usize, u: f64) -> (Facet, f64) {
        let p = &self.patches[i];
        let mut facets = self.facets(i);
        let first = facets.next().expect("a patch has an element");
        if p.elements.len() == 1 {
            return (first, u);
        }
        let target = u * p.area;
        let mut at = 0.0;
        let mut last = first;
        for f in std::iter::once(first).chain(facets) {
            if target < at + f.area {
                return (f, ((target - at) / f.area).clamp(0.0, 1.0 - f64::EPSILON));
            }
            at += f.area;
            last = f;
        }
        (last, 1.0 - f64::EPSILON)
    }

    /// Element `e` as a [`Facet`]; exactly its patch's facet when the patch is a single
    /// triangle.
    pub fn facet(&self, e: usize) -> Facet {
        let el = &self.elements[e];
        let p = &self.patches[el.patch as usize];
        if p.elements.len() == 1 {
            Facet {
                corners: self.element_corners(e),
                normal: p.normal,
                centroid: p.centroid,
                area: p.area,
                source: p.source,
            }
        } else {
            Facet::new(self.element_corners(e), el.source)
        }
    }

    /// The element of patch `i` that the point `x` (on the patch) lies in, and `x`'s
    /// barycentric coordinates in it: the element whose smallest coordinate is largest.
    pub fn locate(&self, i: usize, x: DVec3) -> (usize, [f64; 3]) {
        let r = self.elements_of(i);
        if r.len() == 1 {
            return (
                r.start,
                crate::geometry::barycentric(&self.element_corners(r.start), x),
            );
        }
        let mut best = (
            self.patches[i].elements.start as usize,
            [0.0; 3],
            f64::NEG_INFINITY,
        );
        for e in self.elements_of(i) {
            let l = crate::geometry::barycentric(&self.element_corners(e), x);
            let worst = l[0].min(l[1]).min(l[2]);
            if worst > best.2 {
                best = (e, l, worst);
            }
        }
        (best.0, best.1)
    }

    /// The corners of patch `i` when it is a single triangle (most patches are).
    pub fn single_corners(&self, i: usize) -> Option<[DVec3; 3]> {
        let r = self.elements_of(i);
        (r.len() == 1).then(|| self.element_corners(r.start))
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
            for e in &self.elements[p.elements.start as usize..p.elements.end as usize] {
                for k in e.v {
                    h.update(&k.to_le_bytes());
                }
            }
            if p.elements.len() > 1 {
                h.update(&(p.elements.len() as u32).to_le_bytes());
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
/// on the estimate could never have been meshed within the limit. Small triangles, which
/// may share a cluster patch, count their area over `h²` (a cluster fits in a box of
/// diagonal `h` and faces one way within 25°, so its area is at most about `0.55 h²`).
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
    // Small triangles may share cluster patches: area over the largest cluster's.
    let mut clustered = 0f64;
    let small = SMALL_AREA_SHARE * max_edge * max_edge;
    for t in &scene.triangles {
        let [a, b, c] = t.p;
        let area = 0.5 * (b - a).cross(c - a).length();
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        let sides = if is_two_sided(t, &scene.materials, &scene.surfaces) {
            2.0
        } else {
            1.0
        };
        if scene.mesh.cluster && area <= small {
            clustered += sides * area / (h * h);
            continue;
        }
        let n = (area / tri_area).ceil().max((longest / h).ceil()).max(1.0);
        total += if n.is_finite() {
            n * sides
        } else {
            f64::INFINITY
        };
    }
    total += clustered.ceil();
    if total >= u64::MAX as f64 || total.is_nan() {
        u64::MAX
    } else {
        total as u64
    }
}

/// The mesh as it grows, patch by patch.
#[derive(Default)]
struct Builder {
    vertices: Vec<DVec3>,
    patches: Vec<Patch>,
    elements: Vec<Element>,
}

impl Builder {
    /// Adds a patch of the given elements (vertex indices, source triangle), which come
    /// from `tri`'s surface and material.
    fn push(&mut self, elems: impl Iterator<Item = ([u32; 3], u32)>, tri: &crate::scene::Triangle) {
        let id = self.patches.len() as u32;
        let start = self.elements.len() as u32;
        let (mut area, mut moment, mut normal) = (0.0, DVec3::ZERO, DVec3::ZERO);
        for (v, source) in elems {
            let [a, b, c] = v.map(|k| self.vertices[k as usize]);
            let cr = (b - a).cross(c - a);
            let ea = 0.5 * cr.length();
            area += ea;
            moment += ea * (a + b + c) / 3.0;
            normal += 0.5 * cr;
            self.elements.push(Element {
                v,
                patch: id,
                source,
            });
        }
        let range = start..self.elements.len() as u32;
        let first = self.elements[start as usize];
        let (centroid, normal) = if range.len() == 1 {
            // One triangle: exactly its centroid and normal.
            let [a, b, c] = first.v.map(|k| self.vertices[k as usize]);
            ((a + b + c) / 3.0, (b - a).cross(c - a).normalize())
        } else {
            (moment / area, normal.normalize())
        };
        self.patches.push(Patch {
            elements: range,
            surface: tri.surface,
            material: tri.material,
            group: tri.group,
            area,
            centroid,
            normal,
            source: first.source,
        });
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
        for e in &m.elements {
            let p = &m.patches[e.patch as usize];
            for k in 0..3 {
                *count.entry(key(e.v[k], e.v[(k + 1) % 3])).or_default() += 1;
                surface[e.v[k] as usize] = p.surface;
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
            let c = m.element_corners(i);
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
            let c = m.element_corners(i as usize);
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
