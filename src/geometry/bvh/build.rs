//! Building the BVH: a binary tree by binned SAH over all three axes, collapsed into
//! 8-wide nodes whose leaves lay their triangles out in blocks of four.

use glam::Vec3A;

use super::lanes::{Child, Tri4, Wide, WIDTH};

/// A node of the binary tree the build makes before it is collapsed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    /// Leaf: first triangle; inner: index of the left child (right = left + 1).
    pub(super) first: u32,
    /// Triangles in a leaf; 0 for inner nodes.
    pub(super) count: u32,
}

/// Triangles per leaf the build aims for.
pub(super) const LEAF_MAX: usize = 4;
pub(super) const BINS: usize = 16;

/// The leaves' triangles as the collapse lays them out.
pub(super) struct Leaves<'a> {
    pub(super) tris: &'a [[Vec3A; 3]],
    /// The build's order of the triangles (a leaf holds a run of it).
    pub(super) order: &'a [u32],
    pub(super) blocks: Vec<Tri4>,
    pub(super) ids: Vec<u32>,
}

impl Leaves<'_> {
    /// Stores the leaf `order[first..first + count]` in new blocks; its child code.
    pub(super) fn add(&mut self, first: u32, count: u32) -> u32 {
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

pub(super) fn build(
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
pub(super) fn collapse(
    binary: &[Node],
    roots: &[usize],
    out: &mut Vec<Wide>,
    leaves: &mut Leaves,
) -> u32 {
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
pub(super) fn half_area(l: Vec3A, h: Vec3A) -> f32 {
    let e = (h - l).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The cheapest split by the surface-area heuristic over `BINS` bins: (cost, first bin
/// of the right side); (∞, 0) when no split leaves both sides non-empty.
pub(super) fn best_split(
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
