//! The cluster tree: patches are the leaves, coplanar patches of a surface are grouped
//! into planar subtrees, and the planar subtrees into mixed clusters, up to one root.
//!
//! Node numbering: leaves are `0..n` (node i is patch i); internal node `n + k` has
//! `children[k]`. Internal nodes are numbered children first (post-order), so the root is
//! the last node, a parent's index is always above its children's, and one pass upwards
//! (pull) or downwards (push) visits every node after or before its children.

use std::collections::HashMap;

use glam::DVec3;

use crate::geometry::mesh::Mesh;

/// No plane (a mixed cluster), or no parent (the root).
pub const NONE: u32 = u32::MAX;

/// A binary cluster tree over the patches, with the geometry refinement needs.
pub struct Tree {
    /// Leaves (patches).
    pub n: usize,
    /// Children of internal node `n + k`.
    pub children: Vec<[u32; 2]>,
    /// Parent of every node (`NONE` for the root).
    pub parent: Vec<u32>,
    /// Area of every node, m².
    pub area: Vec<f64>,
    /// Bounding box of every node, m.
    pub lo: Vec<DVec3>,
    pub hi: Vec<DVec3>,
    /// Plane of every node: the index into `planes` of a patch or coplanar cluster, `NONE`
    /// for a mixed cluster.
    pub plane: Vec<u32>,
    /// Per plane: a unit front normal and a point on it.
    pub planes: Vec<(DVec3, DVec3)>,
    /// The leaves under every node are the ranks `span[k].0 .. span[k].1` of a depth-first
    /// order, so `a` is an ancestor of (or equal to) `b` iff its span contains b's.
    pub span: Vec<(u32, u32)>,
    /// Root of each plane's subtree.
    pub plane_roots: Vec<u32>,
}

impl Tree {
    pub fn nodes(&self) -> usize {
        self.n + self.children.len()
    }

    pub fn root(&self) -> u32 {
        (self.nodes() - 1) as u32
    }

    pub fn is_leaf(&self, k: u32) -> bool {
        (k as usize) < self.n
    }

    /// Children of an internal node.
    pub fn kids(&self, k: u32) -> [u32; 2] {
        self.children[k as usize - self.n]
    }

    /// True when `a` is `b` or one of its ancestors.
    pub fn contains(&self, a: u32, b: u32) -> bool {
        let (sa, sb) = (self.span[a as usize], self.span[b as usize]);
        sa.0 <= sb.0 && sb.1 <= sa.1
    }

    /// Diagonal of a node's bounding box, m.
    pub fn size(&self, k: u32) -> f64 {
        (self.hi[k as usize] - self.lo[k as usize]).length()
    }

    pub fn center(&self, k: u32) -> DVec3 {
        (self.hi[k as usize] + self.lo[k as usize]) * 0.5
    }

    /// Builds the tree of `mesh`: plane groups first (patches of one surface whose planes
    /// agree within 1e-5 in normal and 1e-6 of the scene size in offset), a median-split
    /// binary tree over each group's centroids, then the same over the groups.
    pub fn build(mesh: &Mesh) -> Tree {
        let n = mesh.len();
        let mut t = Tree {
            n,
            children: Vec::with_capacity(n.saturating_sub(1)),
            parent: Vec::new(),
            area: Vec::with_capacity(2 * n),
            lo: Vec::with_capacity(2 * n),
            hi: Vec::with_capacity(2 * n),
            plane: Vec::with_capacity(2 * n),
            planes: Vec::new(),
            span: Vec::new(),
            plane_roots: Vec::new(),
        };
        let groups = plane_groups(mesh);
        for (i, p) in mesh.patches.iter().enumerate() {
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for (c, _) in mesh.triangles_of(i) {
                lo = lo.min(c[0].min(c[1]).min(c[2]));
                hi = hi.max(c[0].max(c[1]).max(c[2]));
            }
            t.area.push(p.area);
            t.lo.push(lo);
            t.hi.push(hi);
            t.plane.push(NONE);
        }
        let mut roots = Vec::with_capacity(groups.len());
        for (g, mut members) in groups.into_iter().enumerate() {
            let first = members[0] as usize;
            t.planes
                .push((mesh.patches[first].normal, mesh.patches[first].centroid));
            for &m in &members {
                t.plane[m as usize] = g as u32;
            }
            let root = t.split(&mut members, g as u32, &|k| {
                mesh.patches[k as usize].centroid
            });
            t.plane_roots.push(root);
            roots.push(root);
        }
        let centers: Vec<DVec3> = (0..t.nodes() as u32).map(|k| t.center(k)).collect();
        let root = t.split(&mut roots, NONE, &|k| centers[k as usize]);
        debug_assert_eq!(root, t.root());
        t.finish();
        t
    }

    /// A median-split subtree over `items` (node ids), every new node on `plane`; returns
    /// its root.
    fn split(&mut self, items: &mut [u32], plane: u32, center: &dyn Fn(u32) -> DVec3) -> u32 {
        if items.len() == 1 {
            return items[0];
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &k in items.iter() {
            let c = center(k);
            lo = lo.min(c);
            hi = hi.max(c);
        }
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| center(*a)[axis].total_cmp(&center(*b)[axis]));
        let (left, right) = items.split_at_mut(mid);
        let a = self.split(left, plane, center);
        let b = self.split(right, plane, center);
        self.children.push([a, b]);
        let (ai, bi) = (a as usize, b as usize);
        self.area.push(self.area[ai] + self.area[bi]);
        self.lo.push(self.lo[ai].min(self.lo[bi]));
        self.hi.push(self.hi[ai].max(self.hi[bi]));
        self.plane.push(plane);
        (self.nodes() - 1) as u32
    }

    /// Parents and depth-first spans.
    fn finish(&mut self) {
        let nodes = self.nodes();
        self.parent = vec![NONE; nodes];
        for (k, ch) in self.children.iter().enumerate() {
            for &c in ch {
                self.parent[c as usize] = (self.n + k) as u32;
            }
        }
        self.span = vec![(0, 0); nodes];
        // Leaf ranks in depth-first order, then spans upwards (children precede parents).
        let mut rank = 0u32;
        let mut stack = vec![self.root()];
        while let Some(k) = stack.pop() {
            if self.is_leaf(k) {
                self.span[k as usize] = (rank, rank + 1);
                rank += 1;
            } else {
                let [a, b] = self.kids(k);
                stack.push(b);
                stack.push(a);
            }
        }
        for k in 0..self.children.len() {
            let [a, b] = self.children[k];
            let (sa, sb) = (self.span[a as usize], self.span[b as usize]);
            self.span[self.n + k] = (sa.0.min(sb.0), sa.1.max(sb.1));
        }
    }
}

/// Patches grouped by (surface, plane), in order of first appearance.
fn plane_groups(mesh: &Mesh) -> Vec<Vec<u32>> {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for v in &mesh.vertices {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    let scale = (hi - lo).length().max(1e-9);
    let mut index: HashMap<(u32, [i64; 4]), usize> = HashMap::new();
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for (i, p) in mesh.patches.iter().enumerate() {
        let q = |x: f64, step: f64| (x / step).round() as i64;
        let d = p.normal.dot(p.centroid);
        // A cluster patch that is not flat is a plane of its own.
        let own = p.elements.len() > 1
            && mesh.facets(i).any(|f| {
                f.normal.dot(p.normal) < 1.0 - 1e-9
                    || (f.centroid - p.centroid).dot(p.normal).abs() > 1e-9 * scale
            });
        let key = (
            if own { u32::MAX - i as u32 } else { p.surface },
            [
                q(p.normal.x, 1e-5),
                q(p.normal.y, 1e-5),
                q(p.normal.z, 1e-5),
                q(d, 1e-6 * scale),
            ],
        );
        let g = *index.entry(key).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(i as u32);
    }
    groups
}
