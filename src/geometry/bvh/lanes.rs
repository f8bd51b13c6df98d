//! The vector tests of the BVH: a ray against the 8 child boxes of a wide node (AVX where
//! the build targets it) and against a block of 4 triangles (SSE), with the same
//! arithmetic lane by lane as their references, and the layouts they read.

use glam::Vec3A;

/// Children per node of the collapsed tree.
pub(super) const WIDTH: usize = 8;

/// A node of the collapsed tree: up to 8 children, their boxes lane by lane.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Wide {
    /// Lower corners, by axis then lane.
    pub(super) lo: [[f32; WIDTH]; 3],
    /// Upper corners, by axis then lane.
    pub(super) hi: [[f32; WIDTH]; 3],
    /// Per lane, a [`Child`] code: an inner node's index, or a leaf's triangles.
    pub(super) child: [u32; WIDTH],
    /// Lanes in use (the first `lanes`); the others hold empty boxes.
    pub(super) lanes: u32,
}

/// A child code of a [`Wide`] node: the top bit marks a leaf, whose next 4 bits hold its
/// triangle count less one and whose low 27 bits its first [`Tri4`] block. A leaf's
/// triangles fill consecutive blocks, the last one padded.
pub(super) struct Child;

impl Child {
    pub(super) const LEAF: u32 = 1 << 31;
    pub(super) const FIRST_BITS: u32 = 27;
    /// Triangles a leaf may hold.
    pub(super) const MAX_COUNT: u32 = 16;
    /// Triangles a tree may hold (a leaf's first block must fit its 27 bits).
    pub(super) const MAX_TRIANGLES: usize = 1 << Self::FIRST_BITS;

    pub(super) fn leaf(first: u32, count: u32) -> u32 {
        debug_assert!((1..=Self::MAX_COUNT).contains(&count));
        Self::LEAF | ((count - 1) << Self::FIRST_BITS) | first
    }

    /// A leaf code's first block and triangle count, or None for an inner node's.
    #[inline(always)]
    pub(super) fn triangles(code: u32) -> Option<(usize, usize)> {
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
pub(super) struct Tri4 {
    pub(super) v0: [[f32; 4]; 3],
    pub(super) e1: [[f32; 4]; 3],
    pub(super) e2: [[f32; 4]; 3],
}

impl Tri4 {
    pub(super) fn set(&mut self, lane: usize, t: &[Vec3A; 3]) {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        for a in 0..3 {
            self.v0[a][lane] = t[0][a];
            self.e1[a][lane] = e1[a];
            self.e2[a][lane] = e2[a];
        }
    }

    /// The corners of the triangle in `lane` (as stored: the first corner plus edges).
    pub(super) fn corners(&self, lane: usize) -> [Vec3A; 3] {
        let get = |m: &[[f32; 4]; 3]| Vec3A::new(m[0][lane], m[1][lane], m[2][lane]);
        let v0 = get(&self.v0);
        [v0, v0 + get(&self.e1), v0 + get(&self.e2)]
    }
}

/// A ray prepared for the vector tests, lane-wide by axis: origin and direction (the
/// triangle tests), and the reciprocal direction (the box tests).
#[derive(Clone, Copy)]
pub(super) struct LaneRay {
    pub(super) o: [f32; 3],
    pub(super) d: [f32; 3],
    pub(super) inv: [f32; 3],
}

impl LaneRay {
    pub(super) fn new(o: Vec3A, d: Vec3A) -> LaneRay {
        LaneRay {
            o: o.to_array(),
            d: d.to_array(),
            inv: d.recip().to_array(),
        }
    }
}

/// Where the ray enters each of a node's boxes within `(tmin, tmax)`, and the mask of
/// lanes it meets. On an axis the ray is parallel to (`inv` infinite), a box face through
/// the origin makes a NaN that the comparisons treat as a miss on that lane, as the
/// lane-by-lane version does.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
#[inline(always)]
pub(super) fn enter8(n: &Wide, r: &LaneRay, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
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
pub(super) fn enter8(n: &Wide, r: &LaneRay, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
    enter8_lanes(n, r, tmin, tmax)
}

/// [`enter8`] lane by lane, with the same operations in the same order (x86's `min` and
/// `max` return their second operand when either is NaN).
#[cfg_attr(all(target_arch = "x86_64", target_feature = "avx"), allow(dead_code))]
#[inline(always)]
pub(super) fn enter8_lanes(n: &Wide, r: &LaneRay, tmin: f32, tmax: f32) -> (u32, [f32; WIDTH]) {
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

/// Barycentric slack of the triangle test: rays through a shared edge meet both sides.
pub(super) const EDGE: f32 = 1e-6;

/// Where the ray meets each triangle of a block within `(tmin, tmax)` (Möller–Trumbore),
/// and the mask of lanes it meets. Each lane computes exactly what [`hit_lane`] does.
#[cfg(all(target_arch = "x86_64", target_feature = "fma"))]
#[inline(always)]
pub(super) fn hit4(b: &Tri4, r: &LaneRay, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of every x86-64 and FMA is enabled (cfg above); the loads read 4 f32 from 16-byte aligned
    // arrays of 4 (`Tri4` is `align(16)` and its rows are 16 bytes).
    unsafe {
        let ld = |a: &[f32; 4]| _mm_load_ps(a.as_ptr());
        let (mul, add, sub) = (
            |a, b| _mm_mul_ps(a, b),
            |a, b| _mm_add_ps(a, b),
            |a, b| _mm_sub_ps(a, b),
        );
        let dot = |a: [__m128; 3], b: [__m128; 3]| {
            _mm_fmadd_ps(a[0], b[0], _mm_fmadd_ps(a[1], b[1], mul(a[2], b[2])))
        };
        let cross = |a: [__m128; 3], b: [__m128; 3]| {
            [
                _mm_fmsub_ps(a[1], b[2], mul(a[2], b[1])),
                _mm_fmsub_ps(a[2], b[0], mul(a[0], b[2])),
                _mm_fmsub_ps(a[0], b[1], mul(a[1], b[0])),
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

#[cfg(not(all(target_arch = "x86_64", target_feature = "fma")))]
#[inline(always)]
pub(super) fn hit4(b: &Tri4, r: &LaneRay, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
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
#[cfg_attr(all(target_arch = "x86_64", target_feature = "fma"), allow(dead_code))]
pub(super) fn hit_lane(b: &Tri4, lane: usize, r: &LaneRay, tmin: f32, tmax: f32) -> Option<f32> {
    let get = |m: &[[f32; 4]; 3]| [m[0][lane], m[1][lane], m[2][lane]];
    let dot = |a: [f32; 3], b: [f32; 3]| a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]));
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1].mul_add(b[2], -(a[2] * b[1])),
            a[2].mul_add(b[0], -(a[0] * b[2])),
            a[0].mul_add(b[1], -(a[1] * b[0])),
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
