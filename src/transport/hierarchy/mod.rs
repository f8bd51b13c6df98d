//! Clustered hierarchical radiosity (Hanrahan, Salzman & Aupperle 1991; clusters after
//! Smits, Arvo & Greenberg 1994): the form factors as links between nodes of a cluster
//! tree instead of an n × n matrix.
//!
//! - [`tree`]: patches → coplanar clusters → mixed clusters, one root.
//! - [`refine`]: links from receiver nodes to source nodes, refined by an error oracle
//!   (the spread of the factor over sample pairs, visibility included) until below ε.
//! - [`closure`]: each patch's factor sum checked against rays and rescaled.
//! - `glow.rs`: each patch's expected brightness, which weighs the refinement's errors.
//! - `sweeps.rs`: [`Hierarchy::solve`], gather, push and pull (Jacobi) to a stated
//!   tolerance: the bake's many columns.
//! - `krylov.rs`: [`Hierarchy::solve_krylov`], GMRES through the same links: a request's
//!   few emission columns in fewer passes.
//!
//! Storage is compact: per link a u32 source, an f32 factor and a u8 visibility, grouped
//! by receiver (CSR offsets); per internal node its two children; per patch σ.

pub mod closure;
mod coarse;
mod glow;
mod krylov;
pub mod refine;
mod sweeps;
pub mod tree;

use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::transport::formfactor::{patch_geometry, FormFactorOptions};
pub use coarse::{Coarse, COARSE_CLUSTERS, MAX_CLUSTERS};
pub use glow::{emitter_bounce, GLOW_EMITTERS};
pub use krylov::{Preconditioner, KRYLOV_BYTES};
pub use refine::HierarchyOptions;
pub use sweeps::HierarchySolution;
use tree::Tree;

/// Bytes per link in memory and in the cache: source u32, factor f32, visibility u8, and
/// the receiver's u32 while the links are sorted.
pub const BYTES_PER_LINK: u64 = 9;

/// Figures of a hierarchy's construction.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct HierarchyStats {
    pub nodes: u64,
    pub links: u64,
    /// Links between two patches.
    pub leaf_links: u64,
    /// Mean and largest |S_i − (1 − escape_i)| before closure: how far the links' factor
    /// sums were from the rays' estimate.
    pub closure_mean: f64,
    pub closure_max: f64,
    /// Range of the closure scale σ.
    pub sigma_min: f64,
    pub sigma_max: f64,
    /// Seconds for refinement and for the closure rays.
    pub refine_s: f64,
    pub closure_s: f64,
}

/// The links of a scene, immutable once built.
#[derive(Clone)]
pub struct Hierarchy {
    /// Patches (leaves).
    pub n: usize,
    /// Children of internal node `n + k`; parents come after their children.
    pub children: Vec<[u32; 2]>,
    pub links: Links,
    /// Closure scale of each patch's gathered irradiance.
    pub sigma: Vec<f32>,
    /// Area of every node, m² (from the patches; not stored).
    pub area: Vec<f32>,
    pub stats: HierarchyStats,
}

/// The links of a [`Hierarchy`] by receiver node (compressed rows), as the cache stores
/// them (under the fields' names).
#[derive(Clone)]
pub struct Links {
    /// Links of receiver node r are `offsets[r] .. offsets[r + 1]`.
    pub offsets: Vec<u32>,
    pub src: Vec<u32>,
    /// Factor of each link: irradiance at the receiver (lux) per lm/m² of the source.
    pub k: Vec<f32>,
    /// Visible fraction of each link, 0..=255.
    pub vis: Vec<u8>,
}

impl Links {
    /// The links of receiver node `r`.
    #[inline]
    fn of(&self, r: usize) -> std::ops::Range<usize> {
        self.offsets[r] as usize..self.offsets[r + 1] as usize
    }

    /// Bytes held.
    fn bytes(&self) -> u64 {
        4 * (self.offsets.capacity() + self.src.capacity() + self.k.capacity()) as u64
            + self.vis.capacity() as u64
    }
}

impl Hierarchy {
    /// Rebuilds a hierarchy from its stored parts over patches of area `leaf_area`; None
    /// when they are inconsistent.
    pub fn from_parts(
        leaf_area: &[f32],
        children: Vec<[u32; 2]>,
        links: Links,
        sigma: Vec<f32>,
        stats: HierarchyStats,
    ) -> Option<Hierarchy> {
        let Links {
            offsets,
            src,
            k,
            vis,
        } = &links;
        let n = leaf_area.len();
        let nodes = n + children.len();
        let count = src.len();
        let ok = n > 0
            && children.len() + 1 == n
            && offsets.len() == nodes + 1
            && offsets.first() == Some(&0)
            && offsets.last().map(|&x| x as usize) == Some(count)
            && offsets.windows(2).all(|w| w[0] <= w[1])
            && k.len() == count
            && vis.len() == count
            && sigma.len() == n
            && src.iter().all(|&s| (s as usize) < nodes)
            && children
                .iter()
                .enumerate()
                .all(|(i, c)| c.iter().all(|&x| (x as usize) < n + i));
        if !ok {
            return None;
        }
        let mut area = leaf_area.to_vec();
        for c in &children {
            area.push(area[c[0] as usize] + area[c[1] as usize]);
        }
        Some(Hierarchy {
            n,
            children,
            links,
            sigma,
            area,
            stats,
        })
    }

    pub fn nodes(&self) -> usize {
        self.n + self.children.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        8 * self.children.capacity() as u64
            + self.links.bytes()
            + 4 * (self.sigma.capacity() + self.area.capacity()) as u64
    }

    /// Each patch's form-factor sum through its links and its ancestors' (before closure).
    pub fn factor_sums(&self) -> Vec<f64> {
        let mut g = vec![0f64; self.nodes()];
        g.par_iter_mut().enumerate().for_each(|(r, g)| {
            *g = self.links.k[self.links.of(r)]
                .iter()
                .map(|&k| k as f64)
                .sum();
        });
        for k in (0..self.children.len()).rev() {
            let p = g[self.n + k];
            for c in self.children[k] {
                g[c as usize] += p;
            }
        }
        g.truncate(self.n);
        g
    }
}

/// The receivers' share of a hierarchical bake: the links of the receivers under some
/// plane roots, and the closure rays' hit fraction of their patches. A bake is the union
/// of parts that cover every plane once ([`Plan::shards`]); the parts can be computed
/// apart (a sharded bake) and give the same hierarchy in any grouping.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Part {
    /// The plane roots covered.
    pub roots: Vec<u32>,
    pub links: Vec<refine::Link>,
    /// (patch, hit fraction) for every patch under `roots`.
    pub hits: Vec<(u32, f64)>,
    /// Seconds for refinement and for the closure rays.
    pub refine_s: f64,
    pub closure_s: f64,
}

/// What every part of a bake starts from: the cluster tree, the patch geometry and the
/// sources' glow (see [`refine::refine`]). Deterministic for a given mesh and sources.
pub struct Plan {
    tree: Tree,
    geo: Vec<crate::transport::formfactor::PatchGeo>,
    glow: Vec<f32>,
    /// Per-group accuracy (scene.toml `per_group_accuracy`): links dropped as hidden only
    /// where a wall proves it, and unbiased link values ([`refine`]).
    per_group: bool,
}

impl Plan {
    pub fn new(mesh: &Mesh, rho: &[Rgb], sources: &[f64]) -> Plan {
        Plan {
            tree: Tree::build(mesh),
            geo: patch_geometry(mesh),
            glow: glow::glow(mesh, rho, sources),
            per_group: false,
        }
    }

    /// The plan with per-group accuracy on or off (off by default): see [`refine`].
    /// Every part of a sharded bake must be planned alike.
    pub fn per_group_accuracy(mut self, on: bool) -> Plan {
        self.per_group = on;
        self
    }

    /// Every plane's subtree root (the units parts are made of).
    pub fn plane_roots(&self) -> &[u32] {
        &self.tree.plane_roots
    }

    /// The plane roots dealt into `n` shards of similar work: largest planes (by patch
    /// count) first, each to the shard with the fewest patches so far. Deterministic.
    pub fn shards(&self, n: usize) -> Vec<Vec<u32>> {
        let n = n.max(1);
        let leaves = |r: u32| {
            let (a, b) = self.tree.span[r as usize];
            (b - a) as u64
        };
        let mut roots = self.tree.plane_roots.clone();
        roots.sort_by_key(|&r| (std::cmp::Reverse(leaves(r)), r));
        let mut shards = vec![Vec::new(); n];
        let mut load = vec![0u64; n];
        for r in roots {
            let k = (0..n).min_by_key(|&k| (load[k], k)).unwrap_or(0);
            load[k] += leaves(r);
            shards[k].push(r);
        }
        for s in &mut shards {
            s.sort_unstable();
        }
        shards
    }

    /// The links and closure hits of the receivers under `roots`.
    pub fn part(
        &self,
        roots: &[u32],
        bvh: &Bvh,
        sides: &[closure::Sides],
        opts: HierarchyOptions,
        ff: FormFactorOptions,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Part {
        let t0 = Instant::now();
        let t = &self.tree;
        let links = refine::refine(self, bvh, roots, opts, ff, progress);
        let refine_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let mut mine = vec![false; t.planes.len()];
        for &r in roots {
            if let Some(m) = mine.get_mut(t.plane[r as usize] as usize) {
                *m = true;
            }
        }
        let patches: Vec<u32> = (0..t.n as u32)
            .filter(|&i| mine[t.plane[i as usize] as usize])
            .collect();
        let hits = closure::hit_fraction(&self.geo, bvh, sides, opts.closure_rays, &patches);
        Part {
            roots: roots.to_vec(),
            links,
            hits: patches.into_iter().zip(hits).collect(),
            refine_s,
            closure_s: t1.elapsed().as_secs_f64(),
        }
    }

    /// The hierarchy from parts that cover every plane exactly once, and every patch's
    /// escape fraction; an error names what is missing or repeated. Links are sorted by
    /// (receiver, source), so the result does not depend on how the planes were grouped.
    pub fn assemble(
        self,
        parts: Vec<Part>,
        opts: HierarchyOptions,
    ) -> Result<(Hierarchy, Vec<f32>), String> {
        check_cover(&self.tree, &parts)?;
        let joined = Joined::new(&self.tree, parts)?;
        let (mut h, escape) = self.close(&joined.links, &joined.hits, opts);
        h.stats.refine_s = joined.refine_s;
        h.stats.closure_s = joined.closure_s;
        Ok((h, escape))
    }

    /// The hierarchy of `links` (sorted by receiver) with its closure from the rays' hit
    /// fractions `hits`, and every patch's escape fraction. Stats without timings.
    fn close(
        &self,
        links: &[refine::Link],
        hits: &[f64],
        opts: HierarchyOptions,
    ) -> (Hierarchy, Vec<f32>) {
        let tree = &self.tree;
        let mut h = Hierarchy::from_sorted_links(tree, links);
        let leaf_links = links
            .iter()
            .filter(|l| l.k != 0.0 && (l.r as usize) < tree.n && (l.s as usize) < tree.n)
            .count() as u64;
        let sums = h.factor_sums();
        let (sigma, escape) = closure::combine(&sums, hits, opts.closure_rays);
        let gaps: Vec<f64> = sums.iter().zip(hits).map(|(s, h)| (s - h).abs()).collect();
        h.stats = HierarchyStats {
            nodes: tree.nodes() as u64,
            links: h.links.src.len() as u64,
            leaf_links,
            closure_mean: gaps.iter().sum::<f64>() / gaps.len().max(1) as f64,
            closure_max: gaps.iter().copied().fold(0.0, f64::max),
            sigma_min: sigma
                .iter()
                .map(|&x| x as f64)
                .fold(f64::INFINITY, f64::min),
            sigma_max: sigma.iter().map(|&x| x as f64).fold(0.0, f64::max),
            refine_s: 0.0,
            closure_s: 0.0,
        };
        h.sigma = sigma;
        (h, escape)
    }
}

/// Checks that `parts` cover every plane root of `tree` exactly once.
fn check_cover(tree: &Tree, parts: &[Part]) -> Result<(), String> {
    let mut covered = vec![false; tree.nodes()];
    for r in parts.iter().flat_map(|p| &p.roots) {
        let Some(c) = covered.get_mut(*r as usize) else {
            return Err(format!("node {r} is not in the tree"));
        };
        if *c || !tree.plane_roots.contains(r) {
            return Err(format!("plane root {r} is repeated or not a plane root"));
        }
        *c = true;
    }
    if let Some(r) = tree.plane_roots.iter().find(|&&r| !covered[r as usize]) {
        return Err(format!("no part covers plane root {r}"));
    }
    Ok(())
}

/// The parts of a bake joined: all links in a total order, every patch's hit fraction,
/// and the seconds the parts took.
struct Joined {
    links: Vec<refine::Link>,
    hits: Vec<f64>,
    refine_s: f64,
    closure_s: f64,
}

impl Joined {
    /// Joins `parts`, once every patch of `tree` has one hit fraction and every link
    /// names nodes of the tree.
    fn new(tree: &Tree, parts: Vec<Part>) -> Result<Joined, String> {
        let nodes = tree.nodes();
        let mut hits = vec![f64::NAN; tree.n];
        let (mut refine_s, mut closure_s) = (0.0, 0.0);
        let mut links = Vec::with_capacity(parts.iter().map(|p| p.links.len()).sum());
        for p in parts {
            for (i, h) in p.hits {
                match hits.get_mut(i as usize) {
                    Some(slot) if slot.is_nan() => *slot = h,
                    _ => return Err(format!("patch {i} has no or two hit fractions")),
                }
            }
            if p.links
                .iter()
                .any(|l| l.r as usize >= nodes || l.s as usize >= nodes)
            {
                return Err("a link names a node outside the tree".into());
            }
            refine_s += p.refine_s;
            closure_s += p.closure_s;
            links.extend(p.links);
        }
        if let Some(i) = hits.iter().position(|h| h.is_nan()) {
            return Err(format!("patch {i} has no hit fraction"));
        }
        // A total order, so that the stored links (and every sum over them) are the same
        // bits however the parts were grouped.
        links.par_sort_unstable_by_key(|l| (l.r, l.s, l.k.to_bits(), l.vis));
        Ok(Joined {
            links,
            hits,
            refine_s,
            closure_s,
        })
    }
}

impl Hierarchy {
    /// The hierarchy of `tree` with `links` sorted by receiver (CSR), before closure (σ
    /// 1, no stats).
    /// Zero links are left out.
    fn from_sorted_links(tree: &Tree, links: &[refine::Link]) -> Hierarchy {
        let nodes = tree.nodes();
        let mut offsets = vec![0u32; nodes + 1];
        let kept = || links.iter().filter(|l| l.k != 0.0);
        for l in kept() {
            offsets[l.r as usize + 1] += 1;
        }
        for k in 0..nodes {
            offsets[k + 1] += offsets[k];
        }
        Hierarchy {
            n: tree.n,
            children: tree.children.clone(),
            links: Links {
                offsets,
                src: kept().map(|l| l.s).collect(),
                k: kept().map(|l| l.k).collect(),
                vis: kept().map(|l| l.vis).collect(),
            },
            sigma: vec![1.0; tree.n],
            area: tree.area.iter().map(|&a| a as f32).collect(),
            stats: HierarchyStats::default(),
        }
    }
}
