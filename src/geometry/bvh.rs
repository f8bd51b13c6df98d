//! Geometry: a bounding volume hierarchy over the scene triangles, for visibility (any-hit
//! segment) and nearest-hit queries.
//!
//! The tree is built binary (binned SAH over all three axes) and then collapsed into
//! 8-wide nodes whose children's boxes sit in structure-of-arrays lanes, so one step of a
//! walk tests a ray against 8 boxes at once (AVX where the build targets it, see
//! `.cargo/config.toml`; the same arithmetic lane by lane elsewhere). Walks visit the
//! children a ray enters nearest first and skip the boxes it enters past the hit found
//! so far.
//!
//! Occlusion is geometric: a triangle blocks light from either side, even though it only
//! emits, reflects and receives on its front. Queries skip the triangles a segment
//! starts and ends on, so a ray leaving a surface never counts that surface as a blocker,
//! and endpoints are pulled in by a relative epsilon so that rays grazing a neighbouring
//! coplanar triangle are not blocked.

use glam::Vec3A;

/// A node of the binary tree the build makes before it is collapsed.
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3A,
    hi: Vec3A,
    /// Leaf: first triangle; inner: index of the left child (right = left + 1).
    first: u32,
    /// Triangles in a leaf; 0 for inner nodes.
    count: u32,
}

/// Children per node of the collapsed tree.
const WIDTH: usize = 8;

/// A node of the collapsed tree: up to 8 children, their boxes lane by lane.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Wide {
    /// Lower corners, by axis then lane.
    lo: [[f32; WIDTH]; 3],
    /// Upper corners, by axis then lane.
    hi: [[f32; WIDTH]; 3],
    /// Per lane, a [`Child`] code: an inner node's index, or a leaf's triangles.
    child: [u32; WIDTH],
    /// Lanes in use (the first `lanes`); the others hold empty boxes.
    lanes: u32,
}

/// A child code of a [`Wide`] node: the top bit marks a leaf, whose next 4 bits hold its
/// triangle count less one and whose low 27 bits its first [`Tri4`] block. A leaf's
/// triangles fill consecutive blocks, the last one padded.
struct Child;

impl Child {
    const LEAF: u32 = 1 << 31;
    const FIRST_BITS: u32 = 27;
    /// Triangles a leaf may hold.
    const MAX_COUNT: u32 = 16;
    /// Triangles a tree may hold (a leaf's first block must fit its 27 bits).
    const MAX_TRIANGLES: usize = 1 << Self::FIRST_BITS;

    fn leaf(first: u32, count: u32) -> u32 {
        debug_assert!((1..=Self::MAX_COUNT).contains(&count));
        Self::LEAF | ((count - 1) << Self::FIRST_BITS) | first
    }

    /// A leaf code's first block and triangle count, or None for an inner node's.
    #[inline(always)]
    fn triangles(code: u32) -> Option<(usize, usize)> {
        (code & Self::LEAF != 0).then(|| {
            let first = (code & ((1 << Self::FIRST_BITS) - 1)) as usize;
            let count = ((code >> Self::FIRST_BITS) & 0xf) as usize + 1;
            (first, count)
        })
    }
}

/// Four triangles, lane by lane: a corner and the two edges from it, by axis. Padding
/// lanes hold a degenerate triangle, which no ray meets.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
struct Tri4 {
    v0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
}

impl Tri4 {
    fn set(&mut self, lane: usize, t: &[Vec3A; 3]) {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        for a in 0..3 {
            self.v0[a][lane] = t[0][a];
            self.e1[a][lane] = e1[a];
            self.e2[a][lane] = e2[a];
        }
    }

    /// The corners of the triangle in `lane` (as stored: the first corner plus edges).
    fn corners(&self, lane: usize) -> [Vec3A; 3] {
        let get = |m: &[[f32; 4]; 3]| Vec3A::new(m[0][lane], m[1][lane], m[2][lane]);
        let v0 = get(&self.v0);
        [v0, v0 + get(&self.e1), v0 + get(&self.e2)]
    }
}

/// A BVH over triangles given as corner triples.
pub struct Bvh {
    /// The collapsed tree; the root is the first node (none without triangles).
    nodes: Vec<Wide>,
    /// The leaves' triangles, four to a block.
    blocks: Vec<Tri4>,
    /// Caller's index of each stored triangle (block · 4 + lane); `u32::MAX` on padding.
    ids: Vec<u32>,
}

/// Triangles per leaf the build aims for.
const LEAF_MAX: usize = 4;
const BINS: usize = 16;
/// Entries of a walk's stack kept on the thread's stack; deeper trees spill to the heap.
const STACK: usize = 256;

/// A ray prepared for the box tests: origin and reciprocal direction by axis, lane-wide.
#[derive(Clone, Copy)]
struct Ray8 {
    o: [f32; 3],
    inv: [f32; 3],
}

impl Ray8 {
    fn new(o: Vec3A, inv: Vec3A) -> Ray8 {
        Ray8 {
            o: o.to_array(),
            inv: inv.to_array(),
        }
    }
}

/// Where the ray enters each of a node's boxes within `(tmin, tmax)`, and the mask of
/// lanes it meets. On an axis the ray is parallel to (`inv` infinite), a box face through
/// the origin makes a NaN that the comparisons treat as a miss on that lane, as the
/// lane-by-lane version does.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
#[inline(always)]
fn enter8(n: &Wide, r: &Ray8, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::*;
    // SAFETY: AVX is enabled for this build (cfg above); the loads read 8 f32 from
    // arrays of 8 f32, and `Wide` is 64-byte aligned, so every row is 32-byte aligned.
    unsafe {
        let mut near = _mm256_set1_ps(tmin);
        let mut far = _mm256_set1_ps(tmax);
        for a in 0..3 {
            let o = _mm256_set1_ps(r.o[a]);
            let inv = _mm256_set1_ps(r.inv[a]);
            let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.lo[a].as_ptr()), o), inv);
            let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.hi[a].as_ptr()), o), inv);
            near = _mm256_max_ps(near, _mm256_min_ps(t0, t1));
            far = _mm256_min_ps(far, _mm256_max_ps(t0, t1));
        }
        let far = _mm256_mul_ps(far, _mm256_set1_ps(1.000_001));
        let hit = _mm256_movemask_ps(_mm256_cmp_ps(near, far, _CMP_LE_OQ)) as u32;
        let mut t = [0f32; WIDTH];
        _mm256_storeu_ps(t.as_mut_ptr(), near);
        (hit & ((1u32 << n.lanes) - 1), t)
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
#[inline(always)]
fn enter8(n: &Wide, r: &Ray8, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
    enter8_lanes(n, r, tmin, tmax)
}

/// [`enter8`] lane by lane, with the same operations in the same order (x86's `min` and
/// `max` return their second operand when either is NaN).
#[cfg_attr(all(target_arch = "x86_64", target_feature = "avx"), allow(dead_code))]
#[inline(always)]
fn enter8_lanes(n: &Wide, r: &Ray8, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let mut t = [0f32; WIDTH];
    let mut hit = 0u32;
    for (lane, t) in t.iter_mut().enumerate() {
        let (mut near, mut far) = (tmin, tmax);
        for a in 0..3 {
            let t0 = (n.lo[a][lane] - r.o[a]) * r.inv[a];
            let t1 = (n.hi[a][lane] - r.o[a]) * r.inv[a];
            near = max(near, min(t0, t1));
            far = min(far, max(t0, t1));
        }
        far *= 1.000_001;
        *t = near;
        if near <= far {
            hit |= 1 << lane;
        }
    }
    (hit & ((1u32 << n.lanes) - 1), t)
}

impl Bvh {
    /// Builds the hierarchy. `tris[i]` keeps the id `i` in queries.
    ///
    /// # Panics
    /// With more than 2²⁷ (134 million) triangles; scenes are limited far below that.
    pub fn new(tris: &[[Vec3A; 3]]) -> Bvh {
        assert!(
            tris.len() <= Child::MAX_TRIANGLES,
            "a BVH holds at most 2^27 triangles"
        );
        let mut ids: Vec<u32> = (0..tris.len() as u32).collect();
        let cent: Vec<Vec3A> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let lo: Vec<Vec3A> = tris.iter().map(|t| t[0].min(t[1]).min(t[2])).collect();
        let hi: Vec<Vec3A> = tris.iter().map(|t| t[0].max(t[1]).max(t[2])).collect();
        let mut binary = Vec::with_capacity(2 * tris.len().max(1));
        binary.push(Node {
            lo: Vec3A::ZERO,
            hi: Vec3A::ZERO,
            first: 0,
            count: 0,
        });
        let mut nodes = Vec::new();
        let mut leaves = Leaves {
            tris,
            order: &[],
            blocks: Vec::with_capacity(tris.len() / 2),
            ids: Vec::with_capacity(tris.len() * 2),
        };
        if !tris.is_empty() {
            build(&mut binary, 0, &mut ids, 0, &cent, &lo, &hi);
            leaves.order = &ids;
            collapse(&binary, &[0], &mut nodes, &mut leaves);
        }
        Bvh {
            nodes,
            blocks: leaves.blocks,
            ids: leaves.ids,
        }
    }

    /// True when some triangle other than `skip` blocks the open segment `from → to`.
    /// The segment's ends are trimmed by `1e-5` of its length.
    pub fn occluded(&self, from: Vec3A, to: Vec3A, skip: [u32; 2]) -> bool {
        self.along(from, to, |k, _| {
            let id = self.ids[k];
            id != skip[0] && id != skip[1]
        })
    }

    /// Calls `f` with the id of every triangle the open segment `from → to` crosses, and
    /// where (the parameter along the segment, 0..1; ends trimmed as in
    /// [`Bvh::occluded`]). A segment through an edge shared by two triangles meets both.
    pub fn each_hit(&self, from: Vec3A, to: Vec3A, mut f: impl FnMut(u32, f32)) {
        self.along(from, to, |k, t| {
            f(self.ids[k], t);
            false
        });
    }

    /// Calls `visit(index, t)` for the stored triangles the segment `from → to` (ends
    /// trimmed by `1e-5` of its length) crosses, until it returns true; whether it did.
    #[inline(always)]
    fn along(&self, from: Vec3A, to: Vec3A, visit: impl FnMut(usize, f32) -> bool) -> bool {
        self.traverse_ray(from, to - from, 1e-5, || 1.0 - 1e-5, visit)
    }

    /// Depth first through the nodes whose box the ray `o + t·d` enters within
    /// `(tmin, far())`, the nearer children first, calling `visit(index, t)` for every
    /// stored triangle in the leaves reached that the ray meets within `(tmin, far())`,
    /// until it returns true; whether it did. `far` may shrink as triangles are visited
    /// (a nearest-hit query): boxes entered past it are skipped, and `visit` sees the
    /// hits of a block of four tested against the `far` before it.
    #[inline(always)]
    fn traverse_ray(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        far: impl Fn() -> f32,
        mut visit: impl FnMut(usize, f32) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let ray = Ray8::new(o, d.recip());
        let tri_ray = TriRay {
            o: o.to_array(),
            d: d.to_array(),
        };
        // Pending children (codes) and where the ray enters them, the nearest on top.
        let mut stack = [(0u32, 0f32); STACK];
        let mut spill: Vec<(u32, f32)> = Vec::new();
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let (mut mask, t) = enter8(n, &ray, tmin, far());
            // Push the lanes entered, then order the pushed run so the nearest is on top.
            let base = sp;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let entry = (n.child[lane], t[lane]);
                if sp < STACK {
                    stack[sp] = entry;
                    sp += 1;
                } else {
                    // A tree deeper than the stack (a very skewed scene) spills over
                    // into the heap rather than losing a subtree.
                    spill.push(entry);
                }
            }
            for i in base + 1..sp {
                let e = stack[i];
                let mut j = i;
                while j > base && stack[j - 1].1 < e.1 {
                    stack[j] = stack[j - 1];
                    j -= 1;
                }
                stack[j] = e;
            }
            // Pop until an inner node to open, visiting the leaves on the way.
            loop {
                let (code, enter) = if let Some(top) = spill.pop() {
                    top
                } else if sp > 0 {
                    sp -= 1;
                    stack[sp]
                } else {
                    return false;
                };
                if enter > far() * 1.000_001 {
                    continue;
                }
                match Child::triangles(code) {
                    Some((first, count)) => {
                        for (j, block) in self.blocks[first..first + count.div_ceil(4)]
                            .iter()
                            .enumerate()
                        {
                            let (mut hits, t) = hit4(block, &tri_ray, tmin, far());
                            hits &= (1 << (count - 4 * j).min(4)) - 1;
                            while hits != 0 {
                                let lane = hits.trailing_zeros() as usize;
                                hits &= hits - 1;
                                if visit(4 * (first + j) + lane, t[lane]) {
                                    return true;
                                }
                            }
                        }
                    }
                    None => {
                        node = code as usize;
                        break;
                    }
                }
            }
        }
    }

    /// Depth first through the children whose box passes `enter(lo, hi)`, calling `visit`
    /// with the index of every stored triangle in the leaves reached, until it returns
    /// true; whether it did.
    #[inline(always)]
    fn traverse(
        &self,
        mut enter: impl FnMut(Vec3A, Vec3A) -> bool,
        mut visit: impl FnMut(usize) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            for lane in 0..n.lanes as usize {
                let lo = Vec3A::new(n.lo[0][lane], n.lo[1][lane], n.lo[2][lane]);
                let hi = Vec3A::new(n.hi[0][lane], n.hi[1][lane], n.hi[2][lane]);
                if !enter(lo, hi) {
                    continue;
                }
                match Child::triangles(n.child[lane]) {
                    Some((first, count)) => {
                        for k in 4 * first..4 * first + count {
                            if visit(k) {
                                return true;
                            }
                        }
                    }
                    None => stack.push(n.child[lane]),
                }
            }
            match stack.pop() {
                Some(next) => node = next as usize,
                None => return false,
            }
        }
    }

    /// Appends to `out` the id of every triangle whose bounding box overlaps the box
    /// `lo..hi` (boxes touching at a face count).
    pub fn overlapping(&self, lo: Vec3A, hi: Vec3A, out: &mut Vec<u32>) {
        self.traverse(
            |nlo, nhi| nlo.cmple(hi).all() && lo.cmple(nhi).all(),
            |k| {
                let [a, b, c] = self.blocks[k / 4].corners(k % 4);
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
        let mut best: Option<(f32, u32)> = None;
        // The far end shrinks to each hit; the box test sees it.
        let tmax = std::cell::Cell::new(tmax);
        self.traverse_ray(
            from,
            d,
            tmin,
            || tmax.get(),
            |k, t| {
                if t < tmax.get() {
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
        let mut best: Option<(f32, u32, u8)> = None;
        let far = std::cell::Cell::new(tmax);
        let limit = || (far.get() * (1.0 + TIE)).min(tmax);
        self.traverse_ray(from, d, tmin, limit, |k, t| {
            if t >= limit() {
                return false;
            }
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
        });
        best.map(|(t, id, _)| (t, id))
    }
}

/// A ray prepared for the triangle tests.
#[derive(Clone, Copy)]
struct TriRay {
    o: [f32; 3],
    d: [f32; 3],
}

/// Barycentric slack of the triangle test: rays through a shared edge meet both sides.
const EDGE: f32 = 1e-6;

/// Where the ray meets each triangle of a block within `(tmin, tmax)` (Möller–Trumbore),
/// and the mask of lanes it meets. Each lane computes exactly what [`hit_lane`] does.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn hit4(b: &Tri4, r: &TriRay, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of every x86-64; the loads read 4 f32 from 16-byte aligned
    // arrays of 4 (`Tri4` is `align(16)` and its rows are 16 bytes).
    unsafe {
        let ld = |a: &[f32; 4]| _mm_load_ps(a.as_ptr());
        let (mul, add, sub) = (
            |a, b| _mm_mul_ps(a, b),
            |a, b| _mm_add_ps(a, b),
            |a, b| _mm_sub_ps(a, b),
        );
        let dot = |a: [__m128; 3], b: [__m128; 3]| {
            add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
        };
        let cross = |a: [__m128; 3], b: [__m128; 3]| {
            [
                sub(mul(a[1], b[2]), mul(a[2], b[1])),
                sub(mul(a[2], b[0]), mul(a[0], b[2])),
                sub(mul(a[0], b[1]), mul(a[1], b[0])),
            ]
        };
        let d = r.d.map(|x| _mm_set1_ps(x));
        let v0 = [ld(&b.v0[0]), ld(&b.v0[1]), ld(&b.v0[2])];
        let e1 = [ld(&b.e1[0]), ld(&b.e1[1]), ld(&b.e1[2])];
        let e2 = [ld(&b.e2[0]), ld(&b.e2[1]), ld(&b.e2[2])];
        let p = cross(d, e2);
        let det = dot(e1, p);
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let s = [
            sub(_mm_set1_ps(r.o[0]), v0[0]),
            sub(_mm_set1_ps(r.o[1]), v0[1]),
            sub(_mm_set1_ps(r.o[2]), v0[2]),
        ];
        let u = mul(dot(s, p), inv);
        let q = cross(s, e1);
        let v = mul(dot(d, q), inv);
        let t = mul(dot(e2, q), inv);
        let abs_det = _mm_andnot_ps(_mm_set1_ps(-0.0), det);
        let lo = _mm_set1_ps(-EDGE);
        let hi = _mm_set1_ps(1.0 + EDGE);
        let ok = _mm_and_ps(
            _mm_and_ps(
                _mm_cmpge_ps(abs_det, _mm_set1_ps(1e-20)),
                _mm_and_ps(_mm_cmpge_ps(u, lo), _mm_cmple_ps(u, hi)),
            ),
            _mm_and_ps(
                _mm_and_ps(_mm_cmpge_ps(v, lo), _mm_cmple_ps(add(u, v), hi)),
                _mm_and_ps(
                    _mm_cmpgt_ps(t, _mm_set1_ps(tmin)),
                    _mm_cmplt_ps(t, _mm_set1_ps(tmax)),
                ),
            ),
        );
        let mut out = [0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), t);
        (_mm_movemask_ps(ok) as u32, out)
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn hit4(b: &Tri4, r: &TriRay, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    let mut out = [0f32; 4];
    let mut hits = 0;
    for (lane, out) in out.iter_mut().enumerate() {
        if let Some(t) = hit_lane(b, lane, r, tmin, tmax) {
            *out = t;
            hits |= 1 << lane;
        }
    }
    (hits, out)
}

/// [`hit4`] for one lane, with the same operations in the same order.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn hit_lane(b: &Tri4, lane: usize, r: &TriRay, tmin: f32, tmax: f32) -> Option<f32> {
    let get = |m: &[[f32; 4]; 3]| [m[0][lane], m[1][lane], m[2][lane]];
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let (v0, e1, e2, d) = (get(&b.v0), get(&b.e1), get(&b.e2), r.d);
    let p = cross(d, e2);
    let det = dot(e1, p);
    let inv = 1.0 / det;
    let s = [r.o[0] - v0[0], r.o[1] - v0[1], r.o[2] - v0[2]];
    let u = dot(s, p) * inv;
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    let t = dot(e2, q) * inv;
    let ok = det.abs() >= 1e-20
        && (-EDGE..=1.0 + EDGE).contains(&u)
        && v >= -EDGE
        && u + v <= 1.0 + EDGE
        && t > tmin
        && t < tmax;
    ok.then_some(t)
}

/// The leaves' triangles as the collapse lays them out.
struct Leaves<'a> {
    tris: &'a [[Vec3A; 3]],
    /// The build's order of the triangles (a leaf holds a run of it).
    order: &'a [u32],
    blocks: Vec<Tri4>,
    ids: Vec<u32>,
}

impl Leaves<'_> {
    /// Stores the leaf `order[first..first + count]` in new blocks; its child code.
    fn add(&mut self, first: u32, count: u32) -> u32 {
        let at = self.blocks.len();
        let run = &self.order[first as usize..(first + count) as usize];
        for chunk in run.chunks(4) {
            let mut block = Tri4::default();
            for (lane, &i) in chunk.iter().enumerate() {
                block.set(lane, &self.tris[i as usize]);
            }
            self.blocks.push(block);
            self.ids.extend(chunk);
            self.ids
                .extend(std::iter::repeat_n(u32::MAX, 4 - chunk.len()));
        }
        Child::leaf(at as u32, count)
    }
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
    if ids.len() <= LEAF_MAX {
        nodes[at].first = first;
        nodes[at].count = ids.len() as u32;
        return;
    }
    // Binned SAH over every axis the centroids spread along.
    let ext = chi - clo;
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext[axis];
        let bin_of =
            |i: u32| (((cent[i as usize][axis] - clo[axis]) * scale) as usize).min(BINS - 1);
        let (cost, split) = best_split(ids, &bin_of, lo, hi);
        if cost < best.0 {
            best = (cost, split, axis);
        }
    }
    let (cost, split, axis) = best;
    // A leaf where splitting costs more than testing every triangle (one box test
    // against one triangle test), as long as the leaf stays within a child code's count.
    let leaf_cost = ids.len() as f32 * half_area(blo, bhi);
    if cost >= leaf_cost && ids.len() <= Child::MAX_COUNT as usize {
        nodes[at].first = first;
        nodes[at].count = ids.len() as u32;
        return;
    }
    // No split on the bins (all centroids in one bin or on one point): the median of
    // the widest axis, so leaves stay small even for stacked duplicates.
    let mid = if split == 0 {
        let axis = ext.max_position();
        ids.sort_unstable_by(|&a, &b| cent[a as usize][axis].total_cmp(&cent[b as usize][axis]));
        ids.len() / 2
    } else {
        let scale = BINS as f32 / ext[axis];
        let bin_of =
            |i: u32| (((cent[i as usize][axis] - clo[axis]) * scale) as usize).min(BINS - 1);
        let mut m = 0;
        for k in 0..ids.len() {
            if bin_of(ids[k]) < split {
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

/// Collapses the binary subtrees `roots` (at most [`WIDTH`]) into one wide node appended
/// to `out`, and their descendants below it, the leaves' triangles into `leaves`; the new
/// node's index. Each child opens the
/// inner binary node of largest surface area among its children until it has 8, so a
/// wide node takes the place of about three binary levels.
fn collapse(binary: &[Node], roots: &[usize], out: &mut Vec<Wide>, leaves: &mut Leaves) -> u32 {
    let at = out.len();
    out.push(Wide {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::INFINITY; WIDTH]; 3],
        child: [0; WIDTH],
        lanes: 0,
    });
    let mut kids: Vec<usize> = roots.to_vec();
    while kids.len() < WIDTH {
        let open = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| binary[k].count == 0)
            .max_by(|a, b| {
                let area = |k: usize| half_area(binary[k].lo, binary[k].hi);
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = open else { break };
        let left = binary[kids[i]].first as usize;
        kids[i] = left;
        kids.push(left + 1);
    }
    let mut node = out[at];
    node.lanes = kids.len() as u32;
    for (lane, &k) in kids.iter().enumerate() {
        let b = &binary[k];
        for a in 0..3 {
            node.lo[a][lane] = b.lo[a];
            node.hi[a][lane] = b.hi[a];
        }
        node.child[lane] = if b.count > 0 {
            leaves.add(b.first, b.count)
        } else {
            let l = b.first as usize;
            collapse(binary, &[l, l + 1], out, leaves)
        };
    }
    out[at] = node;
    at as u32
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
        let mut r = lcg(7);
        let tris = soup(&mut r, 3000);
        let bvh = Bvh::new(&tris);
        let mut hits = 0;
        for _ in 0..3000 {
            let o = Vec3A::new(r(), r(), r()) * 10.0;
            let d = Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| hit_t(t, o, d, 0.0, f32::INFINITY).map(|t| (t, i as u32)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let got = bvh.nearest(o, d, 0.0, f32::INFINITY);
            // The same distance on the same triangle (or one of its stacked copies).
            assert_eq!(
                got.map(|g| g.0),
                brute.map(|b| b.0),
                "ray from {o} along {d}"
            );
            if let (Some(g), Some(b)) = (got, brute) {
                assert_eq!(tris[g.1 as usize], tris[b.1 as usize]);
            }
            hits += usize::from(got.is_some());
        }
        // Most rays meet something, so the check is not vacuous.
        assert!(hits > 1500, "{hits} hits");
    }

    fn lcg(seed: u64) -> impl FnMut() -> f32 {
        let mut seed = seed;
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// Random triangles in a 10 m cube, some large, and a stack of 40 copies of one
    /// triangle (centroids on one point: the build must still bound its leaves).
    fn soup(r: &mut impl FnMut() -> f32, n: usize) -> Vec<[Vec3A; 3]> {
        let mut tris = Vec::new();
        for k in 0..n {
            let c = Vec3A::new(r(), r(), r()) * 10.0;
            let size = if k % 50 == 0 { 8.0 } else { 1.5 };
            let mut e = || Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * size;
            tris.push([c, c + e(), c + e()]);
        }
        let t = tris[0];
        tris.extend(std::iter::repeat_n(t, 40));
        tris
    }

    /// The lane-by-lane triangle test on one triangle: the brute-force reference.
    fn hit_t(t: &[Vec3A; 3], o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<f32> {
        let mut block = Tri4::default();
        block.set(0, t);
        let ray = TriRay {
            o: o.to_array(),
            d: d.to_array(),
        };
        hit_lane(&block, 0, &ray, tmin, tmax)
    }

    /// Occlusion and every crossing of a segment agree with testing every triangle, on a
    /// tree of several levels of 8-wide nodes.
    #[test]
    fn occlusion_and_crossings_are_the_brute_force_ones() {
        let mut r = lcg(11);
        let tris = soup(&mut r, 3000);
        let bvh = Bvh::new(&tris);
        assert!(bvh.nodes.len() > 50, "{} wide nodes", bvh.nodes.len());
        let (mut blocked, mut crossings) = (0, 0);
        for _ in 0..3000 {
            let a = Vec3A::new(r(), r(), r()) * 12.0 - 1.0;
            let b = Vec3A::new(r(), r(), r()) * 12.0 - 1.0;
            let d = b - a;
            let mut brute: Vec<u32> = (0..tris.len() as u32)
                .filter(|&i| hit_t(&tris[i as usize], a, d, 1e-5, 1.0 - 1e-5).is_some())
                .collect();
            let skip = [brute.first().copied().unwrap_or(u32::MAX), u32::MAX];
            let brute_blocked = brute.iter().any(|&i| i != skip[0]);
            assert_eq!(bvh.occluded(a, b, skip), brute_blocked, "{a} → {b}");
            let mut got = Vec::new();
            bvh.each_hit(a, b, |id, _| got.push(id));
            got.sort_unstable();
            brute.sort_unstable();
            assert_eq!(got, brute, "{a} → {b}");
            blocked += usize::from(brute_blocked);
            crossings += brute.len();
        }
        assert!(blocked > 500 && blocked < 2900, "{blocked} blocked");
        assert!(crossings > 3000, "{crossings} crossings");
    }

    /// Every triangle whose box overlaps a query box is reported once, and no other.
    #[test]
    fn overlapping_is_the_brute_force_overlap() {
        let mut r = lcg(5);
        let tris = soup(&mut r, 2000);
        let bvh = Bvh::new(&tris);
        for _ in 0..300 {
            let c = Vec3A::new(r(), r(), r()) * 10.0;
            let h = Vec3A::new(r(), r(), r()) * 1.5;
            let (lo, hi) = (c - h, c + h);
            let mut got = Vec::new();
            bvh.overlapping(lo, hi, &mut got);
            got.sort_unstable();
            let brute: Vec<u32> = (0..tris.len() as u32)
                .filter(|&i| {
                    let t = tris[i as usize];
                    let (tl, th) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    tl.cmple(hi).all() && lo.cmple(th).all()
                })
                .collect();
            assert_eq!(got, brute);
        }
    }

    /// The vector box test and the lane-by-lane one agree on every lane, rays parallel to
    /// an axis and through box faces included.
    #[test]
    fn the_vector_box_test_is_the_lane_by_lane_one() {
        let mut r = lcg(9);
        let mut node = Wide {
            lo: [[0.0; WIDTH]; 3],
            hi: [[0.0; WIDTH]; 3],
            child: [0; WIDTH],
            lanes: 7,
        };
        let mut met = 0;
        for k in 0..20_000 {
            for lane in 0..WIDTH {
                for a in 0..3 {
                    let (x, y) = ((r() * 4.0).round() - 2.0, (r() * 4.0).round() - 2.0);
                    node.lo[a][lane] = x.min(y);
                    node.hi[a][lane] = x.max(y);
                }
            }
            let o = Vec3A::new((r() * 4.0).round() - 2.0, r() * 4.0 - 2.0, r() - 0.5);
            let mut d = Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5);
            if k % 3 == 0 {
                d.x = 0.0;
            }
            let ray = Ray8::new(o, d.recip());
            let (m1, t1) = enter8(&node, &ray, 0.0, 3.0);
            let (m2, t2) = enter8_lanes(&node, &ray, 0.0, 3.0);
            assert_eq!(m1, m2, "{o} {d}");
            for lane in 0..WIDTH {
                if m1 & (1 << lane) != 0 {
                    assert_eq!(t1[lane], t2[lane]);
                }
            }
            assert_eq!(m1 >> 7, 0, "an unused lane is never entered");
            met += m1.count_ones();
        }
        assert!(met > 10_000, "{met} boxes met");
    }

    /// The vector triangle test and the lane-by-lane one agree on every lane.
    #[test]
    fn the_vector_triangle_test_is_the_lane_by_lane_one() {
        let mut r = lcg(13);
        let mut met = 0;
        for _ in 0..20_000 {
            let mut block = Tri4::default();
            for lane in 0..4 {
                let c = Vec3A::new(r(), r(), r()) * 2.0 - 1.0;
                let mut e = || Vec3A::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2.0;
                block.set(lane, &[c, c + e(), c + e()]);
            }
            // From a random point toward a point near the first triangle's first corner.
            let o = Vec3A::new(r(), r(), r()) * 4.0 - 2.0;
            let aim = block.corners(0)[0] + Vec3A::new(r(), r(), r()) * 0.5;
            let ray = TriRay {
                o: o.to_array(),
                d: (aim - o).to_array(),
            };
            let (mask, t) = hit4(&block, &ray, 0.0, 4.0);
            for (lane, &t) in t.iter().enumerate() {
                let one = hit_lane(&block, lane, &ray, 0.0, 4.0);
                assert_eq!(mask & (1 << lane) != 0, one.is_some());
                if let Some(one) = one {
                    assert_eq!(t, one);
                    met += 1;
                }
            }
        }
        assert!(met > 2_000, "{met} triangles met");
    }
}
