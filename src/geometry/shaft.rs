//! Geometry: the shaft between a point and an emitting polygon, the region every shadow
//! ray from the point to the polygon sweeps (Haines & Wallace 1994, "Shaft culling for
//! efficient ray-cast radiosity").
//!
//! When no triangle of the scene can meet the shaft, every shadow ray to the emitter is
//! free, and its visible share is exactly 1 without a ray
//! ([`crate::geometry::bvh::Bvh::clear_of`]). The test is conservative: a triangle or a
//! box is set aside only when a plane separates it from the shaft by more than a
//! tolerance that covers the shadow rays' own rounding (single precision) and the
//! triangle test's edge slack. A triangle it cannot set aside (one that may block, or
//! that lies too close to tell) sends the caller back to its rays, so the shaft never
//! changes what the rays would find, only skips them.
//!
//! The shaft is the region the shadow rays actually test: segments from the lifted
//! origin `o` to points of the polygon, trimmed at both ends by [`TRIM`] of their length
//! as [`crate::geometry::bvh::Bvh::occluded`] trims them. So the surface the point lies
//! on, and the ceiling around a light mounted flush with it, touch the full pyramid but
//! not the trimmed shaft, and are set aside by the receiver's and the emitter's planes.
//!
//! An emitter's coplanar triangles that share corners (a panel's two halves) make one
//! set ([`coplanar_sets`]), and one shaft to the set's convex hull stands for all of them.

use glam::{DVec3, Vec3A};

/// The share of a shadow ray's length trimmed at each end ([`crate::geometry::bvh::Bvh::occluded`]).
pub const TRIM: f64 = 1e-5;

/// Most corners of the emitting polygon a [`Shaft`] reaches to.
pub const MAX_CORNERS: usize = 16;

/// The trimmed shaft from a point to a convex planar polygon: the planes that hold it
/// (the receiver's, the emitter's and one per side), its corners, and its bounding box.
#[derive(Debug, Clone)]
pub struct Shaft {
    /// Per plane, a unit normal `m`, a level `k` and a tolerance `tol`: the shaft lies in
    /// `m·p ≤ k`, and a point set lies beyond the plane when `m·p > k + tol` for all of it.
    /// The first `2 + sides` are in use.
    planes: [(DVec3, f64, f64); 2 + MAX_CORNERS],
    /// The trimmed shaft's corners: the ends of the trimmed segments to the polygon's
    /// corners (the first `2 · sides`).
    corners: [DVec3; 2 * MAX_CORNERS],
    sides: usize,
    /// Bounding box of the corners, widened by the side tolerance.
    lo: DVec3,
    hi: DVec3,
    /// Tolerance of the side planes and of a triangle's own plane, metres.
    tol: f64,
}

impl Shaft {
    /// The shaft of the shadow rays from `o` (already lifted off its surface by `lift`
    /// along the receiver's unit normal `n`) to the convex planar polygon `c` (3 to
    /// [`MAX_CORNERS`] corners in order) whose front (unit normal `ne`) faces it. None
    /// where the shaft cannot stand for the rays: a polygon not wholly above the
    /// receiver's surface or not facing the point, or a degenerate one.
    pub fn new(o: DVec3, n: DVec3, lift: f64, c: &[DVec3], ne: DVec3) -> Option<Shaft> {
        let sides = c.len();
        if !(3..=MAX_CORNERS).contains(&sides) {
            return None;
        }
        let x = o - n * lift;
        let scale = c
            .iter()
            .fold(o.abs().max_element(), |m, p| m.max(p.abs().max_element()));
        // Rounding of single-precision rays and the triangle test's edge slack (a
        // millionth of the triangle's edges, bounded by the scene's extent), with room.
        let tol = 2e-5 * (1.0 + scale);
        // Every corner above the receiver's surface by more than the lift: the rays then
        // all leave above it, and the receiver's plane holds the shaft.
        if c.iter().any(|&p| n.dot(p - x) <= 2.0 * lift) {
            return None;
        }
        // The point in front of the emitter: every ray arrives at its front.
        let h_o = ne.dot(o - c[0]);
        if !positive(h_o) {
            return None;
        }
        let mut planes = [(DVec3::ZERO, 0.0, 0.0); 2 + MAX_CORNERS];
        // Receiver: the trimmed segments lie at least `lift` above x's surface; rays that
        // lie within half of that of it graze nothing the rays would meet.
        planes[0] = (-n, -n.dot(x) - lift, 0.5 * lift);
        // Emitter: the segments end `TRIM` of the way short of it, so at least `TRIM · h_o`
        // in front of its plane.
        planes[1] = (-ne, -ne.dot(c[0]) - TRIM * h_o, 0.5 * TRIM * h_o);
        let centre = c.iter().sum::<DVec3>() / sides as f64;
        for i in 0..sides {
            let (a, b) = (c[i], c[(i + 1) % sides]);
            let mut m = (a - o).cross(b - o);
            let len = m.length();
            if !positive(len) {
                return None;
            }
            m /= len;
            if m.dot(centre - o) > 0.0 {
                m = -m;
            }
            // The polygon's centre strictly inside: otherwise o lies in its plane.
            if !positive(-tol - m.dot(centre - o)) {
                return None;
            }
            planes[2 + i] = (m, m.dot(o), tol);
        }
        let mut corners = [DVec3::ZERO; 2 * MAX_CORNERS];
        for (i, &p) in c.iter().enumerate() {
            corners[2 * i] = o + (p - o) * TRIM;
            corners[2 * i + 1] = p - (p - o) * TRIM;
        }
        let (mut lo, mut hi) = (corners[0], corners[0]);
        for p in &corners[1..2 * sides] {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        Some(Shaft {
            planes,
            corners,
            sides,
            lo: lo - DVec3::splat(tol),
            hi: hi + DVec3::splat(tol),
            tol,
        })
    }

    /// Per lane of 8 boxes (`lo`, `hi` by axis then lane), whether the box lies wholly
    /// outside the shaft (off its bounding box, or beyond one of its planes): bit `l` of
    /// the mask. A clear bit says nothing. Empty boxes (lower corner above the upper)
    /// are outside. In double precision, so the planes' tolerances hold as they are.
    pub fn boxes_outside(&self, lo: &[[f32; 8]; 3], hi: &[[f32; 8]; 3]) -> u32 {
        // The boxes clipped to the shaft's bounding box: the shaft lies inside it.
        let mut clo = [[0f64; 8]; 3];
        let mut chi = [[0f64; 8]; 3];
        let mut out = [false; 8];
        for a in 0..3 {
            for l in 0..8 {
                clo[a][l] = (lo[a][l] as f64).max(self.lo[a]);
                chi[a][l] = (hi[a][l] as f64).min(self.hi[a]);
                out[l] |= clo[a][l] > chi[a][l];
            }
        }
        for &(m, k, tol) in &self.planes[..2 + self.sides] {
            // Each box's corner least far along m.
            let pick = |a: usize| if m[a] >= 0.0 { &clo[a] } else { &chi[a] };
            let (px, py, pz) = (pick(0), pick(1), pick(2));
            let level = k + tol;
            for l in 0..8 {
                out[l] |= m.x * px[l] + m.y * py[l] + m.z * pz[l] > level;
            }
        }
        out.iter()
            .enumerate()
            .fold(0, |mask, (l, &o)| mask | (u32::from(o) << l))
    }

    /// Whether the triangle `t` lies wholly outside the shaft: beyond one of its planes,
    /// or with the whole shaft strictly on one side of its own plane. False says it may
    /// meet the shaft.
    pub fn triangle_outside(&self, t: &[Vec3A; 3]) -> bool {
        let t = t.map(|p| p.as_dvec3());
        let beyond = self.planes[..2 + self.sides].iter().any(|&(m, k, tol)| {
            let least = m.dot(t[0]).min(m.dot(t[1])).min(m.dot(t[2]));
            least > k + tol
        });
        if beyond {
            return true;
        }
        let nt = (t[1] - t[0]).cross(t[2] - t[0]);
        let len = nt.length();
        if !positive(len) {
            // A degenerate triangle: no ray meets it (the triangle test needs a
            // determinant), but its line may still cross the shaft; the box test and the
            // planes above are all that set it aside.
            return false;
        }
        let nt = nt / len;
        let (mut above, mut below) = (true, true);
        for &p in &self.corners[..2 * self.sides] {
            let s = nt.dot(p - t[0]);
            above &= s > self.tol;
            below &= s < -self.tol;
        }
        above || below
    }
}

/// Whether `v` is above zero (false for NaN).
fn positive(v: f64) -> bool {
    v > 0.0
}

/// Joins triangles (`tris`, with unit front normals `normals`) that share a corner and
/// lie in one plane facing one way into sets, and gives each set the convex hull of its
/// corners in that plane (in order, at most [`MAX_CORNERS`]): a shaft to the hull holds
/// the shaft to each of its triangles, so one test stands for the set's. A set whose
/// hull has more corners is split into its triangles. Returns each triangle's set and
/// each set's hull.
pub fn coplanar_sets(tris: &[[DVec3; 3]], normals: &[DVec3]) -> (Vec<u32>, Vec<Vec<DVec3>>) {
    let count = tris.len();
    let mut parent: Vec<usize> = (0..count).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    // Triangles by corner (exact coordinates), to find those sharing one.
    let mut by_corner: std::collections::HashMap<[u64; 3], Vec<usize>> = Default::default();
    for (i, t) in tris.iter().enumerate() {
        for p in t {
            by_corner
                .entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .or_default()
                .push(i);
        }
    }
    let coplanar = |i: usize, j: usize| {
        let (ni, nj) = (normals[i], normals[j]);
        let size = (tris[i][1] - tris[i][0])
            .length()
            .max((tris[j][1] - tris[j][0]).length());
        ni.dot(nj) > 1.0 - 1e-9
            && tris[j]
                .iter()
                .all(|&p| ni.dot(p - tris[i][0]).abs() <= 1e-9 * (1.0 + size))
    };
    for list in by_corner.values() {
        for (a, &i) in list.iter().enumerate() {
            for &j in &list[a + 1..] {
                if coplanar(i, j) {
                    let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                    parent[ri] = rj;
                }
            }
        }
    }
    let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for i in 0..count {
        members.entry(root(&mut parent, i)).or_default().push(i);
    }
    let mut set = vec![0u32; count];
    let mut hulls = Vec::new();
    for list in members.into_values() {
        let points: Vec<DVec3> = list.iter().flat_map(|&i| tris[i]).collect();
        match hull_in_plane(&points, normals[list[0]]) {
            Some(h) if list.len() > 1 && h.len() <= MAX_CORNERS => {
                for &i in &list {
                    set[i] = hulls.len() as u32;
                }
                hulls.push(h);
            }
            _ => {
                for &i in &list {
                    set[i] = hulls.len() as u32;
                    hulls.push(tris[i].to_vec());
                }
            }
        }
    }
    (set, hulls)
}

/// The convex hull (counter-clockwise about `n`, collinear points dropped) of `points`
/// lying in a plane of unit normal `n`; None with fewer than 3 corners.
fn hull_in_plane(points: &[DVec3], n: DVec3) -> Option<Vec<DVec3>> {
    let (t, b) = crate::geometry::frame(n);
    let mut p: Vec<(f64, f64, DVec3)> = points.iter().map(|&q| (q.dot(t), q.dot(b), q)).collect();
    p.sort_by(|a, c| a.0.total_cmp(&c.0).then(a.1.total_cmp(&c.1)));
    p.dedup_by(|a, c| a.0 == c.0 && a.1 == c.1);
    if p.len() < 3 {
        return None;
    }
    let cross = |o: &(f64, f64, DVec3), a: &(f64, f64, DVec3), c: &(f64, f64, DVec3)| {
        (a.0 - o.0) * (c.1 - o.1) - (a.1 - o.1) * (c.0 - o.0)
    };
    let mut hull: Vec<(f64, f64, DVec3)> = Vec::with_capacity(2 * p.len());
    // Andrew's monotone chain: the lower half left to right, the upper right to left.
    let backwards: Vec<(f64, f64, DVec3)> = p.iter().rev().copied().collect();
    for half in [&p, &backwards] {
        let start = hull.len();
        for q in half {
            while hull.len() >= start + 2
                && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(*q);
        }
        hull.pop();
    }
    (hull.len() >= 3).then(|| hull.into_iter().map(|q| q.2).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray_offset;
    use crate::sampling::{sample_triangle, Rng};

    fn tri(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [DVec3; 3] {
        [a.into(), b.into(), c.into()]
    }

    /// A light 2 m over a floor point: the floor around the point and the ceiling around
    /// the light (flush with it) are set aside; a blocker halfway is not; a blocker beside
    /// the shaft is, by a side plane or by its own plane.
    #[test]
    fn the_receivers_and_emitters_planes_set_aside_what_touches_them() {
        let light = tri([-0.5, 2.0, -0.5], [0.5, 2.0, -0.5], [0.0, 2.0, 0.5]);
        let ne = DVec3::new(0.0, -1.0, 0.0);
        let n = DVec3::Y;
        let lift = 1e-6 * 2.0;
        let o = DVec3::new(0.3, 0.0, 0.1) + n * lift;
        let s = Shaft::new(o, n, lift, &light[..], ne).unwrap();
        let f32t = |t: [DVec3; 3]| t.map(|p| Vec3A::from(p.as_vec3()));
        // The floor, through the point.
        let floor = tri([-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [0.0, 0.0, 5.0]);
        assert!(s.triangle_outside(&f32t(floor)));
        // The ceiling, flush with the light, over it.
        let ceiling = tri([-5.0, 2.0, -5.0], [5.0, 2.0, -5.0], [0.0, 2.0, 5.0]);
        assert!(s.triangle_outside(&f32t(ceiling)));
        // The light itself.
        assert!(s.triangle_outside(&f32t(light)));
        // A small card halfway up, on the line to the light's centroid.
        let g = (light[0] + light[1] + light[2]) / 3.0;
        let mid = (o + g) * 0.5;
        let card = [
            mid + DVec3::new(-0.01, 0.0, -0.01),
            mid + DVec3::new(0.01, 0.0, -0.01),
            mid + DVec3::new(0.0, 0.0, 0.01),
        ];
        assert!(!s.triangle_outside(&f32t(card)));
        // The same card 1 m to the side.
        let aside = card.map(|p| p + DVec3::new(1.5, 0.0, 0.0));
        assert!(s.triangle_outside(&f32t(aside)));
        // A wall 3 m away, beyond the shaft's box and every plane.
        let wall = tri([3.0, 0.0, -5.0], [3.0, 3.0, -5.0], [3.0, 0.0, 5.0]);
        assert!(s.triangle_outside(&f32t(wall)));
        // Boxes: the floor's (flat), the ceiling's, and one around the card.
        let b = |lo: [f32; 3], hi: [f32; 3]| {
            let mut l = [[f32::INFINITY; 8]; 3];
            let mut h = [[f32::NEG_INFINITY; 8]; 3];
            for a in 0..3 {
                l[a][2] = lo[a];
                h[a][2] = hi[a];
            }
            let mask = s.boxes_outside(&l, &h);
            assert_eq!(mask | 4, 0xff, "empty lanes are outside");
            mask & 4 != 0
        };
        assert!(b([-5.0, 0.0, -5.0], [5.0, 0.0, 5.0]));
        assert!(b([-5.0, 2.0, -5.0], [5.0, 2.0, 5.0]));
        assert!(!b([-5.0, 0.9, -5.0], [5.0, 1.1, 5.0]));
        assert!(b([1.5, 0.9, -0.2], [1.7, 1.1, 0.2]));
    }

    /// What the shaft sets aside no shadow ray meets: random triangles near a random
    /// shaft, each set aside one tested against 400 segments from the point to points of
    /// the emitter (as the direct light draws them), trimmed as the rays are.
    #[test]
    fn no_shadow_ray_meets_a_triangle_set_aside() {
        let mut rng = Rng::new(3, 4);
        let mut r = || rng.next_f64();
        let (mut aside, mut kept) = (0, 0);
        for _ in 0..300 {
            let light = tri(
                [r() - 0.5, 2.0 + 0.1 * r(), r() - 0.5],
                [r() - 0.5, 2.0 + 0.1 * r(), r() - 0.5],
                [r() - 0.5, 2.0 + 0.1 * r(), r() - 0.5],
            );
            let mut ne = (light[1] - light[0]).cross(light[2] - light[0]).normalize();
            if ne.y > 0.0 {
                ne = -ne;
            }
            let n = DVec3::Y;
            let x = DVec3::new(2.0 * r() - 1.0, 0.0, 2.0 * r() - 1.0);
            let lift = ray_offset(x);
            let o = x + n * lift;
            let Some(s) = Shaft::new(o, n, lift, &light[..], ne) else {
                continue;
            };
            for _ in 0..20 {
                // About the shaft: a point of it, moved up to 0.3 m.
                let y = sample_triangle(&light, r(), r());
                let centre = o + (y - o) * r() + (DVec3::new(r(), r(), r()) - 0.5) * 0.6;
                let size = 0.3 * r();
                let t = [0, 1, 2].map(|_| {
                    let p = centre + (DVec3::new(r(), r(), r()) - 0.5) * size;
                    Vec3A::from(p.as_vec3())
                });
                if !s.triangle_outside(&t) {
                    kept += 1;
                    continue;
                }
                aside += 1;
                let bvh = crate::geometry::bvh::Bvh::new(&[t]);
                let mut k = Rng::new(5, 6);
                for _ in 0..400 {
                    let y = sample_triangle(&light, k.next_f64(), k.next_f64());
                    let blocked = bvh.occluded(
                        Vec3A::from(o.as_vec3()),
                        Vec3A::from(y.as_vec3()),
                        [u32::MAX, u32::MAX],
                    );
                    assert!(!blocked, "a ray met a triangle the shaft set aside");
                }
            }
        }
        assert!(aside > 1000 && kept > 300, "{aside} set aside, {kept} kept");
    }

    /// On the Cornell box, from random points of its surfaces to its light (one set: the
    /// quad's two triangles): wherever the scene's tree finds the shaft clear, none of
    /// 256 shadow rays to the light is blocked; and the shaft is clear for most points
    /// of the floor and walls but not for those in the blocks' shadows.
    #[test]
    fn a_clear_shaft_in_the_cornell_box_blocks_no_shadow_ray() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box");
        let scene = crate::scene::Scene::load(&dir).unwrap();
        let tris: Vec<[Vec3A; 3]> = scene
            .triangles
            .iter()
            .map(|t| t.p.map(|p| Vec3A::from(p.as_vec3())))
            .collect();
        let bvh = crate::geometry::bvh::Bvh::new(&tris);
        let lights: Vec<[DVec3; 3]> = scene
            .triangles
            .iter()
            .filter(|t| t.group.is_some())
            .map(|t| t.p)
            .collect();
        let normal = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let normals: Vec<DVec3> = lights.iter().map(normal).collect();
        let (set, hulls) = coplanar_sets(&lights, &normals);
        assert_eq!((set, hulls.len(), hulls[0].len()), (vec![0, 0], 1, 4));
        let mut rng = Rng::new(11, 12);
        let (mut clear, mut blocked) = (0, 0);
        for _ in 0..3000 {
            let i = (rng.next_f64() * scene.triangles.len() as f64) as usize;
            let t = &scene.triangles[i];
            if t.group.is_some() {
                continue;
            }
            let x = sample_triangle(&t.p, rng.next_f64(), rng.next_f64());
            let n = normal(&t.p);
            let lift = ray_offset(x);
            let o = x + n * lift;
            let Some(s) = Shaft::new(o, n, lift, &hulls[0], normals[0]) else {
                continue;
            };
            if !bvh.clear_of(&s, [i as u32, u32::MAX]) {
                blocked += 1;
                continue;
            }
            clear += 1;
            for _ in 0..256 {
                let light = &lights[(rng.next_f64() * 2.0) as usize];
                let y = sample_triangle(light, rng.next_f64(), rng.next_f64());
                let hit = bvh.occluded(
                    Vec3A::from(o.as_vec3()),
                    Vec3A::from(y.as_vec3()),
                    [i as u32, u32::MAX],
                );
                assert!(!hit, "a ray from {x} to {y} is blocked");
            }
        }
        assert!(clear > 500 && blocked > 150, "{clear} clear, {blocked} not");
    }

    /// A quad's two triangles make one set with the quad as its hull; a second quad in
    /// the same plane that shares no corner with it makes another; a triangle sharing a
    /// corner but tilted stays alone.
    #[test]
    fn coplanar_sets_join_a_quads_triangles_and_nothing_else() {
        let quad = |x0: f64| {
            [
                tri([x0, 2.0, 0.0], [x0 + 1.0, 2.0, 0.0], [x0 + 1.0, 2.0, 1.0]),
                tri([x0, 2.0, 0.0], [x0 + 1.0, 2.0, 1.0], [x0, 2.0, 1.0]),
            ]
        };
        let mut tris = quad(0.0).to_vec();
        tris.extend(quad(3.0));
        tris.push(tri([0.0, 2.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, -1.0]));
        let normals: Vec<DVec3> = tris
            .iter()
            .map(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize())
            .collect();
        let (set, hulls) = coplanar_sets(&tris, &normals);
        assert_eq!(set[0], set[1]);
        assert_eq!(set[2], set[3]);
        assert!(set[0] != set[2] && set[4] != set[0] && set[4] != set[2]);
        let mut sizes: Vec<usize> = hulls.iter().map(Vec::len).collect();
        sizes.sort();
        assert_eq!(sizes, vec![3, 4, 4]);
        let h = &hulls[set[0] as usize];
        for corner in [
            [0.0, 2.0, 0.0],
            [1.0, 2.0, 0.0],
            [1.0, 2.0, 1.0],
            [0.0, 2.0, 1.0],
        ] {
            assert!(h.contains(&DVec3::from(corner)), "{h:?}");
        }
    }
}
