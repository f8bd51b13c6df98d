//! Link refinement: which node gathers light from which, and with what factor.
//!
//! Every plane's subtree starts with one link to the root of the whole tree (together these
//! are the root's self-link, split once per plane: a receiver must be planar, see below).
//! A link from receiver r to source s is then, in order:
//! - dropped when r and s are coplanar or one lies wholly behind the other's plane;
//! - split on the source side while s contains r;
//! - split on the larger side while r and s are closer than their sizes;
//! - for two patches, computed accurately (exact point-to-triangle factors at quadrature
//!   points times the visible fraction, as in the dense mode) and kept;
//! - otherwise estimated from [`HierarchyOptions::samples`] stratified point pairs, each
//!   with a visibility ray: the factor `F̂` is their mean and its error the spread
//!   `max − min` of the per-pair values. A link whose spread is at most
//!   [`HierarchyOptions::epsilon`] is kept; otherwise the larger side is split. A partly
//!   hidden source has a spread as large as its factor, so links are refined along
//!   shadow boundaries down to the patches, or until the factor itself is below ε (below
//!   ε / [`PARTIAL_CLUSTER`] when the receiver is a cluster: pushed down, the link gives
//!   each leaf the cluster's mean visibility). Sample pairs that all see zero (edge-on or
//!   from behind) do not drop a link that is not wholly behind: it is split.
//!   An accepted link's value is then estimated again from fresh pairs (with their own
//!   visibility rays when the link is partly or wholly hidden): reusing the deciding
//!   samples would bias every link low, since small estimates are the ones accepted
//!   (measured on the Cornell box: the ceiling gathered 0.4 % too little).
//!
//! **Per-group accuracy** ([`Plan::per_group_accuracy`]) changes three things, for rooms
//! lit only through openings (docs/accuracy.md, "Light through openings"):
//! - **Hidden only where a wall proves it.** Rays cannot show that a link is hidden:
//!   light from one room into the next but one, through a door and a window, is seen by
//!   0.1 % of a pair of wall clusters' point pairs and missed by hundreds of rays. A link
//!   whose factor is too large to keep partly visible is settled by its first rays
//!   ([`Ctx::estimate`]): rays that saw both ways split it; when the first
//!   [`HierarchyOptions::samples`] are all blocked, a plane of the scene's triangles
//!   between the two nodes' boxes that covers every segment between them
//!   ([`crate::geometry::blocker`]) drops it, and otherwise it is split too, down to
//!   nodes small enough that the rays see through the openings or a wall proves them
//!   hidden. By default such links are dropped when their rays and a few fresh ones all
//!   miss: the room two openings from the lit one of `benches/doors` read 11 % low.
//! - **Fresh values from fresh rays.** Every accepted link's value traces a visibility
//!   ray per fresh pair: a "wholly visible" verdict from N rays hides a blocked part of
//!   up to about 1/N, every such link too high by the same sign (with walls alone, the
//!   rooms beside a lit one read 2–3 % high).
//! - **Pairs turned at random.** The fresh pairs pair the strata by a random turn
//!   ([`Ctx::pair`]), so their value is unbiased.
//!
//! Receivers are planar (a patch or a cluster of coplanar patches): every leaf under a
//! receiver has the receiver's normal, so the irradiance gathered at the receiver holds for
//! each leaf, and pushing it down is exact up to the link's stated spread. Mixed clusters
//! (from the tree above the planes) act as sources only: their factor is estimated with
//! each sample point's own normal, and their radiosity is their leaves' area average.

use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DVec3, Vec3A};
use rayon::prelude::*;
use serde::Serialize;

use super::tree::{Tree, NONE};
use super::Plan;
use crate::geometry::bvh::Bvh;
use crate::sampling::Rng;
use crate::transport::formfactor::{
    directed, face_each_other, quadrature_level, quadrature_tables, visible_fraction,
    FormFactorOptions, PatchGeo, PatchPoint,
};

/// Quality knobs of the hierarchical transfer. Part of the cache key.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct HierarchyOptions {
    /// Largest accepted spread of a link's factor over its sample pairs.
    pub epsilon: f64,
    /// Sample pairs (and visibility rays) per link estimate.
    pub samples: u32,
    /// Cosine-distributed rays per patch for the closure estimate ([`super::closure`]).
    pub closure_rays: u32,
}

impl Default for HierarchyOptions {
    fn default() -> Self {
        HierarchyOptions {
            epsilon: 1e-3,
            samples: 6,
            closure_rays: 256,
        }
    }
}

/// One link: receiver `r` gathers `k · B_s` (lux per lm/m² of the source's mean
/// radiosity); `vis` is the visible fraction of its rays, 0..=255.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    pub r: u32,
    pub s: u32,
    pub k: f32,
    pub vis: u8,
}

/// Nodes closer than this times the sum of their sizes (bounding-box diagonals) are not
/// estimated from samples: the kernel may peak between the samples there, and a spread
/// that misses the peak would accept an underestimate.
const NEAR: f64 = 2.0;

/// A partly visible link at a cluster receiver is kept only while its factor is below
/// ε / PARTIAL_CLUSTER. Its visibility is the receiver's mean, and pushed down it gives
/// every leaf that mean: a leaf that sees the source wholly (or not at all) is off by up
/// to the whole factor, and by the same sign on every such link of its cluster (leaves
/// under a desk or in a slot between two panels against leaves beside them). Measured
/// on the panel floor (benches/floor): these correlated errors, hundreds of links of
/// nearly ε each, made leaves' factor sums 25 % low or high.
const PARTIAL_CLUSTER: f64 = 8.0;

/// Most visibility rays of one link estimate.
const MAX_LINK_RAYS: u32 = 128;

/// Receivers with more leaves than this split in parallel.
const PARALLEL_LEAVES: u32 = 512;

struct Ctx<'a> {
    tree: &'a Tree,
    /// Per node: the brightest source term among its leaves over the scene's mean
    /// radiosity (see [`refine`]).
    glow: Vec<f32>,
    geo: &'a [PatchGeo],
    bvh: &'a Bvh,
    opts: HierarchyOptions,
    ff: FormFactorOptions,
    quad: [Vec<DVec3>; 5],
    /// Per-group accuracy ([`Plan::per_group_accuracy`]): links dropped as hidden only
    /// where a wall proves it, fresh values from fresh rays, pairs turned at random.
    walls: bool,
}

/// The links of every receiver under the plane roots `roots` of `plan`'s tree, in no
/// particular order. `progress` gets the finished fraction of their receiver area.
///
/// The plan's `glow[i]` is patch i's own source term (emission plus first reflection of luminaire
/// light, all groups at intensity 1) over the scene's mean radiosity. A link from a
/// source node whose brightest leaf has glow w must keep its spread below ε / (1 + w):
/// the error that matters is the factor's error times the source's radiosity (Hanrahan's
/// BF refinement), estimated before the solve from the sources.
pub(crate) fn refine(
    plan: &Plan,
    bvh: &Bvh,
    roots: &[u32],
    opts: HierarchyOptions,
    ff: FormFactorOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Vec<Link> {
    let tree = &plan.tree;
    let ctx = Ctx::new(plan, bvh, opts, ff);
    let total: f64 = roots.iter().map(|&p| tree.area[p as usize]).sum();
    let done = AtomicU64::new(0);
    let root = tree.root();
    let mut roots = roots.to_vec();
    // Largest planes first, for load balance.
    roots.sort_by(|a, b| tree.area[*b as usize].total_cmp(&tree.area[*a as usize]));
    let parts: Vec<Vec<Link>> = roots
        .par_iter()
        .map(|&p| {
            let mut out = Vec::new();
            ctx.link(p, root, &mut out);
            let a = (tree.area[p as usize] * 1e6) as u64;
            let now = done.fetch_add(a, Ordering::Relaxed) + a;
            progress((now as f64 / 1e6 / total.max(1e-300)).min(1.0));
            out
        })
        .collect();
    joined(parts)
}

/// The parts' links in one vector, each part freed as soon as it is moved (the peak is
/// about one copy of the links, not two).
fn joined(parts: Vec<Vec<Link>>) -> Vec<Link> {
    let mut out = Vec::with_capacity(parts.iter().map(Vec::len).sum());
    for p in parts {
        out.extend(p);
    }
    out
}

impl<'a> Ctx<'a> {
    fn new(plan: &'a Plan, bvh: &'a Bvh, opts: HierarchyOptions, ff: FormFactorOptions) -> Ctx<'a> {
        let tree = &plan.tree;
        let mut glow: Vec<f32> = plan.glow.to_vec();
        glow.resize(tree.n, 0.0);
        for ch in &tree.children {
            glow.push(glow[ch[0] as usize].max(glow[ch[1] as usize]));
        }
        Ctx {
            tree,
            glow,
            geo: &plan.geo,
            bvh,
            opts,
            ff,
            quad: quadrature_tables(),
            walls: plan.per_group,
        }
    }
}

impl Ctx<'_> {
    /// The bound on the factor error of a link from `s`: ε / (1 + glow).
    fn eps(&self, s: u32) -> f64 {
        self.opts.epsilon / (1.0 + self.glow[s as usize] as f64)
    }

    fn link(&self, r: u32, s: u32, out: &mut Vec<Link>) {
        let t = self.tree;
        let (pr, ps) = (t.plane[r as usize], t.plane[s as usize]);
        if ps != NONE && ps == pr {
            return;
        }
        if t.contains(s, r) {
            return self.split_source(r, s, out);
        }
        if self.culled(r, s) {
            return;
        }
        let (rl, sl) = (t.is_leaf(r), t.is_leaf(s));
        if rl && sl {
            if let Some(l) = self.leaf_link(r, s) {
                out.push(l);
            }
            return;
        }
        let near = t.center(r).distance(t.center(s)) < NEAR * (t.size(r) + t.size(s));
        if !near {
            let eps = self.eps(s);
            let (k, spread, vis, unoccluded) = self.estimate(r, s, eps);
            if spread <= eps {
                let hidden = vis == 0.0;
                let w = self.partial_weight(r);
                if hidden && self.walls && unoccluded * w > eps {
                    // A wall proved it hidden ([`Ctx::estimate`]).
                    return;
                }
                // The accepted value comes from fresh pairs: the deciding estimate is
                // biased low (small estimates are the ones accepted), and so is a "wholly
                // hidden" verdict from a few rays.
                let (k, vis) = if k > 0.0 || hidden {
                    let m = self.opts.samples.max(1);
                    let partial = vis < 1.0;
                    let rays = partial || self.walls;
                    self.fresh_value(r, s, if partial { 2 * m } else { m }, rays, vis)
                } else {
                    (k, vis)
                };
                // By default a "wholly hidden" verdict that the fresh rays contradict
                // was wrong: the link is partly visible, so its error is its whole
                // unoccluded factor (the leaves that see the source would get the
                // receiver's mean, a fraction of theirs), and it is refined like any
                // partly visible link. That lets the fresh rays decide, and a link
                // refined when they contradict the verdict and dropped when they do not
                // loses v·F·(1 − v)^(rays) on average, every such link the same sign.
                let contradicted = !self.walls && hidden && vis > 0.0 && unoccluded * w > eps;
                if !contradicted {
                    if k > 0.0 {
                        out.push(Link {
                            r,
                            s,
                            k: k as f32,
                            vis: (vis * 255.0).round() as u8,
                        });
                    }
                    return;
                }
            }
        }
        let split_receiver = !rl && (sl || t.size(r) >= t.size(s));
        if split_receiver {
            self.split_receiver(r, s, out)
        } else {
            self.split_source(r, s, out)
        }
    }

    /// How much a partly visible link's factor counts against ε at receiver r: 1 at a
    /// patch; [`PARTIAL_CLUSTER`] at a cluster, whose leaves may see the source far
    /// more or less than their mean (see there).
    fn partial_weight(&self, r: u32) -> f64 {
        if self.tree.is_leaf(r) {
            1.0
        } else {
            PARTIAL_CLUSTER
        }
    }

    fn split_source(&self, r: u32, s: u32, out: &mut Vec<Link>) {
        for c in self.tree.kids(s) {
            self.link(r, c, out);
        }
    }

    fn split_receiver(&self, r: u32, s: u32, out: &mut Vec<Link>) {
        let [a, b] = self.tree.kids(r);
        let (lo, hi) = self.tree.span[r as usize];
        if hi - lo > PARALLEL_LEAVES {
            let (mut va, mut vb) = (Vec::new(), Vec::new());
            rayon::join(|| self.link(a, s, &mut va), || self.link(b, s, &mut vb));
            out.extend(va);
            out.extend(vb);
        } else {
            self.link(a, s, out);
            self.link(b, s, out);
        }
    }

    /// True when s lies wholly behind r's plane, or r wholly behind s's (planar s).
    fn culled(&self, r: u32, s: u32) -> bool {
        let t = self.tree;
        let behind = |plane: u32, node: u32| -> bool {
            let (n, p) = t.planes[plane as usize];
            let (lo, hi) = (t.lo[node as usize], t.hi[node as usize]);
            let tol = 1e-9 + 1e-7 * t.size(node);
            // The box corner farthest along n.
            let far = DVec3::new(
                if n.x > 0.0 { hi.x } else { lo.x },
                if n.y > 0.0 { hi.y } else { lo.y },
                if n.z > 0.0 { hi.z } else { lo.z },
            );
            n.dot(far - p) <= tol
        };
        let (pr, ps) = (t.plane[r as usize], t.plane[s as usize]);
        behind(pr, s) || (ps != NONE && behind(ps, r))
    }

    /// Whether a wall of the scene lies between r and s and blocks every segment between
    /// their boxes ([`crate::geometry::blocker`]).
    fn walled(&self, r: u32, s: u32) -> bool {
        let t = self.tree;
        let bx = |k: u32| (t.lo[k as usize], t.hi[k as usize]);
        crate::geometry::blocker::wall_between(self.bvh, bx(r), bx(s))
    }

    /// Patch to patch, as the dense mode computes it.
    fn leaf_link(&self, r: u32, s: u32) -> Option<Link> {
        let (a, b) = (&self.geo[r as usize], &self.geo[s as usize]);
        if !face_each_other(a, b) {
            return None;
        }
        let f = directed(a, b, &self.quad, quadrature_level(a, b));
        if f <= 0.0 {
            return None;
        }
        let fmax = f * (a.area / b.area).max(1.0);
        let v = visible_fraction(
            a,
            b,
            Rng::new(r as usize, s as usize),
            fmax,
            self.bvh,
            &self.ff,
        );
        (v > 0.0).then(|| Link {
            r,
            s,
            k: (f * v) as f32,
            vis: (v * 255.0).round() as u8,
        })
    }

    /// A point of node `k` (area-distributed, by the stratum `u` in 0..1), with its
    /// element's normal and scene triangle.
    fn sample(&self, k: u32, mut u: f64, rng: &mut Rng) -> PatchPoint {
        let t = self.tree;
        let mut k = k;
        while !t.is_leaf(k) {
            let [a, b] = t.kids(k);
            let pa = (t.area[a as usize] / t.area[k as usize]).clamp(0.0, 1.0);
            if u < pa {
                u = (u / pa.max(1e-300)).min(1.0);
                k = a;
            } else {
                u = ((u - pa) / (1.0 - pa).max(1e-300)).clamp(0.0, 1.0);
                k = b;
            }
        }
        self.geo[k as usize].point(rng.next_f64(), rng.next_f64())
    }

    /// What the point pairs of the link r ← s share.
    #[inline]
    fn ends(&self, r: u32, s: u32) -> LinkEnds {
        let t = self.tree;
        LinkEnds {
            r,
            s,
            nr: t.planes[t.plane[r as usize] as usize].0,
            area_s: t.area[s as usize],
            leaf_source: t.is_leaf(s),
            cluster_receiver: t.is_leaf(r) && self.geo[r as usize].cluster.is_some(),
        }
    }

    /// The turn of the source strata against the receiver strata for one set of `count`
    /// point pairs ([`Ctx::pair`]): uniform in 0..count with per-group accuracy, else 0
    /// (and no random number drawn, so the default bake is unchanged).
    fn pair_shift(&self, count: u32, rng: &mut Rng) -> u32 {
        if self.walls {
            rng.index(count as usize) as u32
        } else {
            0
        }
    }

    /// Pair `k` of `count` stratified point pairs of the link `e`: a point of the
    /// receiver and a point of the source. Receiver strata in order, source strata
    /// reversed and turned by `shift` (drawn once per set of pairs, see
    /// [`Ctx::pair_shift`]).
    ///
    /// A random turn is what makes the pairs unbiased: every receiver stratum then
    /// meets every source stratum with the same chance. A fixed pairing samples a few of
    /// the count² stratum pairs only, and a visibility that depends on both ends (light
    /// through a door or a window, seen from one end of a room and not the other) is then
    /// missed or counted in every estimate alike: on the three-room scene of
    /// `benches/doors` the links from the lit room read 17 % of its light into the room
    /// two openings away as hidden.
    #[inline]
    fn pair(
        &self,
        e: &LinkEnds,
        k: u32,
        count: u32,
        shift: u32,
        rng: &mut Rng,
    ) -> (PatchPoint, PatchPoint) {
        let ur = rng.stratum(k as usize, count as usize);
        let js = (count - 1 - k + shift) % count;
        let us = rng.stratum(js as usize, count as usize);
        let x = self.sample(e.r, ur, rng);
        let y = self.sample(e.s, us, rng);
        (x, y)
    }

    /// Whether the segment x → y is blocked (the triangles they lie on skipped).
    #[inline]
    fn blocked(&self, x: &PatchPoint, y: &PatchPoint) -> bool {
        self.bvh.occluded(
            Vec3A::from(x.x.as_vec3()),
            Vec3A::from(y.x.as_vec3()),
            [x.source, y.source],
        )
    }

    /// The unoccluded factor estimate of one point pair of the link `e`: from x (on the
    /// receiver) to the whole source when it is a patch (exact), else to the point y
    /// standing for the source's area. A cluster patch receives with the normal of the
    /// element x lies on.
    #[inline]
    fn pair_factor(&self, e: &LinkEnds, x: &PatchPoint, y: &PatchPoint) -> f64 {
        let nr = if e.cluster_receiver { x.n } else { e.nr };
        if e.leaf_source {
            self.geo[e.s as usize].seen_from(x.x, nr)
        } else {
            let d = y.x - x.x;
            let d2 = d.length_squared();
            if d2 > 0.0 {
                let cr = nr.dot(d).max(0.0);
                let cs = (-y.n.dot(d)).max(0.0);
                e.area_s * cr * cs / (PI * d2 * d2)
            } else {
                0.0
            }
        }
    }

    /// The value of an accepted link from `count` fresh stratified pairs, independent of
    /// the ones that decided to accept it (a value from those would be biased low: small
    /// estimates are the ones accepted). With `rays`, each pair also traces its own
    /// visibility ray and the factor is the mean of factor × visibility; else `vis`
    /// scales the mean factor.
    fn fresh_value(&self, r: u32, s: u32, count: u32, rays: bool, vis: f64) -> (f64, f64) {
        let e = self.ends(r, s);
        let mut rng = Rng::new(r as usize ^ (1 << 40), s as usize ^ (1 << 41));
        let (mut sum, mut free) = (0.0, 0u32);
        let shift = self.pair_shift(count, &mut rng);
        for k in 0..count {
            let (x, y) = self.pair(&e, k, count, shift, &mut rng);
            let f = self.pair_factor(&e, &x, &y);
            if rays {
                if !self.blocked(&x, &y) {
                    free += 1;
                    sum += f;
                }
            } else {
                sum += f;
            }
        }
        let count = count.max(1) as f64;
        if rays {
            (sum / count, free as f64 / count)
        } else {
            (vis * sum / count, vis)
        }
    }

    /// Factor, error bound, visible fraction and unoccluded factor of the link r ← s.
    ///
    /// The unoccluded factor F is the mean over [`HierarchyOptions::samples`] stratified
    /// point pairs, its error their spread (max − min). Visibility is a separate estimate,
    /// the unblocked fraction of `N = clamp(8 F/ε, samples, MAX_LINK_RAYS)` rays: a link
    /// whose rays all agree is accepted as wholly visible or hidden, and the chance that
    /// N rays all miss a part visible with fraction v is (1 − v)^N, so the error of that
    /// decision, v·F·(1 − v)^N ≤ F/(e·N), stays below ε/20 (and below 0.3 % of F) while
    /// N is not capped. A partly visible link's error is its whole factor: it is refined
    /// until the factor is below ε (shadow boundaries), ε / [`PARTIAL_CLUSTER`] at a
    /// cluster receiver. Pairs that all see zero bound nothing (the error is infinite:
    /// split).
    ///
    /// With per-group accuracy a link whose factor exceeds that bound stops at its first
    /// rays: seen both ways it is split (an infinite error); its first `samples` rays all
    /// blocked, it is hidden (factor, error and visibility 0) where a wall proves it
    /// ([`Ctx::walled`]), else split.
    fn estimate(&self, r: u32, s: u32, eps: f64) -> (f64, f64, f64, f64) {
        let m = self.opts.samples.max(1);
        let e = self.ends(r, s);
        let mut rng = Rng::new(r as usize, s as usize);
        let (mut sum, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
        let mut pairs = Vec::with_capacity(m as usize);
        let shift = self.pair_shift(m, &mut rng);
        for k in 0..m {
            let (x, y) = self.pair(&e, k, m, shift, &mut rng);
            let f = self.pair_factor(&e, &x, &y);
            pairs.push((x, y));
            sum += f;
            lo = lo.min(f);
            hi = hi.max(f);
        }
        let f = sum / m as f64;
        if f <= 0.0 {
            // Every pair saw the other end edge-on or from behind, yet the nodes are not
            // wholly behind each other (`culled`): a front-facing part may lie between the
            // samples. Zero pairs bound nothing, so the link is split, not dropped.
            return (0.0, f64::INFINITY, 1.0, 0.0);
        }
        let rays =
            ((8.0 * f / eps).ceil().min(u32::MAX as f64) as u32).clamp(m, MAX_LINK_RAYS.max(m));
        // A link too large to keep partly visible is settled by its first rays.
        let settle = self.walls && f * self.partial_weight(r) > eps;
        let mut free = 0u32;
        for k in 0..rays {
            let (x, y) = match pairs.get(k as usize) {
                Some(p) => *p,
                None => {
                    let u = rng.stratum(k as usize, rays as usize);
                    let x = self.sample(r, u, &mut rng);
                    let y = self.sample(s, rng.next_f64(), &mut rng);
                    (x, y)
                }
            };
            free += u32::from(!self.blocked(&x, &y));
            if settle {
                // Partly visible or hidden, the link is split unless a wall proves it
                // hidden: the other rays would decide nothing. Rays that saw both ways
                // settle it at once; the first `m` all blocked ask for the wall.
                let traced = k + 1;
                if free > 0 && free < traced {
                    return (0.0, f64::INFINITY, 1.0, f);
                }
                if free == 0 && traced == m {
                    return if self.walled(r, s) {
                        (0.0, 0.0, 0.0, f)
                    } else {
                        (0.0, f64::INFINITY, 1.0, f)
                    };
                }
            }
        }
        let vis = free as f64 / rays as f64;
        let spread = if free == 0 || free == rays {
            // Rays that all agree may miss a part seen (or hidden) with fraction
            // v ≈ 1/N: at most F/(e·N) of light, below ε/(8e) while N = 8F/ε.
            (hi - lo) * vis
        } else {
            f * self.partial_weight(r)
        };
        (f * vis, spread, vis, f)
    }
}

/// The link r ← s as its point pairs see it.
struct LinkEnds {
    r: u32,
    s: u32,
    /// The receiver's plane normal.
    nr: DVec3,
    area_s: f64,
    /// The source is a patch (its factor is exact from each receiver point).
    leaf_source: bool,
    /// The receiver is a cluster patch: each point receives with its element's normal.
    cluster_receiver: bool,
}
