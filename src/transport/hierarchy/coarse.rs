//! A coarse transfer: the light of every bounce after the first, carried between
//! clusters and solved once at load, which preconditions the emission answers (GMRES in
//! [`super::krylov`]).
//!
//! The clusters are a cut of the cluster tree: the largest nodes split first (about
//! [`COARSE_CLUSTERS`]), then every cluster split until it is coherent, one plane whose
//! patches see each other (`coherent`): a cluster reaching under a wall would carry the
//! lit room's light into the dark one. With `P` the prolongation (a cluster's value on
//! every patch under it) and `R` the area mean, the Galerkin operator `K_c = R ρ H P`
//! (m × m, per channel) is assembled from the links, and `M = (I − K_c)⁻¹ K_c` is kept.
//! `v ↦ v + P M R v` approximates `(I − ρH)⁻¹`; GMRES corrects what it misses.
//!
//! Alone, as an answer in one pass (`B = E + ρH(E + P M R E)`), it was measured and not
//! kept: light through doors and near each emitter varies inside a cluster (see
//! docs/performance.md).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use faer::Mat;
use rayon::prelude::*;

use glam::Vec3A;

use super::tree::{Tree, NONE as TREE_NONE};
use super::Hierarchy;
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::transport::solve::solve_general_in_place;

const NONE: u32 = u32::MAX;

/// Clusters the cut starts from ([`Hierarchy::coarse`]); coherence splits more.
pub const COARSE_CLUSTERS: usize = 1000;
/// Most clusters: `M` is 3 × m² floats (201 MB at this bound). Past it, clusters that
/// are not coherent stay as they are.
pub const MAX_CLUSTERS: usize = 4096;

/// The coarse transfer of a [`Hierarchy`]: immutable once built.
#[derive(Clone)]
pub struct Coarse {
    /// Cluster of every patch.
    pub cluster: Vec<u32>,
    /// Area of every cluster, m².
    pub area: Vec<f32>,
    /// Per channel, `M = (I − K_c)⁻¹ K_c` (m × m, column-major): the reflected
    /// radiosity of every cluster (lm/m²) per lm/m² emitted over a cluster.
    pub transfer: [Mat<f32>; 3],
}

/// A node and its area, ordered by area (then by index, so the cut is deterministic).
#[derive(PartialEq)]
struct ByArea(f32, u32);
impl Eq for ByArea {}
impl PartialOrd for ByArea {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for ByArea {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

impl Hierarchy {
    /// The cut: from the root, the node of largest area is split until there are `m`
    /// (patches are not split); then every cluster that is not coherent is split until
    /// it is (see [`coherent`]). Returns the cluster roots.
    fn cut(&self, m: usize, coherent: &(dyn Fn(u32) -> bool + Sync)) -> Vec<u32> {
        let root = (self.nodes() - 1) as u32;
        let mut heap = BinaryHeap::from([ByArea(self.area[root as usize], root)]);
        let mut first = Vec::new();
        while let Some(ByArea(_, k)) = heap.pop() {
            if heap.len() + first.len() + 1 >= m || (k as usize) < self.n {
                first.push(k);
                if heap.len() + first.len() >= m {
                    first.extend(heap.drain().map(|b| b.1));
                }
                continue;
            }
            for c in self.children[k as usize - self.n] {
                heap.push(ByArea(self.area[c as usize], c));
            }
        }
        // Split the clusters that are not coherent, largest first, while the count
        // allows: each round splits the frontier and tests the children.
        let test = |ks: &[u32]| -> Vec<(u32, bool)> {
            ks.par_iter()
                .map(|&k| (k, (k as usize) < self.n || coherent(k)))
                .collect()
        };
        let mut done = Vec::new();
        let mut frontier = Vec::new();
        for (k, ok) in test(&first) {
            if ok {
                done.push(k);
            } else {
                frontier.push(k);
            }
        }
        while !frontier.is_empty() {
            // Splitting a node adds one cluster.
            let room = MAX_CLUSTERS.saturating_sub(done.len() + frontier.len());
            frontier.sort_unstable_by(|&a, &b| {
                self.area[b as usize]
                    .total_cmp(&self.area[a as usize])
                    .then(a.cmp(&b))
            });
            let keep = frontier.split_off(room.min(frontier.len()));
            done.extend(keep);
            let kids: Vec<u32> = frontier
                .iter()
                .flat_map(|&k| self.children[k as usize - self.n])
                .collect();
            frontier.clear();
            for (k, ok) in test(&kids) {
                if ok {
                    done.push(k);
                } else {
                    frontier.push(k);
                }
            }
        }
        done.sort_unstable();
        done
    }

    /// The coarse transfer with about `m` clusters for reflectances `rho`.
    pub fn coarse(&self, mesh: &Mesh, bvh: &Bvh, rho: &[Rgb], m: usize) -> Coarse {
        let tree = Tree::build(mesh);
        let roots = self.cut(m.max(1), &|k| coherent(&tree, mesh, bvh, k));
        let cut = Cut::new(&tree, roots);
        let asig = self.area_sigma();
        let k_c = self.galerkin(&cut, &asig);
        let rho_bar = cut.mean_rho(&asig, rho, self.n);
        Coarse {
            cluster: cut.cl[..self.n].to_vec(),
            area: cut.roots.iter().map(|&r| self.area[r as usize]).collect(),
            transfer: [0, 1, 2].map(|j| channel_transfer(&k_c, &rho_bar, j)),
        }
    }

    /// Σ A σ over the patches under every node.
    fn area_sigma(&self) -> Vec<f64> {
        let mut asig = vec![0f64; self.nodes()];
        for (a, (&area, &sigma)) in asig.iter_mut().zip(self.area.iter().zip(&self.sigma)) {
            *a = area as f64 * sigma as f64;
        }
        for (k, ch) in self.children.iter().enumerate() {
            asig[self.n + k] = asig[ch[0] as usize] + asig[ch[1] as usize];
        }
        asig
    }

    /// `K_c = R σ H P` without ρ (m × m), from the links.
    ///
    /// A table whose rows and columns are the clusters, then the upper nodes: a cluster
    /// row holds the links at and below the cluster, an upper row the raw factors of the
    /// upper node's links. Upper sources are spread to the clusters below them (their
    /// value is the clusters' area mean), then upper receivers (their irradiance reaches
    /// every patch below them).
    fn galerkin(&self, cut: &Cut, asig: &[f64]) -> Mat<f32> {
        let (n, m, w) = (self.n, cut.roots.len(), cut.width());
        // Fine receivers grouped by their row of the table.
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); w];
        for r in 0..self.nodes() {
            if !self.links.of(r).is_empty() {
                rows[cut.col(r)].push(r as u32);
            }
        }
        let mut table = vec![0f32; w * w];
        table
            .par_chunks_mut(w)
            .zip(&rows)
            .enumerate()
            .for_each(|(row, (out, rs))| {
                for &r in rs {
                    let r = r as usize;
                    let wr = if row < m {
                        (asig[r] / pos(self.area[cut.roots[row] as usize]) as f64) as f32
                    } else {
                        1.0
                    };
                    for l in self.links.of(r) {
                        out[cut.col(self.links.src[l] as usize)] += wr * self.links.k[l];
                    }
                }
                for (i, &s) in cut.upper.iter().enumerate() {
                    let v = out[m + i];
                    if v == 0.0 {
                        continue;
                    }
                    let s = s as usize;
                    for ch in self.children[s - n] {
                        out[cut.col(ch as usize)] += v * self.area[ch as usize] / pos(self.area[s]);
                    }
                }
            });
        for (i, &r) in cut.upper.iter().enumerate() {
            let src = table[(m + i) * w..(m + i) * w + m].to_vec();
            for ch in self.children[r as usize - n] {
                let ch = ch as usize;
                let dst = cut.col(ch);
                let f = if dst < m {
                    (asig[ch] / pos(self.area[ch]) as f64) as f32
                } else {
                    1.0
                };
                for (o, &x) in table[dst * w..dst * w + m].iter_mut().zip(&src) {
                    *o += f * x;
                }
            }
        }
        Mat::<f32>::from_fn(m, m, |c, s| table[c * w + s])
    }
}

/// A cut of the tree: the cluster roots, the cluster of every node at or below them, and
/// the nodes above them ("upper", parents first).
struct Cut {
    roots: Vec<u32>,
    /// Cluster of every node, `NONE` above the cut.
    cl: Vec<u32>,
    upper: Vec<u32>,
    /// Index in `upper` of every node above the cut.
    up: Vec<u32>,
}

impl Cut {
    fn new(tree: &Tree, roots: Vec<u32>) -> Cut {
        let nodes = tree.nodes();
        let mut cl = vec![NONE; nodes];
        for (c, &r) in roots.iter().enumerate() {
            cl[r as usize] = c as u32;
        }
        // Parents come after their children: downwards, every node takes its parent's.
        for k in (0..nodes).rev() {
            let p = tree.parent[k];
            if cl[k] == NONE && p != TREE_NONE {
                cl[k] = cl[p as usize];
            }
        }
        let upper: Vec<u32> = (0..nodes as u32)
            .rev()
            .filter(|&k| cl[k as usize] == NONE)
            .collect();
        let mut up = vec![NONE; nodes];
        for (i, &k) in upper.iter().enumerate() {
            up[k as usize] = i as u32;
        }
        Cut {
            roots,
            cl,
            upper,
            up,
        }
    }

    /// Rows (and columns) of the assembly table: the clusters, then the upper nodes.
    fn width(&self) -> usize {
        self.roots.len() + self.upper.len()
    }

    /// Node `s`'s row (and column) of the table.
    fn col(&self, s: usize) -> usize {
        if self.cl[s] != NONE {
            self.cl[s] as usize
        } else {
            self.roots.len() + self.up[s] as usize
        }
    }

    /// Per cluster, ρ averaged with weights A σ over its `n` patches.
    fn mean_rho(&self, asig: &[f64], rho: &[Rgb], n: usize) -> Vec<[f64; 3]> {
        let mut rho_bar = vec![[0f64; 3]; self.roots.len()];
        for i in 0..n {
            let c = self.cl[i] as usize;
            for j in 0..3 {
                rho_bar[c][j] += asig[i] * rho[i][j] as f64;
            }
        }
        for (c, &r) in self.roots.iter().enumerate() {
            let a = asig[r as usize].max(f64::MIN_POSITIVE);
            rho_bar[c].iter_mut().for_each(|x| *x /= a);
        }
        rho_bar
    }
}

/// Channel `j`'s `M = (I − K_c)⁻¹ K_c` with `K_c = diag(ρ̄_j) k_c`.
fn channel_transfer(k_c: &Mat<f32>, rho_bar: &[[f64; 3]], j: usize) -> Mat<f32> {
    let m = k_c.nrows();
    let kj = Mat::<f32>::from_fn(m, m, |a, b| rho_bar[a][j] as f32 * k_c[(a, b)]);
    let a = Mat::<f32>::from_fn(m, m, |a, b| (a == b) as u8 as f32 - kj[(a, b)]);
    let mut x = kj;
    solve_general_in_place(a, x.as_mut());
    x
}

impl Coarse {
    /// Clusters.
    pub fn len(&self) -> usize {
        self.area.len()
    }

    pub fn is_empty(&self) -> bool {
        self.area.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let m = self.len() as u64;
        4 * (self.cluster.capacity() as u64 + m + 3 * m * m)
    }

    /// `v + P M R v` for `c` columns `v` (n × c row-major; column j in channel j % 3):
    /// an approximate inverse of `I − ρH` whose bounces after the first are carried
    /// between clusters. One product with `M` per channel.
    pub fn precondition(&self, area: &[f32], v: &[f32], c: usize) -> Vec<f32> {
        let m = self.len();
        // R v, per channel: the columns of channel j are j, j + 3, ….
        let z: Vec<Mat<f32>> = (0..3.min(c))
            .into_par_iter()
            .map(|j| {
                let cols: Vec<usize> = (j..c).step_by(3).collect();
                let mut e = Mat::<f32>::zeros(m, cols.len());
                for (i, &cl) in self.cluster.iter().enumerate() {
                    let row = &v[i * c..(i + 1) * c];
                    for (q, &col) in cols.iter().enumerate() {
                        e[(cl as usize, q)] += area[i] * row[col];
                    }
                }
                for q in 0..cols.len() {
                    for (x, &a) in e.col_as_slice_mut(q).iter_mut().zip(&self.area) {
                        *x /= pos(a);
                    }
                }
                let mut z = Mat::<f32>::zeros(m, cols.len());
                faer::linalg::matmul::matmul(
                    z.as_mut(),
                    faer::Accum::Replace,
                    self.transfer[j].as_ref(),
                    e.as_ref(),
                    1.0,
                    faer::Par::Seq,
                );
                z
            })
            .collect();
        let mut out = v[..self.cluster.len() * c].to_vec();
        out.par_chunks_mut(c)
            .zip(&self.cluster)
            .for_each(|(row, &cl)| {
                for (col, x) in row.iter_mut().enumerate() {
                    *x += z[col % 3][(cl as usize, col / 3)];
                }
            });
        out
    }
}

/// An area as a divisor: a cluster of patches without area holds no light.
fn pos(a: f32) -> f32 {
    a.max(f32::MIN_POSITIVE)
}

/// Height above a cluster's plane of the points whose rays test it, m.
const LIFT: f64 = 0.01;

/// Whether node `k` can carry one value: its patches lie in one plane, and each sees the
/// patch nearest the node's centre (points [`LIFT`] above the plane), so that no wall
/// or furniture standing on the plane divides it.
fn coherent(tree: &Tree, mesh: &Mesh, bvh: &Bvh, k: u32) -> bool {
    let plane = tree.plane[k as usize];
    if plane == TREE_NONE {
        return false;
    }
    let normal = tree.planes[plane as usize].0;
    let mut leaves = Vec::new();
    let mut stack = vec![k];
    while let Some(x) = stack.pop() {
        if tree.is_leaf(x) {
            leaves.push(x as usize);
        } else {
            stack.extend(tree.kids(x));
        }
    }
    let centre = tree.center(k);
    let Some(&anchor) = leaves.iter().min_by(|&&p, &&q| {
        let d = |i: usize| (mesh.patches[i].centroid - centre).length_squared();
        d(p).total_cmp(&d(q))
    }) else {
        return true;
    };
    let lift = |i: usize| Vec3A::from((mesh.patches[i].centroid + normal * LIFT).as_vec3());
    let from = lift(anchor);
    let sa = mesh.patches[anchor].source;
    leaves
        .iter()
        .all(|&i| i == anchor || !bvh.occluded(from, lift(i), [sa, mesh.patches[i].source]))
}
