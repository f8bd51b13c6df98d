//! Shading vertices: the Gouraud values an image blends.
//!
//! A shading vertex is a mesh vertex together with the patches around it that lie within
//! one surface and bend less than `CREASE_DEG` (30°) against each other. Its value is the
//! area-weighted mean of those patches, so creases stay sharp and no light bleeds across
//! corners or surfaces.

use glam::DVec3;
use rayon::prelude::*;

use crate::color::Rgb;
use crate::geometry::mesh::Mesh;

/// Patches meeting at a vertex at a sharper angle than this are shaded separately.
pub(super) const CREASE_DEG: f64 = 30.0;

/// Per-corner shading vertices and their patch weights (CSR).
pub struct Shading {
    /// Shading vertex of each element corner (indexed like [`Mesh::elements`]).
    pub(super) corner: Vec<[u32; 3]>,
    start: Vec<u32>,
    patch: Vec<u32>,
    weight: Vec<f32>,
}

impl Shading {
    pub fn new(mesh: &Mesh) -> Shading {
        // Incident elements per mesh vertex.
        let nv = mesh.vertices.len();
        let mut inc: Vec<Vec<(u32, u8)>> = vec![Vec::new(); nv];
        for (e, elem) in mesh.elements.iter().enumerate() {
            for (k, &v) in elem.v.iter().enumerate() {
                inc[v as usize].push((e as u32, k as u8));
            }
        }
        let patch_of = |e: u32| mesh.elements[e as usize].patch;
        let cos_crease = CREASE_DEG.to_radians().cos();
        let mut corner = vec![[0u32; 3]; mesh.elements.len()];
        let mut start = vec![0u32];
        let mut patch = Vec::new();
        let mut weight = Vec::new();
        for list in &inc {
            // Greedy clusters by normal.
            let mut clusters: Vec<(DVec3, Vec<(u32, u8)>)> = Vec::new();
            for &(e, k) in list {
                let n = mesh.patches[patch_of(e) as usize].normal;
                match clusters.iter_mut().find(|(cn, _)| cn.dot(n) >= cos_crease) {
                    Some(c) => c.1.push((e, k)),
                    None => clusters.push((n, vec![(e, k)])),
                }
            }
            for (_, members) in clusters {
                let sv = (start.len() - 1) as u32;
                // Each patch once, though several of a cluster patch's elements may meet
                // at the vertex.
                let mut around: Vec<u32> = Vec::with_capacity(members.len());
                for &(e, k) in &members {
                    corner[e as usize][k as usize] = sv;
                    if !around.contains(&patch_of(e)) {
                        around.push(patch_of(e));
                    }
                }
                let total: f64 = around.iter().map(|&p| mesh.patches[p as usize].area).sum();
                for p in around {
                    patch.push(p);
                    weight.push((mesh.patches[p as usize].area / total) as f32);
                }
                start.push(patch.len() as u32);
            }
        }
        Shading {
            corner,
            start,
            patch,
            weight,
        }
    }

    /// The shading vertex of each element corner (indexed like [`Mesh::elements`]).
    pub fn corners(&self) -> &[[u32; 3]] {
        &self.corner
    }

    /// An element around shading vertex `v`, and which of its corners `v` is.
    pub(super) fn anchor(&self, mesh: &Mesh, v: usize) -> (u32, usize) {
        let p = self.patch[self.start[v] as usize];
        for e in mesh.elements_of(p as usize) {
            if let Some(k) = self.corner[e].iter().position(|&c| c as usize == v) {
                return (e as u32, k);
            }
        }
        (mesh.patches[p as usize].elements.start, 0)
    }

    /// Number of shading vertices.
    pub fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// True when there is no shading vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The shading mesh for clients that draw it themselves (the web page's 3D view), in
    /// one little-endian buffer, every array 4-byte aligned:
    ///
    /// ```text
    /// "RLMESH01"                       8 bytes
    /// u32 nv, nt, nw                   shading vertices, triangles (elements), weights
    /// f32 position[nv][3]              m
    /// u32 triangle[nt][3]              shading vertices of element t, counter-clockwise
    ///                                  seen from its lit (front) side
    /// u32 surface[nt]                  index into the scene's surfaces
    /// u32 start[nv + 1]                CSR: vertex v blends patch[start[v]..start[v+1]]
    /// u32 patch[nw], f32 weight[nw]    with these weights (sum 1 per vertex)
    /// ```
    ///
    /// A vertex colour is `Σ weight · B[patch]` over per-patch radiosity from the radiosity
    /// endpoint, exactly as the server's renderer shades.
    pub fn mesh_bytes(&self, mesh: &Mesh) -> Vec<u8> {
        let weights = (0..self.len()).map(|v| self.blend(v as u32).collect());
        self.write_mesh(mesh, weights)
    }

    /// The preview mesh (see [`super::preview`]) in the layout of [`Shading::mesh_bytes`]:
    /// `coarse` with its shading `coarse_shading`, each vertex blending patches of `fine`
    /// (whose shading is `self`), so the radiosity of the fine patches colours it.
    pub fn preview_bytes(&self, fine: &Mesh, coarse: &Mesh, coarse_shading: &Shading) -> Vec<u8> {
        let w = super::preview::preview_weights(fine, self, coarse, coarse_shading);
        coarse_shading.write_mesh(coarse, w.into_iter())
    }

    /// This shading's vertices and triangles over `mesh`, with the given patch weights
    /// per shading vertex.
    fn write_mesh(&self, mesh: &Mesh, weights: impl Iterator<Item = Vec<(u32, f32)>>) -> Vec<u8> {
        let (nv, nt) = (self.len(), self.corner.len());
        let mut pos = vec![[0f32; 3]; nv];
        for (e, c) in mesh.elements.iter().zip(&self.corner) {
            for k in 0..3 {
                pos[c[k] as usize] = mesh.vertices[e.v[k] as usize].as_vec3().to_array();
            }
        }
        let mut start = vec![0u32];
        let (mut patch, mut weight) = (Vec::new(), Vec::new());
        for list in weights {
            for (q, w) in list {
                patch.push(q);
                weight.push(w);
            }
            start.push(patch.len() as u32);
        }
        let nw = patch.len();
        let mut out = Vec::with_capacity(20 + 12 * nv + 16 * nt + 4 * (nv + 1) + 8 * nw);
        out.extend_from_slice(b"RLMESH01");
        for n in [nv, nt, nw] {
            out.extend_from_slice(&(n as u32).to_le_bytes());
        }
        let words = |out: &mut Vec<u8>, it: &mut dyn Iterator<Item = u32>| {
            for w in it {
                out.extend_from_slice(&w.to_le_bytes());
            }
        };
        words(&mut out, &mut pos.iter().flatten().map(|v| v.to_bits()));
        words(&mut out, &mut self.corner.iter().flatten().copied());
        words(
            &mut out,
            &mut mesh
                .elements
                .iter()
                .map(|e| mesh.patches[e.patch as usize].surface),
        );
        words(&mut out, &mut start.iter().copied());
        words(&mut out, &mut patch.iter().copied());
        words(&mut out, &mut weight.iter().map(|w| w.to_bits()));
        out
    }

    /// The patches shading vertex `v` blends, with their weights.
    pub(super) fn blend(&self, v: u32) -> impl Iterator<Item = (u32, f32)> + '_ {
        let r = self.start[v as usize] as usize..self.start[v as usize + 1] as usize;
        self.patch[r.clone()]
            .iter()
            .copied()
            .zip(self.weight[r].iter().copied())
    }

    /// Vertex values from per-patch values (n × 3 interleaved).
    pub fn vertex_values(&self, per_patch: &[f32]) -> Vec<Rgb> {
        let per_patch = Rgb::column(per_patch);
        (0..self.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|s| {
                let mut acc = Rgb::ZERO;
                for k in self.start[s] as usize..self.start[s + 1] as usize {
                    acc += self.weight[k] * per_patch[self.patch[k] as usize];
                }
                acc
            })
            .collect()
    }
}
