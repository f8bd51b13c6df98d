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

/// Builds the binary subtree over `ids` (the triangles `first..first + ids.len()` of the
/// build's order, which it reorders) into `nodes[at]` and the nodes it appends.
pub(super) fn build(
    nodes: &mut Vec<Node>,
    at: usize,
    ids: &mut [u32],
    first: u32,
    cent: &[Vec3A],
    lo: &[Vec3A],
    hi: &[Vec3A],
) {
    let b = Bounds::of(ids, cent, lo, hi);
    nodes[at].lo = b.lo;
    nodes[at].hi = b.hi;
    if ids.len() <= LEAF_MAX {
        nodes[at].first = first;
        nodes[at].count = ids.len() as u32;
        return;
    }
    let (cost, split, axis) = sah_split(ids, &b, cent, lo, hi);
    // A leaf where splitting costs more than testing every triangle (one box test
    // against one triangle test), as long as the leaf stays within a child code's count.
    let leaf_cost = ids.len() as f32 * half_area(b.lo, b.hi);
    if cost >= leaf_cost && ids.len() <= Child::MAX_COUNT as usize {
        nodes[at].first = first;
        nodes[at].count = ids.len() as u32;
        return;
    }
    let mid = partition(ids, &b, cent, split, axis);
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

/// The boxes around a node's triangles and around their centroids.
struct Bounds {
    lo: Vec3A,
    hi: Vec3A,
    /// The centroids' box.
    clo: Vec3A,
    chi: Vec3A,
}

impl Bounds {
    fn of(ids: &[u32], cent: &[Vec3A], lo: &[Vec3A], hi: &[Vec3A]) -> Bounds {
        let mut b = Bounds {
            lo: Vec3A::splat(f32::INFINITY),
            hi: Vec3A::splat(f32::NEG_INFINITY),
            clo: Vec3A::splat(f32::INFINITY),
            chi: Vec3A::splat(f32::NEG_INFINITY),
        };
        for &i in ids.iter() {
            b.lo = b.lo.min(lo[i as usize]);
            b.hi = b.hi.max(hi[i as usize]);
            b.clo = b.clo.min(cent[i as usize]);
            b.chi = b.chi.max(cent[i as usize]);
        }
        b
    }

    /// The bin of `BINS` along `axis` that each triangle's centroid falls in.
    fn bin_of<'a>(&self, cent: &'a [Vec3A], axis: usize) -> impl Fn(u32) -> usize + 'a {
        let scale = BINS as f32 / (self.chi - self.clo)[axis];
        let clo = self.clo[axis];
        move |i: u32| (((cent[i as usize][axis] - clo) * scale) as usize).min(BINS - 1)
    }
}

/// Binned SAH over every axis the centroids spread along: (cost, first bin of the
/// right side, axis); (∞, 0, 0) when no axis has a split.
fn sah_split(
    ids: &[u32],
    b: &Bounds,
    cent: &[Vec3A],
    lo: &[Vec3A],
    hi: &[Vec3A],
) -> (f32, usize, usize) {
    let ext = b.chi - b.clo;
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let (cost, split) = best_split(ids, &b.bin_of(cent, axis), lo, hi);
        if cost < best.0 {
            best = (cost, split, axis);
        }
    }
    best
}

/// Reorders `ids` into the two children's runs; the length of the left one, never 0
/// nor all of `ids`. The bins `..split` along `axis` go left; with no split on the
/// bins (all centroids in one bin or on one point), the median of the widest axis, so
/// leaves stay small even for stacked duplicates.
fn partition(ids: &mut [u32], b: &Bounds, cent: &[Vec3A], split: usize, axis: usize) -> usize {
    let mid = if split == 0 {
        let axis = (b.chi - b.clo).max_position();
        ids.sort_unstable_by(|&a, &b| cent[a as usize][axis].total_cmp(&cent[b as usize][axis]));
        ids.len() / 2
    } else {
        let bin_of = b.bin_of(cent, axis);
        let mut m = 0;
        for k in 0..ids.len() {
            if bin_of(ids[k]) < split {
                ids.swap(k, m);
                m += 1;
            }
        }
        m
    };
    if mid == 0 || mid == ids.len() {
        ids.len() / 2
    } else {
        mid
    }
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
