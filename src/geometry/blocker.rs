//! Geometry: a proof that one wall blocks every segment between two boxes.
//!
//! Rays cannot prove that two clusters do not see each other: a part visible through a
//! door and a window, a fraction of 0.1 % of the point pairs, escapes hundreds of rays. A
//! plane can. When two boxes lie strictly on either side of a plane, every segment
//! between them crosses the plane inside the convex hull Q of the crossings of the 64
//! segments between their corners (the hull of the two boxes meets the plane in Q). When
//! the scene's triangles that lie in that plane cover Q, every segment meets one of them,
//! and no point of one box sees any point of the other.
//!
//! The planes tried are those of the triangles that the segment between the boxes'
//! centres crosses (at most [`MAX_PLANES`]): a wall between two rooms is among them.
//! Coverage is decided by cutting each triangle of the plane out of Q: what is left of Q
//! is kept as convex pieces, and Q is covered when none is left. Triangles that overlap
//! (two-sided exports repeat every triangle) are no problem. The proof is conservative:
//! a triangle off the plane by more than a tolerance (single-precision rounding of the
//! scene's extent) counts for nothing, and past [`MAX_TRIANGLES`] triangles in Q or
//! [`MAX_PIECES`] pieces the answer is "not proven". It never changes what rays would
//! find, only settles what they cannot.

use glam::{DVec2, DVec3, Vec3A};

use super::bvh::Bvh;

/// Most candidate planes tried per pair of boxes.
pub const MAX_PLANES: usize = 6;

/// Most triangles of a plane meeting Q looked at; more leave the pair unproven.
pub const MAX_TRIANGLES: usize = 512;

/// Most convex pieces of Q left uncovered at once; more leave the pair unproven.
pub const MAX_PIECES: usize = 128;

/// A box, `lo..hi`.
pub type Aabb = (DVec3, DVec3);

/// True when some plane of the scene's triangles (`bvh`) lies strictly between the boxes
/// `a` and `b` and its triangles cover every segment from `a` to `b`. False when that is
/// not proven (the boxes may or may not see each other).
pub fn wall_between(bvh: &Bvh, a: Aabb, b: Aabb) -> bool {
    let (ca, cb) = ((a.0 + a.1) * 0.5, (b.0 + b.1) * 0.5);
    let scale = [a.0, a.1, b.0, b.1]
        .iter()
        .fold(0f64, |m, p| m.max(p.abs().max_element()));
    let tol = 1e-5 * (1.0 + scale);
    let mut planes: Vec<(DVec3, f64)> = Vec::with_capacity(MAX_PLANES);
    bvh.each_hit_corners(
        Vec3A::from(ca.as_vec3()),
        Vec3A::from(cb.as_vec3()),
        |tri| {
            if planes.len() >= MAX_PLANES {
                return;
            }
            let [p, q, r] = tri.map(|c| c.as_dvec3());
            let n = (q - p).cross(r - p);
            let len = n.length();
            if len.is_nan() || len <= 0.0 {
                return;
            }
            let n = n / len;
            let d = n.dot(p);
            let same = |&(m, e): &(DVec3, f64)| {
                (m.dot(n).abs() > 1.0 - 1e-9) && (e - d * m.dot(n).signum()).abs() <= tol
            };
            if !planes.iter().any(same) {
                planes.push((n, d));
            }
        },
    );
    planes.iter().any(|&(n, d)| covered(bvh, a, b, n, d, tol))
}

/// The 8 corners of a box.
fn corners((lo, hi): Aabb) -> [DVec3; 8] {
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// A plane `n·x = d` with a basis `u`, `v` for its own 2-D coordinates.
struct Plane {
    n: DVec3,
    d: f64,
    u: DVec3,
    v: DVec3,
}

impl Plane {
    fn new(n: DVec3, d: f64) -> Plane {
        let u = n.any_orthonormal_vector();
        Plane {
            n,
            d,
            u,
            v: n.cross(u),
        }
    }

    fn height(&self, p: DVec3) -> f64 {
        self.n.dot(p) - self.d
    }

    fn flat(&self, p: DVec3) -> DVec2 {
        DVec2::new(self.u.dot(p), self.v.dot(p))
    }
}

/// Whether the plane `n·x = d` separates `a` from `b` by more than `tol` and its triangles
/// cover every segment between them.
fn covered(bvh: &Bvh, a: Aabb, b: Aabb, n: DVec3, d: f64, tol: f64) -> bool {
    let plane = Plane::new(n, d);
    let Some((crossings, lo, hi)) = crossings(&plane, a, b, tol) else {
        return false;
    };
    let pad = DVec3::splat(2.0 * tol);
    let Some(tris) = plane_triangles(bvh, &plane, (lo - pad, hi + pad), tol) else {
        return false;
    };
    let hull = convex_hull(crossings);
    let whole = area(&hull);
    if whole.is_nan() || whole <= 0.0 {
        // The boxes are points or segments seen edge-on: nothing to prove it with.
        return false;
    }
    cut_out(hull, whole, &tris)
}

/// Where the 64 segments between the corners of `a` and `b` cross `plane` (in its 2-D
/// coordinates), and the crossings' bounding box; None unless the plane separates the
/// boxes by more than `tol`.
fn crossings(plane: &Plane, a: Aabb, b: Aabb, tol: f64) -> Option<(Vec<DVec2>, DVec3, DVec3)> {
    let (ka, kb) = (corners(a), corners(b));
    let ha = ka.map(|p| plane.height(p));
    let hb = kb.map(|p| plane.height(p));
    let above = |h: &[f64; 8]| h.iter().all(|&x| x > tol);
    let below = |h: &[f64; 8]| h.iter().all(|&x| x < -tol);
    if !((above(&ha) && below(&hb)) || (below(&ha) && above(&hb))) {
        return None;
    }
    let mut crossings = Vec::with_capacity(64);
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (p, hp) in ka.iter().zip(ha) {
        for (q, hq) in kb.iter().zip(hb) {
            let x = *p + (*q - *p) * (hp / (hp - hq));
            lo = lo.min(x);
            hi = hi.max(x);
            crossings.push(plane.flat(x));
        }
    }
    Some((crossings, lo, hi))
}

/// The scene's triangles within `tol` of `plane` whose boxes overlap `(lo, hi)`, in the
/// plane's coordinates and counter-clockwise; None for none, or more than
/// [`MAX_TRIANGLES`].
fn plane_triangles(bvh: &Bvh, plane: &Plane, (lo, hi): Aabb, tol: f64) -> Option<Vec<[DVec2; 3]>> {
    let mut tris: Vec<[DVec2; 3]> = Vec::new();
    let mut too_many = false;
    bvh.overlapping_corners(
        Vec3A::from(lo.as_vec3()),
        Vec3A::from(hi.as_vec3()),
        |tri| {
            if too_many {
                return;
            }
            let t = tri.map(|c| c.as_dvec3());
            if t.iter().all(|&p| plane.height(p).abs() <= tol) {
                if tris.len() >= MAX_TRIANGLES {
                    too_many = true;
                    return;
                }
                let mut f = t.map(|p| plane.flat(p));
                let twice = (f[1] - f[0]).perp_dot(f[2] - f[0]);
                if twice < 0.0 {
                    f.swap(1, 2);
                }
                if twice != 0.0 {
                    tris.push(f);
                }
            }
        },
    );
    (!too_many && !tris.is_empty()).then_some(tris)
}

/// Whether the triangles `tris` (counter-clockwise) cover the convex polygon `hull` of
/// area `whole`: each is cut out of what is left, as convex pieces. False past
/// [`MAX_PIECES`] pieces.
fn cut_out(hull: Vec<DVec2>, whole: f64, tris: &[[DVec2; 3]]) -> bool {
    // Triangles of less area than the hull cannot cover it.
    let total: f64 = tris
        .iter()
        .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]))
        .sum();
    if total < whole * (1.0 - 1e-9) {
        return false;
    }
    let least = 1e-9 * whole;
    let mut left = vec![hull];
    for t in tris {
        let mut next = Vec::with_capacity(left.len());
        for piece in left {
            cut(piece, t, least, &mut next);
        }
        if next.is_empty() {
            return true;
        }
        if next.len() > MAX_PIECES {
            return false;
        }
        left = next;
    }
    false
}

/// Appends to `out` the convex pieces of `piece` outside the triangle `t` (counter-
/// clockwise), leaving out pieces smaller than `least`.
fn cut(piece: Vec<DVec2>, t: &[DVec2; 3], least: f64, out: &mut Vec<Vec<DVec2>>) {
    let (plo, phi) = bounds(&piece);
    let (tlo, thi) = bounds(t);
    if plo.x > thi.x || plo.y > thi.y || tlo.x > phi.x || tlo.y > phi.y {
        out.push(piece);
        return;
    }
    let mut rest = piece;
    for k in 0..3 {
        let (p, q) = (t[k], t[(k + 1) % 3]);
        // Inside the triangle: left of each edge.
        let side = |x: DVec2| (q - p).perp_dot(x - p);
        let outside = clip(&rest, |x| -side(x));
        if area(&outside) > least {
            out.push(outside);
        }
        rest = clip(&rest, side);
        if area(&rest) <= least {
            return;
        }
    }
}

/// The part of the convex polygon `poly` where `f ≥ 0` (`f` affine).
fn clip(poly: &[DVec2], f: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (fa, fb) = (f(a), f(b));
        if fa >= 0.0 {
            out.push(a);
        }
        if (fa >= 0.0) != (fb >= 0.0) {
            out.push(a + (b - a) * (fa / (fa - fb)));
        }
    }
    out
}

fn bounds(poly: &[DVec2]) -> (DVec2, DVec2) {
    poly.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    )
}

/// The area of a simple polygon (positive counter-clockwise).
fn area(poly: &[DVec2]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for (i, &a) in poly.iter().enumerate() {
        s += a.perp_dot(poly[(i + 1) % poly.len()]);
    }
    0.5 * s
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn convex_hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_unstable_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let turn = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let it: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in it {
            while hull.len() >= start + 2
                && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(c: [[f32; 3]; 4]) -> [[Vec3A; 3]; 2] {
        let v = c.map(Vec3A::from);
        [[v[0], v[1], v[2]], [v[0], v[2], v[3]]]
    }

    /// A wall in the plane x = 0, 10 × 3 m, with a 1 m door at 4 ≤ z ≤ 5 (y < 2).
    fn wall_with_door() -> Vec<[Vec3A; 3]> {
        let mut t = Vec::new();
        t.extend(quad([
            [0., 0., 0.],
            [0., 3., 0.],
            [0., 3., 4.],
            [0., 0., 4.],
        ]));
        t.extend(quad([
            [0., 0., 5.],
            [0., 3., 5.],
            [0., 3., 10.],
            [0., 0., 10.],
        ]));
        t.extend(quad([
            [0., 2., 4.],
            [0., 3., 4.],
            [0., 3., 5.],
            [0., 2., 5.],
        ]));
        t
    }

    fn bx(lo: [f64; 3], hi: [f64; 3]) -> Aabb {
        (DVec3::from(lo), DVec3::from(hi))
    }

    /// Boxes on either side of a solid part of the wall are proven blind to each other;
    /// boxes whose segments may pass the door are not; nor are boxes on one side.
    #[test]
    fn a_wall_proves_what_it_blocks_and_a_door_does_not() {
        let bvh = Bvh::new(&wall_with_door());
        // Both near z = 1.5, well clear of the door.
        let a = bx([-2.0, 0.5, 1.0], [-1.0, 1.5, 2.0]);
        let b = bx([1.0, 0.5, 1.0], [2.0, 1.5, 2.0]);
        assert!(wall_between(&bvh, a, b));
        assert!(wall_between(&bvh, b, a));
        // Facing each other through the door.
        let a = bx([-2.0, 0.5, 4.2], [-1.0, 1.5, 4.8]);
        let b = bx([1.0, 0.5, 4.2], [2.0, 1.5, 4.8]);
        assert!(!wall_between(&bvh, a, b));
        // The shaft grazes the door: a segment from a's far corner passes it.
        let a = bx([-2.0, 0.5, 1.0], [-1.0, 1.5, 3.5]);
        let b = bx([5.0, 0.5, 8.0], [6.0, 1.5, 9.0]);
        assert!(!wall_between(&bvh, a, b));
        // The same with b lower: every segment stays below the door's side (z < 4).
        let b = bx([5.0, 0.5, 3.0], [6.0, 1.5, 4.0]);
        assert!(wall_between(&bvh, a, b));
        // Beyond the wall's end (z > 10): nothing blocks.
        let a = bx([-1.0, 0.5, 11.0], [-0.5, 1.0, 12.0]);
        let b = bx([0.5, 0.5, 11.0], [1.0, 1.0, 12.0]);
        assert!(!wall_between(&bvh, a, b));
        // Both on one side.
        let a = bx([-3.0, 0.5, 1.0], [-2.0, 1.5, 2.0]);
        let b = bx([-1.5, 0.5, 1.0], [-1.0, 1.5, 2.0]);
        assert!(!wall_between(&bvh, a, b));
    }

    /// Every triangle given twice (a two-sided export) and a wall cut into many strips
    /// still cover; a crack between two strips does not.
    #[test]
    fn repeated_and_split_triangles_cover_and_a_crack_does_not() {
        let mut tris = Vec::new();
        for k in 0..10 {
            let (z0, z1) = (k as f32, k as f32 + 1.0);
            let q = quad([[0., 0., z0], [0., 3., z0], [0., 3., z1], [0., 0., z1]]);
            tris.extend(q);
            // The same strip again, wound the other way.
            tris.extend(q.map(|[a, b, c]| [a, c, b]));
        }
        let bvh = Bvh::new(&tris);
        let a = bx([-3.0, 0.5, 2.0], [-1.0, 2.5, 6.0]);
        let b = bx([1.0, 0.5, 3.0], [4.0, 2.5, 8.0]);
        assert!(wall_between(&bvh, a, b));
        // A 1 cm crack at z = 5.
        let mut cracked = Vec::new();
        for k in 0..10 {
            let (z0, z1) = (k as f32, if k == 4 { 4.99 } else { k as f32 + 1.0 });
            cracked.extend(quad([
                [0., 0., z0],
                [0., 3., z0],
                [0., 3., z1],
                [0., 0., z1],
            ]));
        }
        let bvh = Bvh::new(&cracked);
        assert!(!wall_between(&bvh, a, b));
    }

    #[test]
    fn the_hull_of_a_square_and_its_inside_points_is_the_square() {
        let pts = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.5, 0.5),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.2, 0.7),
        ];
        let h = convex_hull(pts);
        assert_eq!(h.len(), 4);
        assert!((area(&h) - 1.0).abs() < 1e-12);
    }
}
