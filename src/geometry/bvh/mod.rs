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

mod build;
mod lanes;
mod order;
#[cfg(test)]
mod tests;

use std::mem::MaybeUninit;

use glam::Vec3A;

use super::shaft::Shaft;
use build::{build, collapse, Leaves, Node};
use lanes::{enter8, hit4, Child, LaneRay, Tri4, Wide, WIDTH};

/// A BVH over triangles given as corner triples.
pub struct Bvh {
    /// The collapsed tree; the root is the first node (none without triangles).
    nodes: Vec<Wide>,
    /// The leaves' triangles, four to a block.
    blocks: Vec<Tri4>,
    /// Caller's index of each stored triangle (block · 4 + lane); `u32::MAX` on padding.
    ids: Vec<u32>,
}

/// The share of a segment's length trimmed at each end by [`Bvh::occluded`] and
/// [`Bvh::each_hit`].
const TRIM: f32 = 1e-5;

/// Entries of a walk's stack kept on the thread's stack; deeper trees spill to the heap.
/// The unit tests keep fewer, so their trees of a few thousand triangles spill too.
const STACK: usize = if cfg!(test) { 16 } else { 256 };

impl Bvh {
    /// Builds the hierarchy. `tris[i]` keeps the id `i` in queries.
    ///
    /// # Panics
    /// With more than 2²⁷ (134 million) triangles; scenes are limited far below that.
    pub fn new(tris: &[[Vec3A; 3]]) -> Bvh {
        let mut bvh = Bvh::unordered(tris);
        bvh.order_for_occlusion(tris);
        bvh
    }

    /// The tree in the build's order (see [`Bvh::order_for_occlusion`]).
    fn unordered(tris: &[[Vec3A; 3]]) -> Bvh {
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

    /// Calls `f` with the corners of every triangle the open segment `from → to` crosses
    /// (ends trimmed as in [`Bvh::occluded`]).
    pub fn each_hit_corners(&self, from: Vec3A, to: Vec3A, mut f: impl FnMut([Vec3A; 3])) {
        self.along(from, to, |k, _| {
            f(self.blocks[k / 4].corners(k % 4));
            false
        });
    }

    /// Calls `visit(index, t)` for the stored triangles the segment `from → to` (ends
    /// trimmed by `1e-5` of its length) crosses, until it returns true; whether it did.
    ///
    /// Depth first through the boxes the segment enters, in the order they are stored:
    /// any hit ends an occlusion query, so ordering buys it nothing. On office-floor its
    /// shadow rays met 6.8 nodes and blocks each unordered against 8.6 nearest first (the
    /// boxes a ray starts inside, the surfaces around its origin, come first and seldom
    /// block it), and the walk skips the sort and keeps no entry distances.
    #[inline(always)]
    fn along(&self, from: Vec3A, to: Vec3A, mut visit: impl FnMut(usize, f32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let (o, d) = (from, to - from);
        let (tmin, tmax) = (TRIM, 1.0 - TRIM);
        let ray = LaneRay::new(o, d);
        // Pending children's codes. Left uninitialised: entries below `sp` are written.
        let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
        let mut spill: Vec<u32> = Vec::new();
        let mut sp = 0usize;
        let mut code = 0u32;
        loop {
            match Child::triangles(code) {
                Some(leaf) => {
                    if self.visit_leaf(leaf, &ray, tmin, &|| tmax, &mut visit) {
                        return true;
                    }
                }
                None => {
                    let n = &self.nodes[code as usize];
                    let (mut mask, _) = enter8(n, &ray, tmin, tmax);
                    if sp + WIDTH <= STACK {
                        while mask != 0 {
                            let lane = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            stack[sp].write(n.child[lane & (WIDTH - 1)]);
                            sp += 1;
                        }
                    } else {
                        while mask != 0 {
                            let lane = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            // A tree deeper than the stack (a very skewed scene) spills
                            // over into the heap rather than losing a subtree.
                            spill.push(n.child[lane & (WIDTH - 1)]);
                        }
                    }
                }
            }
            code = if sp > 0 {
                sp -= 1;
                // SAFETY: entries below the old `sp` are written.
                unsafe { stack[sp].assume_init() }
            } else if let Some(next) = spill.pop() {
                next
            } else {
                return false;
            };
        }
    }

    /// Calls `visit(index, t)` for the triangles of the leaf `first, count` that the ray
    /// meets within `(tmin, far())`, until it returns true; whether it did. The padding
    /// lanes of its last block hold degenerate triangles, which no ray meets.
    #[inline(always)]
    fn visit_leaf(
        &self,
        (first, count): (usize, usize),
        ray: &LaneRay,
        tmin: f32,
        far: &impl Fn() -> f32,
        visit: &mut impl FnMut(usize, f32) -> bool,
    ) -> bool {
        let blocks = &self.blocks[first..first + count.div_ceil(4)];
        for (j, block) in blocks.iter().enumerate() {
            let (mut hits, t) = hit4(block, ray, tmin, far());
            while hits != 0 {
                let lane = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                if visit(4 * (first + j) + lane, t[lane]) {
                    return true;
                }
            }
        }
        false
    }

    /// Depth first through the nodes whose box the ray `o + t·d` enters within
    /// `(tmin, far())`, the nearer children first, calling `visit(index, t)` for every
    /// stored triangle in the leaves reached that the ray meets within `(tmin, far())`.
    /// `far` may shrink as triangles are visited (a nearest-hit query): boxes entered
    /// past it are skipped, and `visit` sees the hits of a block of four tested against
    /// the `far` before it.
    #[inline(always)]
    fn nearest_first(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        far: impl Fn() -> f32,
        mut visit: impl FnMut(usize, f32),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let ray = LaneRay::new(o, d);
        let mut pending = Pending::new();
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let (mask, t) = enter8(n, &ray, tmin, far());
            pending.push_nearest_on_top(n, mask, &t);
            // Pop until an inner node to open, visiting the leaves on the way.
            loop {
                let Some((code, enter)) = pending.pop() else {
                    return;
                };
                // The far end may have shrunk since this box was pushed.
                if enter > far() * 1.000_001 {
                    continue;
                }
                match Child::triangles(code) {
                    Some(leaf) => {
                        self.visit_leaf(leaf, &ray, tmin, &far, &mut |k, t| {
                            visit(k, t);
                            false
                        });
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

    /// Calls `f` with the corners of every triangle whose bounding box overlaps the box
    /// `lo..hi` (boxes touching at a face count).
    pub fn overlapping_corners(&self, lo: Vec3A, hi: Vec3A, mut f: impl FnMut([Vec3A; 3])) {
        self.traverse(
            |nlo, nhi| nlo.cmple(hi).all() && lo.cmple(nhi).all(),
            |k| {
                let [a, b, c] = self.blocks[k / 4].corners(k % 4);
                if self.ids[k] != u32::MAX
                    && a.min(b).min(c).cmple(hi).all()
                    && lo.cmple(a.max(b).max(c)).all()
                {
                    f([a, b, c]);
                }
                false
            },
        );
    }

    /// True when no triangle other than `skip` can meet `shaft` ([`Shaft`]): every
    /// shadow ray the shaft stands for is then free. False when some triangle may meet it
    /// (the caller traces its rays).
    pub fn clear_of(&self, shaft: &Shaft, skip: [u32; 2]) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        // Left uninitialised as in `along`: entries below `sp` are written.
        let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
        let mut spill: Vec<u32> = Vec::new();
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let mut mask = !shaft.boxes_outside(&n.lo, &n.hi) & ((1u32 << n.lanes) - 1);
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let code = n.child[lane];
                match Child::triangles(code) {
                    Some((first, count)) => {
                        for k in 4 * first..4 * first + count {
                            let id = self.ids[k];
                            if id != skip[0]
                                && id != skip[1]
                                && !shaft.triangle_outside(&self.blocks[k / 4].corners(k % 4))
                            {
                                return false;
                            }
                        }
                    }
                    None if sp < STACK => {
                        stack[sp].write(code);
                        sp += 1;
                    }
                    None => spill.push(code),
                }
            }
            node = if let Some(next) = spill.pop() {
                next as usize
            } else if sp > 0 {
                sp -= 1;
                // SAFETY: entries below the old `sp` are written.
                unsafe { stack[sp].assume_init() as usize }
            } else {
                return true;
            };
        }
    }

    /// Distance parameter of the nearest hit along `from + t·d`, t in (tmin, tmax), with
    /// the id of the triangle hit.
    pub fn nearest(&self, from: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        // The far end shrinks to each hit; the box test sees it.
        let tmax = std::cell::Cell::new(tmax);
        self.nearest_first(
            from,
            d,
            tmin,
            || tmax.get(),
            |k, t| {
                if t < tmax.get() {
                    tmax.set(t);
                    best = Some((t, self.ids[k]));
                }
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
        self.nearest_first(from, d, tmin, limit, |k, t| {
            if t >= limit() {
                return;
            }
            let id = self.ids[k];
            let r = rank(id);
            if r == 0 {
                return;
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
        });
        best.map(|(t, id, _)| (t, id))
    }
}

/// The pending children of a nearest-first walk (codes) and where the ray enters them,
/// the nearest on top.
struct Pending {
    /// Left uninitialised: zeroing 2 KB per query was a tenth of an occlusion test's
    /// time. Entries below `sp` are written.
    stack: [MaybeUninit<(u32, f32)>; STACK],
    sp: usize,
    /// A tree deeper than the stack (a very skewed scene) spills over into the heap
    /// rather than losing a subtree; the spill is popped first.
    spill: Vec<(u32, f32)>,
}

impl Pending {
    #[inline(always)]
    fn new() -> Pending {
        Pending {
            stack: [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK],
            sp: 0,
            spill: Vec::new(),
        }
    }

    /// Pushes the children of `n` in `mask` with their entry distances `t`, then orders
    /// the pushed run so the nearest is on top.
    #[inline(always)]
    fn push_nearest_on_top(&mut self, n: &Wide, mut mask: u32, t: &[f32; WIDTH]) {
        let base = self.sp;
        let stack = &mut self.stack;
        if self.sp + WIDTH <= STACK {
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                stack[self.sp].write((n.child[lane], t[lane]));
                self.sp += 1;
            }
        } else {
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let entry = (n.child[lane], t[lane]);
                if self.sp < STACK {
                    stack[self.sp].write(entry);
                    self.sp += 1;
                } else {
                    self.spill.push(entry);
                }
            }
        }
        // Insertion sort of the pushed run, farthest at the bottom.
        for i in base + 1..self.sp {
            // SAFETY: entries below `sp` are written.
            let e = unsafe { stack[i].assume_init() };
            let mut j = i;
            // SAFETY: as above, `j - 1 < i < sp`.
            while j > base && unsafe { stack[j - 1].assume_init() }.1 < e.1 {
                stack[j] = stack[j - 1];
                j -= 1;
            }
            stack[j].write(e);
        }
    }

    /// The next pending child: the spill's last, else the top of the stack.
    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if let Some(top) = self.spill.pop() {
            Some(top)
        } else if self.sp > 0 {
            self.sp -= 1;
            // SAFETY: entries below the old `sp` are written.
            Some(unsafe { self.stack[self.sp].assume_init() })
        } else {
            None
        }
    }
}
