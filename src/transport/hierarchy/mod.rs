//! Clustered hierarchical radiosity (Hanrahan, Salzman & Aupperle 1991; clusters after
//! Smits, Arvo & Greenberg 1994): the form factors as links between nodes of a cluster
//! tree instead of an n × n matrix.
//!
//! - [`tree`]: patches → coplanar clusters → mixed clusters, one root.
//! - [`refine`]: links from receiver nodes to source nodes, refined by an error oracle
//!   (the spread of the factor over sample pairs, visibility included) until below ε.
//! - [`closure`]: each patch's factor sum checked against rays and rescaled.
//! - [`importance`]: the dark-room pass: after a first solve, links refined again where
//!   their error is large next to what their receiver gathers in some light group.
//! - [`Hierarchy::solve`]: gather, push and pull (Jacobi) to a stated tolerance.
//!
//! Storage is compact: per link a u32 source, an f32 factor and a u8 visibility, grouped
//! by receiver (CSR offsets); per internal node its two children; per patch σ.

pub mod closure;
pub mod importance;
pub mod refine;
pub mod tree;

use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::transport::formfactor::{patch_geometry, FormFactorOptions};
pub use importance::DarkRoomPass;
pub use refine::HierarchyOptions;
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

/// A solve's result, per patch and column (row-major n × C).
pub struct HierarchySolution {
    /// Radiosity, lm/m².
    pub b: Vec<f32>,
    /// Irradiance gathered through the links, lux (direct light not included).
    pub h: Vec<f32>,
    pub sweeps: usize,
    /// Largest relative residual `‖S − (B − ρH)‖∞ / ‖S‖∞` over the columns.
    pub residual: f64,
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

    /// The irradiance `H = σ K B` (n × c) that the patch radiosities `b` (n × c) give.
    pub fn irradiance(&self, b: &[f32], c: usize) -> Vec<f32> {
        let mut x = vec![0f32; self.nodes() * c];
        x[..self.n * c].copy_from_slice(&b[..self.n * c]);
        self.pull(&mut x, c);
        self.gather(&x, c)
    }

    /// Area means of `c` columns from the leaves up (`x` is nodes × c; leaves filled).
    fn pull(&self, x: &mut [f32], c: usize) {
        for (k, ch) in self.children.iter().enumerate() {
            let node = self.n + k;
            let (wa, wb) = (self.area[ch[0] as usize], self.area[ch[1] as usize]);
            let inv = 1.0 / self.area[node].max(f32::MIN_POSITIVE);
            let (lo, hi) = x.split_at_mut(node * c);
            let (a, b) = (ch[0] as usize * c, ch[1] as usize * c);
            for j in 0..c {
                hi[j] = (wa * lo[a + j] + wb * lo[b + j]) * inv;
            }
        }
    }

    /// `σ · Σ_links k · x_s` at every patch, links of ancestors included (push).
    fn gather(&self, x: &[f32], c: usize) -> Vec<f32> {
        let mut g = Vec::new();
        self.gather_into(x, c, &mut g);
        g.truncate(self.n * c);
        g
    }

    /// [`Hierarchy::gather`] into `g` (resized to nodes × c; the patches' rows come
    /// first), so that sweeps reuse one buffer: at a few hundred columns it is hundreds of
    /// MB, and a fresh one per sweep cost as much time in page faults as in arithmetic.
    fn gather_into(&self, x: &[f32], c: usize, g: &mut Vec<f32>) {
        g.clear();
        g.resize(self.nodes() * c, 0.0);
        g.par_chunks_mut(c)
            .enumerate()
            .with_min_len(256)
            .for_each(|(r, acc)| {
                let links = &self.links;
                for l in links.of(r) {
                    let (k, s) = (links.k[l], links.src[l] as usize * c);
                    for (o, &v) in acc.iter_mut().zip(&x[s..s + c]) {
                        *o += k * v;
                    }
                }
            });
        for k in (0..self.children.len()).rev() {
            let p = (self.n + k) * c;
            for ch in self.children[k] {
                let q = ch as usize * c;
                for j in 0..c {
                    g[q + j] += g[p + j];
                }
            }
        }
        g[..self.n * c]
            .par_chunks_mut(c)
            .zip(&self.sigma)
            .for_each(|(row, &s)| row.iter_mut().for_each(|v| *v *= s));
    }

    /// Solves `B = S + ρ H`, `H = σ K B` for `c` columns of sources `s` (n × c row-major,
    /// lm/m²); column j uses the reflectance channel j % 3. Jacobi sweeps until, in every
    /// column, the largest change is at most `tol` of the largest reflected radiosity ρH
    /// (emitters' own exitance does not set the scale), at most `max_sweeps`.
    pub fn solve(
        &self,
        rho: &[Rgb],
        s: &[f32],
        c: usize,
        tol: f64,
        max_sweeps: usize,
        progress: &(dyn Fn(f64) + Sync),
    ) -> HierarchySolution {
        let n = self.n;
        let mut x = vec![0f32; self.nodes() * c];
        x[..n * c].copy_from_slice(&s[..n * c]);
        let mut sweeps = 0;
        let mut h = Vec::new();
        loop {
            self.pull(&mut x, c);
            self.gather_into(&x, c, &mut h);
            if sweeps >= max_sweeps {
                break;
            }
            sweeps += 1;
            // Per column: the largest change and the largest reflected radiosity ρH.
            let zero = || (vec![0f32; c], vec![0f32; c]);
            let (change, top) = x[..n * c]
                .par_chunks_mut(c)
                .zip(s.par_chunks(c))
                .zip(h.par_chunks(c))
                .zip(rho.par_iter())
                .fold(zero, |(mut ch, mut top), (((b, s), h), r)| {
                    for j in 0..c {
                        let reflected = r[j % 3] * h[j];
                        let v = s[j] + reflected;
                        ch[j] = ch[j].max((v - b[j]).abs());
                        top[j] = top[j].max(reflected.abs());
                        b[j] = v;
                    }
                    (ch, top)
                })
                .reduce(zero, |mut a, b| {
                    for j in 0..c {
                        a.0[j] = a.0[j].max(b.0[j]);
                        a.1[j] = a.1[j].max(b.1[j]);
                    }
                    a
                });
            let converged = change
                .iter()
                .zip(&top)
                .all(|(&ch, &t)| ch as f64 <= tol * t as f64);
            progress((sweeps as f64 / 60.0).min(0.99));
            if converged {
                self.pull(&mut x, c);
                self.gather_into(&x, c, &mut h);
                break;
            }
        }
        x.truncate(n * c);
        h.truncate(n * c);
        let residual = residual(&x, s, &h, rho, c);
        HierarchySolution {
            b: x,
            h,
            sweeps,
            residual,
        }
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
    /// Per-group accuracy (scene.toml `per_group_accuracy`): unbiased link values, hidden
    /// links kept as zero links, and the dark-room pass at assembly ([`importance`]).
    per_group: bool,
}

impl Plan {
    pub fn new(mesh: &Mesh, rho: &[Rgb], sources: &[f64]) -> Plan {
        Plan {
            tree: Tree::build(mesh),
            geo: patch_geometry(mesh),
            glow: glow(mesh, rho, sources),
            per_group: false,
        }
    }

    /// The plan with per-group accuracy on or off (off by default): see
    /// [`importance`]. Every part of a sharded bake must be planned alike.
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
    /// With `dark` and per-group accuracy, the assembled links go through the dark-room
    /// pass ([`importance`]).
    pub fn assemble(
        self,
        parts: Vec<Part>,
        opts: HierarchyOptions,
        dark: Option<&DarkRoomPass<'_>>,
    ) -> Result<(Hierarchy, Vec<f32>), String> {
        check_cover(&self.tree, &parts)?;
        let joined = Joined::new(&self.tree, parts)?;
        let mut refine_s = joined.refine_s;
        let mut links = joined.links;
        let (mut h, mut escape) = self.close(&links, &joined.hits, opts);
        if let Some(pass) = dark.filter(|_| self.per_group) {
            let t0 = Instant::now();
            if let Some(imp) = importance::Importance::solve(&self.tree, &h, pass) {
                drop(h);
                links = refine::refine_again(&self, pass.bvh, opts, pass.ff, &imp, links);
                drop(imp);
                links.par_sort_unstable_by_key(|l| (l.r, l.s, l.k.to_bits(), l.vis));
                (h, escape) = self.close(&links, &joined.hits, opts);
            }
            refine_s += t0.elapsed().as_secs_f64();
        }
        h.stats.refine_s = refine_s;
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
    /// Zero links (hidden ones the refinement keeps for the dark-room pass) are left out.
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

/// Most emitting scene triangles whose first reflection enters the glow estimate
/// ([`emitter_bounce`]): the brightest by flux.
pub const GLOW_EMITTERS: usize = 64;

/// Visibility rays per patch and emitting triangle in [`emitter_bounce`].
const GLOW_RAYS: u32 = 4;

/// The first reflection of the emitting surfaces' light, `ρ̄_i Σ_t M_t F(x_i → t) v_it`
/// (lm/m², channel mean, all groups at intensity 1), estimated at each patch's centroid
/// with the exact point-to-triangle factor and [`GLOW_RAYS`] visibility rays, from the
/// [`GLOW_EMITTERS`] brightest emitting scene triangles. Only the refinement uses it (as
/// part of the glow, where luminaires' direct light already is), so an estimate does.
pub fn emitter_bounce(
    scene: &crate::scene::Scene,
    mesh: &Mesh,
    bvh: &Bvh,
    rho: &[Rgb],
    emission: &[f64],
) -> Vec<f64> {
    // Emitting scene triangles with their exitance (the mean over their patches).
    let mut tri_m: std::collections::BTreeMap<u32, (f64, f64)> = Default::default();
    for (p, &e) in mesh.patches.iter().zip(emission) {
        if e > 0.0 {
            let t = tri_m.entry(p.source).or_default();
            t.0 += e * p.area;
            t.1 += p.area;
        }
    }
    let mut emitters: Vec<(u32, f64, f64)> = tri_m
        .into_iter()
        .filter(|(_, (flux, area))| *flux > 0.0 && *area > 0.0)
        .map(|(t, (flux, area))| (t, flux, flux / area))
        .collect();
    emitters.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    emitters.truncate(GLOW_EMITTERS);
    if emitters.is_empty() {
        return vec![0.0; mesh.len()];
    }
    let geo = patch_geometry(mesh);
    (0..mesh.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let g = &geo[i];
            let r = &rho[i];
            let rho_mean = (r[0] + r[1] + r[2]) as f64 / 3.0;
            if rho_mean <= 0.0 {
                return 0.0;
            }
            let mut rng = crate::sampling::Rng::new(i, usize::MAX - 1);
            let mut h = 0.0;
            for &(t, _, m) in &emitters {
                if t == g.source {
                    continue;
                }
                let c = scene.triangles[t as usize].p;
                let front = (c[1] - c[0]).cross(c[2] - c[0]);
                if front.dot(g.centroid - c[0]) <= 0.0 {
                    continue;
                }
                let f = crate::transport::formfactor::point_to_polygon(g.centroid, g.n, &c);
                if f <= 0.0 {
                    continue;
                }
                let x = glam::Vec3A::from((g.centroid + g.n * (1e-6 * g.size)).as_vec3());
                let free = (0..GLOW_RAYS)
                    .filter(|_| {
                        let y =
                            crate::sampling::sample_triangle(&c, rng.next_f64(), rng.next_f64());
                        !bvh.occluded(x, glam::Vec3A::from(y.as_vec3()), [g.source, t])
                    })
                    .count();
                h += m * f * free as f64 / GLOW_RAYS as f64;
            }
            rho_mean * h
        })
        .collect()
}

/// Each patch's source term over the scene's mean radiosity, estimated as the sources'
/// flux over the area, divided by (1 − ρ̄) for the interreflections (ρ̄ the area mean of
/// the reflectance, at most 0.9).
fn glow(mesh: &Mesh, rho: &[Rgb], sources: &[f64]) -> Vec<f32> {
    let (mut flux, mut area, mut rho_a) = (0.0, 0.0, 0.0);
    for ((p, s), r) in mesh.patches.iter().zip(sources).zip(rho) {
        flux += p.area * s;
        area += p.area;
        rho_a += p.area * (r[0] + r[1] + r[2]) as f64 / 3.0;
    }
    if flux <= 0.0 || area <= 0.0 {
        return vec![0.0; mesh.len()];
    }
    let mean = flux / area / (1.0 - (rho_a / area).min(0.9));
    sources.iter().map(|&s| (s / mean) as f32).collect()
}

/// Largest relative residual `‖S − (B − ρH)‖∞ / ‖S‖∞` over the columns.
fn residual(b: &[f32], s: &[f32], h: &[f32], rho: &[Rgb], c: usize) -> f64 {
    let mut worst = 0f64;
    for j in 0..c {
        let (mut num, mut den) = (0f64, 0f64);
        for (i, rh) in rho.iter().enumerate() {
            let k = i * c + j;
            let r = s[k] as f64 - (b[k] as f64 - rh[j % 3] as f64 * h[k] as f64);
            num = num.max(r.abs());
            den = den.max(s[k].abs() as f64);
        }
        if den > 0.0 {
            worst = worst.max(num / den);
        }
    }
    worst
}
