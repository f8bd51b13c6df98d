//! Geometry: a bounding volume hierarchy (binned SAH) over the scene triangles, for
//! visibility (any-hit segment) queries.
//!
//! Occlusion is geometric: a triangle blocks light from either side, even though it only
//! emits, reflects and receives on its front. Queries skip the triangles a segment
//! starts and ends on, so a ray leaving a surface never counts that surface as a blocker,
//! and endpoints are pulled in by a relative epsilon so that rays grazing a neighbouring
//! coplanar triangle are not blocked.

use glam::Vec3A;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3A,
    hi: Vec3A,
    /// Leaf: first triangle; inner: index of the left child (right = left + 1).
    first: u32,
    /// Triangles in a leaf; 0 for inner nodes.
    count: u32,
}

#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

/// A BVH over triangles given as corner triples.
pub struct Bvh {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
    /// Caller's index of each stored triangle.
    ids: Vec<u32>,
}

const LEAF_MAX: usize = 4;
const BINS: usize = 12;

impl Bvh {
    /// Builds the hierarchy. `tris[i]` keeps the id `i` in queries.
    pub fn new(tris: &[[Vec3A; 3]]) -> Bvh {
        let mut ids: Vec<u32> = (0..tris.len() as u32).collect();
        let cent: Vec<Vec3A> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let lo: Vec<Vec3A> = tris.iter().map(|t| t[0].min(t[1]).min(t[2])).collect();
        let hi: Vec<Vec3A> = tris.iter().map(|t| t[0].max(t[1]).max(t[2])).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len().max(1));
        nodes.push(Node {
            lo: Vec3A::ZERO,
            hi: Vec3A::ZERO,
            first: 0,
            count: 0,
        });
        if !tris.is_empty() {
            build(&mut nodes, 0, &mut ids, 0, &cent, &lo, &hi);
        }
        let stored = ids
            .iter()
            .map(|&i| {
                let t = tris[i as usize];
                Tri {
                    v0: t[0],
                    e1: t[1] - t[0],
                    e2: t[2] - t[0],
                }
            })
            .collect();
        Bvh {
            nodes,
            tris: stored,
            ids,
        }
    }

    /// True when some triangle other than `skip` blocks the open segment `from → to`.
    /// The segment's ends are trimmed by `1e-5` of its length.
    pub fn occluded(&self, from: Vec3A, to: Vec3A, skip: [u32; 2]) -> bool {
        self.along(from, to, |k, tri, d, (tmin, tmax)| {
            let id = self.ids[k];
            id != skip[0] && id != skip[1] && hit(tri, from, d, tmin, tmax)
        })
    }

    /// Calls `f` with the id of every triangle the open segment `from → to` crosses, and
    /// where (the parameter along the segment, 0..1; ends trimmed as in
    /// [`Bvh::occluded`]). A segment through an edge shared by two triangles meets both.
    pub fn each_hit(&self, from: Vec3A, to: Vec3A, mut f: impl FnMut(u32, f32)) {
        self.along(from, to, |k, tri, d, (tmin, tmax)| {
            if let Some(t) = hit_t(tri, from, d, tmin, tmax) {
                f(self.ids[k], t);
            }
            false
        });
    }

    /// Visits the stored triangles in the leaves the segment `from → to` (ends trimmed by
    /// `1e-5` of its length) passes through, as `visit(index, triangle, direction,
    /// (tmin, tmax))`, until `visit` returns true; whether it did.
    #[inline(always)]
    fn along(
        &self,
        from: Vec3A,
        to: Vec3A,
        mut visit: impl FnMut(usize, &Tri, Vec3A, (f32, f32)) -> bool,
    ) -> bool {
        let d = to - from;
        let (tmin, tmax) = (1e-5f32, 1.0 - 1e-5f32);
        self.traverse_ray(
            from,
            d.recip(),
            tmin,
            || tmax,
            |k| visit(k, &self.tris[k], d, (tmin, tmax)),
        )
    }

    /// Depth first through the nodes whose box the ray `o + t·d` (`inv` = 1/d) enters
    /// within `(tmin, far())`, the nearer child first, calling `visit` with the index of
    /// every stored triangle in the leaves reached, until it returns true; whether it did.
    /// `far` may shrink as triangles are visited (a nearest-hit query): boxes entered past
    /// it are skipped.
    #[inline(always)]
    fn traverse_ray(
        &self,
        o: Vec3A,
        inv: Vec3A,
        tmin: f32,
        far: impl Fn() -> f32,
        mut visit: impl FnMut(usize) -> bool,
    ) -> bool {
        let Some(root) = self.nodes.first().filter(|_| !self.tris.is_empty()) else {
            return false;
        };
        if slab_t(root.lo, root.hi, o, inv, tmin, far()).is_none() {
            return false;
        }
        // Pending far children and where the ray enters them.
        let mut stack = [(0u32, 0f32); 64];
        let mut spill: Vec<(u32, f32)> = Vec::new();
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                for k in n.first..n.first + n.count {
                    if visit(k as usize) {
                        return true;
                    }
                }
            } else {
                let (a, b) = (n.first, n.first + 1);
                let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
                let f = far();
                let ta = slab_t(na.lo, na.hi, o, inv, tmin, f);
                let tb = slab_t(nb.lo, nb.hi, o, inv, tmin, f);
                match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let ((near, _), later) = if ta <= tb {
                            ((a, ta), (b, tb))
                        } else {
                            ((b, tb), (a, ta))
                        };
                        // A tree deeper than the stack (a very skewed scene) spills
                        // over into the heap rather than losing a subtree.
                        if sp < stack.len() {
                            stack[sp] = later;
                            sp += 1;
                        } else {
                            spill.push(later);
                        }
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            loop {
                let (next, enter) = if let Some(top) = spill.pop() {
                    top
                } else if sp > 0 {
                    sp -= 1;
                    stack[sp]
                } else {
                    return false;
                };
                if enter <= far() * 1.000_001 {
                    node = next;
                    break;
                }
            }
        }
    }

    /// Depth first through the nodes whose box passes `enter`, calling `visit` with the
    /// index of every stored triangle in the leaves reached, until it returns true;
    /// whether it did.
    #[inline(always)]
    fn traverse(
        &self,
        mut enter: impl FnMut(&Node) -> bool,
        mut visit: impl FnMut(usize) -> bool,
    ) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let mut stack = [0u32; 64];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            if enter(n) {
                if n.count > 0 {
                    for k in n.first..n.first + n.count {
                        if visit(k as usize) {
                            return true;
                        }
                    }
                } else {
                    if sp < stack.len() {
                        stack[sp] = n.first + 1;
                        sp += 1;
                    }
                    node = n.first;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack[sp];
        }
    }

    /// Appends to `out` the id of every triangle whose bounding box overlaps the box
    /// `lo..hi` (boxes touching at a face count).
    pub fn overlapping(&self, lo: Vec3A, hi: Vec3A, out: &mut Vec<u32>) {
        self.traverse(
            |n| n.lo.cmple(hi).all() && lo.cmple(n.hi).all(),
            |k| {
                let t = &self.tris[k];
                let (a, b, c) = (t.v0, t.v0 + t.e1, t.v0 + t.e2);
                if a.min(b).min(c).cmple(hi).all() && lo.cmple(a.max(b).max(c)).all() {
                    out.push(self.ids[k]);
                }
                false
            },
        );
    }

    /// Distance parameter of the nearest hit along `from + t·d`, t in (tmin, tmax), with
    /// the id of the triangle hit.
    pub fn nearest(&self, from: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        let inv = d.recip();
        let mut best: Option<(f32, u32)> = None;
        // The far end shrinks to each hit; the box test sees it.
        let tmax = std::cell::Cell::new(tmax);
        self.traverse_ray(
            from,
            inv,
            tmin,
            || tmax.get(),
            |k| {
                if let Some(t) = hit_t(&self.tris[k], from, d, tmin, tmax.get()) {
                    tmax.set(t);
                    best = Some((t, self.ids[k]));
                }
                false
            },
        );
        best
    }

    /// As [`Bvh::nearest`], with each triangle ranked by `rank(id)`: triangles of rank 0
    /// are passed through, and of triangles hit at the same distance (within a relative
    /// `1e-5`: the two faces of a two-sided surface) the higher rank wins.
    pub fn nearest_ranked(
        &self,
        from: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        rank: impl Fn(u32) -> u8,
    ) -> Option<(f32, u32)> {
        const TIE: f32 = 1e-5;
        let inv = d.recip();
        let mut best: Option<(f32, u32, u8)> = None;
        let far = std::cell::Cell::new(tmax);
        self.traverse_ray(
            from,
            inv,
            tmin,
            || far.get() * (1.0 + TIE),
            |k| {
                let limit = (far.get() * (1.0 + TIE)).min(tmax);
                let Some(t) = hit_t(&self.tris[k], from, d, tmin, limit) else {
                    return false;
                };
                let id = self.ids[k];
                let r = rank(id);
                if r == 0 {
                    return false;
                }
                let take = match best {
                    None => true,
                    Some((bt, _, _)) if t < bt * (1.0 - TIE) => true,
                    // A tie: the higher rank wins, then the nearer.
                    Some((bt, _, br)) => r > br || (r == br && t < bt),
                };
                if take {
                    best = Some((t, id, r));
                    far.set(far.get().min(t));
                }
                false
            },
        );
        best.map(|(t, id, _)| (t, id))
    }
}

/// Where the ray `o + t·d` (`inv` = 1/d) enters the box `lo..hi` within `(tmin, tmax)`,
/// if it meets it there.
#[inline]
fn slab_t(lo: Vec3A, hi: Vec3A, o: Vec3A, inv: Vec3A, tmin: f32, tmax: f32) -> Option<f32> {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    // NaN (0·inf on an axis-parallel ray in a box face) drops out of min/max.
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element().min(tmax);
    (near <= far * 1.000_001).then_some(near)
}

#[inline]
fn hit_t(t: &Tri, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<f32> {
    let p = d.cross(t.e2);
    let det = t.e1.dot(p);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - t.v0;
    let u = s.dot(p) * inv;
    const E: f32 = 1e-6;
    if !(-E..=1.0 + E).contains(&u) {
        return None;
    }
    let q = s.cross(t.e1);
    let v = d.dot(q) * inv;
    if v < -E || u + v > 1.0 + E {
        return None;
    }
    let tt = t.e2.dot(q) * inv;
    (tt > tmin && tt < tmax).then_some(tt)
}

#[inline]
fn hit(t: &Tri, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> bool {
    hit_t(t, o, d, tmin, tmax).is_some()
}

fn build(
    nodes: &mut Vec<Node>,
    at: usize,
    ids: &mut [u32],
    first: u32,
    cent: &[Vec3A],
    lo: &[Vec3A],
    hi: &[Vec3A],
) {
    let mut blo = Vec3A::splat(f32::INFINITY);
    let mut bhi = Vec3A::splat(f32::NEG_INFINITY);
    let mut clo = blo;
    let mut chi = bhi;
    for &i in ids.iter() {
        blo = blo.min(lo[i as usize]);
        bhi = bhi.max(hi[i as usize]);
        clo = clo.min(cent[i as usize]);
        chi = chi.max(cent[i as usize]);
    }
    nodes[at].lo = blo;
    nodes[at].hi = bhi;
    let leaf = |nodes: &mut Vec<Node>| {
        nodes[at].first = first;
        nodes[at].count = ids.len() as u32;
    };
    if ids.len() <= LEAF_MAX {
        return leaf(nodes);
    }
    // Binned SAH over the widest centroid axis.
    let ext = chi - clo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    if ext[axis] <= 0.0 {
        return leaf(nodes);
    }
    let scale = BINS as f32 / ext[axis];
    let bin_of = |i: u32| (((cent[i as usize][axis] - clo[axis]) * scale) as usize).min(BINS - 1);
    let best = best_split(ids, &bin_of, lo, hi);
    if best.0 >= ids.len() as f32 * half_area(blo, bhi) && ids.len() <= 16 {
        return leaf(nodes);
    }
    let mid = if best.1 == 0 {
        ids.len() / 2
    } else {
        let mut m = 0;
        for k in 0..ids.len() {
            if bin_of(ids[k]) < best.1 {
                ids.swap(k, m);
                m += 1;
            }
        }
        m
    };
    let mid = if mid == 0 || mid == ids.len() {
        ids.len() / 2
    } else {
        mid
    };
    let left = nodes.len();
    nodes[at].first = left as u32;
    nodes[at].count = 0;
    let blank = Node {
        lo: Vec3A::ZERO,
        hi: Vec3A::ZERO,
        first: 0,
        count: 0,
    };
    nodes.push(blank);
    nodes.push(blank);
    let (l, r) = ids.split_at_mut(mid);
    build(nodes, left, l, first, cent, lo, hi);
    build(nodes, left + 1, r, first + mid as u32, cent, lo, hi);
}

/// Half the surface area of a box (the SAH's measure).
fn half_area(l: Vec3A, h: Vec3A) -> f32 {
    let e = (h - l).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The cheapest split by the surface-area heuristic over `BINS` bins: (cost, first bin
/// of the right side); (∞, 0) when no split leaves both sides non-empty.
fn best_split(
    ids: &[u32],
    bin_of: &impl Fn(u32) -> usize,
    lo: &[Vec3A],
    hi: &[Vec3A],
) -> (f32, usize) {
    let mut bcount = [0usize; BINS];
    let mut blo_b = [Vec3A::splat(f32::INFINITY); BINS];
    let mut bhi_b = [Vec3A::splat(f32::NEG_INFINITY); BINS];
    for &i in ids.iter() {
        let b = bin_of(i);
        bcount[b] += 1;
        blo_b[b] = blo_b[b].min(lo[i as usize]);
        bhi_b[b] = bhi_b[b].max(hi[i as usize]);
    }
    let mut best = (f32::INFINITY, 0usize);
    for split in 1..BINS {
        let (mut ln, mut rn) = (0usize, 0usize);
        let (mut l0, mut l1) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        let (mut r0, mut r1) = (l0, l1);
        for b in 0..split {
            ln += bcount[b];
            l0 = l0.min(blo_b[b]);
            l1 = l1.max(bhi_b[b]);
        }
        for b in split..BINS {
            rn += bcount[b];
            r0 = r0.min(blo_b[b]);
            r1 = r1.max(bhi_b[b]);
        }
        if ln == 0 || rn == 0 {
            continue;
        }
        let cost = ln as f32 * half_area(l0, l1) + rn as f32 * half_area(r0, r1);
        if cost < best.0 {
            best = (cost, split);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(y: f32, id_base: usize) -> Vec<[Vec3A; 3]> {
        let _ = id_base;
        let a = Vec3A::new(-1.0, y, -1.0);
        let b = Vec3A::new(1.0, y, -1.0);
        let c = Vec3A::new(1.0, y, 1.0);
        let d = Vec3A::new(-1.0, y, 1.0);
        vec![[a, b, c], [a, c, d]]
    }

    #[test]
    fn blocks_and_skips() {
        let mut tris = quad(0.0, 0);
        tris.extend(quad(1.0, 2));
        // Many small far triangles so the tree has depth.
        for k in 0..200 {
            let x = 10.0 + k as f32;
            tris.push([
                Vec3A::new(x, 0.0, 0.0),
                Vec3A::new(x + 0.5, 0.0, 0.0),
                Vec3A::new(x, 0.5, 0.0),
            ]);
        }
        let bvh = Bvh::new(&tris);
        let from = Vec3A::new(0.1, -1.0, 0.2);
        let to = Vec3A::new(0.0, 2.0, 0.0);
        assert!(bvh.occluded(from, to, [u32::MAX; 2]));
        // Endpoint on the lower quad: that quad is skipped, the upper one still blocks.
        let on_floor = Vec3A::new(0.3, 0.0, 0.3);
        assert!(bvh.occluded(on_floor, to, [0, 1]));
        // Between the two quads nothing blocks.
        assert!(!bvh.occluded(on_floor, Vec3A::new(-0.2, 0.9, 0.1), [0, 1]));
        // A segment lying in the plane of the lower quad (grazing) is not blocked by it.
        assert!(!bvh.occluded(
            Vec3A::new(-0.5, 0.0, 0.5),
            Vec3A::new(0.5, 0.0, -0.5),
            [u32::MAX; 2]
        ));
        let (t, id) = bvh
            .nearest(from, Vec3A::new(0.0, 1.0, 0.0), 0.0, 10.0)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-5 && id < 2);
    }

    /// The nearest hit of the ordered walk (nearer child first, boxes past the current
    /// hit skipped) is the nearest of all the triangles, by brute force.
    #[test]
    fn nearest_is_the_brute_force_nearest() {
        let mut seed = 7u64;
        let mut r = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut tris = Vec::new();
        for _ in 0..500 {
            let c = Vec3A::new(r(), r(), r()) * 10.0;
            let e = |r: &mut dyn FnMut() -> f32| Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * 4.0;
            tris.push([c, c + e(&mut r), c + e(&mut r)]);
        }
        let bvh = Bvh::new(&tris);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3A::new(r(), r(), r()) * 10.0;
            let d = Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    let tri = Tri {
                        v0: t[0],
                        e1: t[1] - t[0],
                        e2: t[2] - t[0],
                    };
                    hit_t(&tri, o, d, 0.0, f32::INFINITY).map(|t| (t, i as u32))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let got = bvh.nearest(o, d, 0.0, f32::INFINITY);
            assert_eq!(
                got.map(|g| g.1),
                brute.map(|b| b.1),
                "ray from {o} along {d}"
            );
            hits += usize::from(got.is_some());
        }
        // Most rays meet something, so the check is not vacuous.
        assert!(hits > 1000, "{hits} hits");
    }
}
