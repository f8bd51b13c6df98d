//! The order in which an occlusion walk visits a node's children, chosen from sample
//! segments.
//!
//! Any hit ends an occlusion query, so the cheapest walk visits first the children most
//! likely to end it for the least work: for independent children, visiting them by
//! falling `p / c` (the share of the segments entering a child that meet a triangle in
//! it, over the work of walking it) minimises the expected work (Ize & Hansen's ray
//! termination SAH, 2011, measured here rather than estimated from areas). The sample
//! is the segments relight traces most: between random points of the scene's triangles
//! (by area) that face each other, each leaving the front of one and reaching the front
//! of the other. A node's lanes are then reordered so the walk's stack pops them in that
//! order; children no sample entered keep the build's order, after the others.
//!
//! Fixed orders were measured first: the build's order (the children of the largest
//! boxes opened last, on top of the stack) and the smallest box first each won on one
//! furnished office floor and lost about a tenth on another.

use glam::Vec3A;

use super::lanes::{Child, LaneRay, WIDTH};
use super::{Bvh, TRIM};

/// Sample segments per tree, at most, and per triangle.
const SAMPLES: usize = 16_384;
const SAMPLES_PER_TRIANGLE: usize = 16;
/// Draws per sample kept (pairs that do not face each other are drawn again).
const DRAWS_PER_SAMPLE: usize = 8;
/// The work of opening a wide node and of testing a block of four triangles, in the
/// same unit (25 ns and 9 ns on this project's reference machine).
const NODE_COST: f32 = 1.0;
const BLOCK_COST: f32 = 0.36;
/// The sample's seed.
const SEED: u64 = 0x5DEE_CE66_D1CE_5EED;
/// Nodes deeper than this below the root are walked but not scored (a very skewed
/// tree keeps its build order there, and the recursion stays shallow).
const MAX_DEPTH: usize = 64;

/// Per lane of a node: segments that entered it, those that met a triangle in it, and
/// the work of walking it, summed.
#[derive(Clone, Copy, Default)]
struct Lane {
    entered: f32,
    met: f32,
    cost: f32,
}

impl Bvh {
    /// Reorders every node's lanes for occlusion walks (see the module doc); `tris` are
    /// the triangles the tree was built over. Nearest-hit walks sort what they enter by
    /// distance, so they are unaffected, and every walk meets the same triangles.
    pub(super) fn order_for_occlusion(&mut self, tris: &[[Vec3A; 3]]) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stats = vec![[Lane::default(); WIDTH]; self.nodes.len()];
        for (from, to, skip) in sample_segments(tris, SEED) {
            let (o, d) = (from, to - from);
            self.probe(0, 0, &LaneRay::new(o, d), skip, &mut stats);
        }
        for (node, lanes) in self.nodes.iter_mut().zip(&stats) {
            let used = node.lanes as usize;
            let key = |l: usize| {
                let s = lanes[l];
                if s.entered > 0.0 {
                    (s.met / s.cost.max(f32::MIN_POSITIVE), 1)
                } else {
                    (0.0, 0)
                }
            };
            // The walk pops the highest lane first: the best goes last. Lanes no sample
            // entered go first (popped last), in the build's order.
            let mut perm: Vec<usize> = (0..used).collect();
            perm.sort_by(|&a, &b| {
                let (ka, kb) = (key(a), key(b));
                ka.1.cmp(&kb.1).then(ka.0.total_cmp(&kb.0))
            });
            let old = *node;
            for (to, &from) in perm.iter().enumerate() {
                for a in 0..3 {
                    node.lo[a][to] = old.lo[a][from];
                    node.hi[a][to] = old.hi[a][from];
                }
                node.child[to] = old.child[from];
            }
        }
    }

    /// Walks every child of `node` the segment enters (no early end), scoring each lane;
    /// whether some triangle other than `skip` met the segment below `node`, and the work.
    fn probe(
        &self,
        node: usize,
        depth: usize,
        ray: &LaneRay,
        skip: [u32; 2],
        stats: &mut [[Lane; WIDTH]],
    ) -> (bool, f32) {
        let (tmin, tmax) = (TRIM, 1.0 - TRIM);
        let n = &self.nodes[node];
        let (mut mask, _) = super::lanes::enter8(n, ray, tmin, tmax);
        let (mut met, mut cost) = (false, NODE_COST);
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let code = n.child[lane];
            let (m, c) = match Child::triangles(code) {
                Some(leaf @ (_, count)) => {
                    // Whether a triangle other than the skipped ones meets the segment.
                    let m = self.visit_leaf(leaf, ray, tmin, &|| tmax, &mut |k, _| {
                        let id = self.ids[k];
                        id != skip[0] && id != skip[1]
                    });
                    (m, BLOCK_COST * count.div_ceil(4) as f32)
                }
                None if depth < MAX_DEPTH => self.probe(code as usize, depth + 1, ray, skip, stats),
                // Too deep to score: counted as one node that ends nothing.
                None => (false, NODE_COST),
            };
            let s = &mut stats[node][lane];
            s.entered += 1.0;
            s.met += f32::from(u8::from(m));
            s.cost += c;
            met |= m;
            cost += c;
        }
        (met, cost)
    }
}

/// Segments between random points of `tris` (by area) that face each other, with the
/// two triangles' indices; deterministic.
fn sample_segments(tris: &[[Vec3A; 3]], seed: u64) -> Vec<(Vec3A, Vec3A, [u32; 2])> {
    let mut total = 0.0f64;
    let cumulative: Vec<f64> = tris
        .iter()
        .map(|t| {
            total += f64::from(0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length());
            total
        })
        .collect();
    let wanted = SAMPLES.min(SAMPLES_PER_TRIANGLE * tris.len());
    let mut out = Vec::with_capacity(wanted);
    if total.is_nan() || total <= 0.0 || total.is_infinite() {
        return out;
    }
    let mut state = seed;
    let mut next = move || {
        // SplitMix64.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    };
    let point = |next: &mut dyn FnMut() -> f64| {
        let at = next() * total;
        let i = cumulative.partition_point(|&c| c <= at).min(tris.len() - 1);
        let t = &tris[i];
        let (mut u, mut v) = (next() as f32, next() as f32);
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let normal = (t[1] - t[0]).cross(t[2] - t[0]);
        (
            t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v,
            normal,
            i as u32,
        )
    };
    for _ in 0..wanted * DRAWS_PER_SAMPLE {
        if out.len() == wanted {
            break;
        }
        let (x, nx, i) = point(&mut next);
        let (y, ny, j) = point(&mut next);
        let d = y - x;
        if d.dot(nx) > 0.0 && d.dot(ny) < 0.0 {
            out.push((x, y, [i, j]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::lanes::hit4;
    use super::*;

    /// Work of `bvh.occluded(from, to, skip)` as its walk does it (the stack pops the
    /// highest lane first), in [`NODE_COST`] and [`BLOCK_COST`]; and its answer.
    fn occlusion_work(bvh: &Bvh, from: Vec3A, to: Vec3A, skip: [u32; 2]) -> (f32, bool) {
        let (o, d) = (from, to - from);
        let ray = LaneRay::new(o, d);
        let (mut work, mut stack) = (0.0, vec![0u32]);
        while let Some(code) = stack.pop() {
            match Child::triangles(code) {
                Some((first, count)) => {
                    for (j, block) in bvh.blocks[first..first + count.div_ceil(4)]
                        .iter()
                        .enumerate()
                    {
                        work += BLOCK_COST;
                        let (mut hits, _) = hit4(block, &ray, TRIM, 1.0 - TRIM);
                        while hits != 0 {
                            let l = hits.trailing_zeros() as usize;
                            hits &= hits - 1;
                            let id = bvh.ids[4 * (first + j) + l];
                            if id != skip[0] && id != skip[1] {
                                return (work, true);
                            }
                        }
                    }
                }
                None => {
                    work += NODE_COST;
                    let n = &bvh.nodes[code as usize];
                    let (mut mask, _) = super::super::lanes::enter8(n, &ray, TRIM, 1.0 - TRIM);
                    while mask != 0 {
                        stack.push(n.child[mask.trailing_zeros() as usize]);
                        mask &= mask - 1;
                    }
                }
            }
        }
        (work, false)
    }

    /// A floor of 6 × 6 rooms (4 m square, 3 m high) with a desk and a cabinet in each,
    /// as triangles.
    fn floor_plan() -> Vec<[Vec3A; 3]> {
        let mut tris = Vec::new();
        let mut quad = |a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A| {
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        };
        let v = Vec3A::new;
        quad(
            v(0., 0., 0.),
            v(24., 0., 0.),
            v(24., 24., 0.),
            v(0., 24., 0.),
        );
        quad(
            v(0., 0., 3.),
            v(0., 24., 3.),
            v(24., 24., 3.),
            v(24., 0., 3.),
        );
        for k in 0..=6 {
            let x = 4.0 * k as f32;
            quad(v(x, 0., 0.), v(x, 24., 0.), v(x, 24., 3.), v(x, 0., 3.));
            quad(v(0., x, 0.), v(0., x, 3.), v(24., x, 3.), v(24., x, 0.));
        }
        let mut boxes = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                let (x, y) = (4.0 * i as f32, 4.0 * j as f32);
                boxes.push((v(x + 1.0, y + 1.0, 0.7), v(x + 2.6, y + 1.8, 0.74)));
                boxes.push((v(x + 3.2, y + 0.3, 0.0), v(x + 3.7, y + 2.0, 1.9)));
            }
        }
        for (lo, hi) in boxes {
            let c = |m: u32| {
                v(
                    if m & 1 != 0 { hi.x } else { lo.x },
                    if m & 2 != 0 { hi.y } else { lo.y },
                    if m & 4 != 0 { hi.z } else { lo.z },
                )
            };
            for [a, b, cc, d] in [
                [0, 2, 3, 1],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 4, 6, 2],
                [1, 3, 7, 5],
            ] {
                quad(c(a), c(b), c(cc), c(d));
            }
        }
        tris
    }

    /// Ordered by the sample, a floor plan's shadow rays (a fresh sample of them) do less
    /// work than in the build's order (2.80 against 3.03 nodes' worth per segment when
    /// written), and every answer stays the same.
    #[test]
    fn ordering_for_occlusion_cuts_the_work_of_shadow_rays_and_changes_no_answer() {
        let tris = floor_plan();
        let ordered = Bvh::new(&tris);
        let unordered = Bvh::unordered(&tris);
        let segments = sample_segments(&tris, 7);
        assert!(segments.len() > 10_000, "{} segments", segments.len());
        let (mut before, mut after, mut blocked) = (0.0, 0.0, 0);
        for &(from, to, skip) in &segments {
            let (w0, b0) = occlusion_work(&unordered, from, to, skip);
            let (w1, b1) = occlusion_work(&ordered, from, to, skip);
            assert_eq!(b0, b1);
            assert_eq!(b1, ordered.occluded(from, to, skip));
            assert_eq!(b0, unordered.occluded(from, to, skip));
            before += w0;
            after += w1;
            blocked += usize::from(b1);
        }
        let n = segments.len() as f32;
        assert!(blocked > segments.len() / 2, "{blocked} blocked");
        assert!(
            after < 0.95 * before,
            "work per segment {:.3} ordered against {:.3}",
            after / n,
            before / n
        );
    }

    /// Reordering moves whole lanes: every node keeps its children and their boxes.
    #[test]
    fn ordering_permutes_each_nodes_lanes() {
        let tris = floor_plan();
        let (ordered, unordered) = (Bvh::new(&tris), Bvh::unordered(&tris));
        assert_eq!(ordered.nodes.len(), unordered.nodes.len());
        let mut moved = 0;
        for (a, b) in ordered.nodes.iter().zip(&unordered.nodes) {
            assert_eq!(a.lanes, b.lanes);
            let lane = |n: &super::super::lanes::Wide, l: usize| {
                (
                    n.child[l],
                    [0, 1, 2].map(|x| (n.lo[x][l].to_bits(), n.hi[x][l].to_bits())),
                )
            };
            let mut la: Vec<_> = (0..a.lanes as usize).map(|l| lane(a, l)).collect();
            let mut lb: Vec<_> = (0..b.lanes as usize).map(|l| lane(b, l)).collect();
            moved += usize::from(la != lb);
            la.sort();
            lb.sort();
            assert_eq!(la, lb);
        }
        assert!(moved > 0, "no node was reordered");
    }
}
