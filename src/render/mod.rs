//! Rendering: the solved radiosity seen through a camera.
//!
//! Radiosity is view-independent, so an image splits into a geometric part, built once
//! per (scene, camera, size), and a cheap per-lighting part:
//!
//! 1. [`Shading`]: Gouraud values per *shading vertex*. A shading vertex is a mesh vertex
//!    together with the patches around it that lie within one surface and bend less than
//!    [`CREASE_DEG`] against each other. Its value is the area-weighted mean of those
//!    patches, so creases stay sharp and no light bleeds across corners or surfaces.
//! 2. [`ViewBuffer`]: the scene rasterized with a z-buffer at S×S samples per pixel. Every
//!    pixel keeps the few shading vertices it blends, with weights (barycentric × sample
//!    coverage). Back faces are culled; empty samples are black.
//! 3. A relit image is a gather: vertex values (lm/m²) → radiance B/π → the pixel's
//!    weighted sum, then exposure, tone mapping, sRGB and encoding.

pub mod pipeline;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::color::{luminance, Rgb};
use crate::geometry::mesh::Mesh;
use crate::scene::CameraDef;

/// Patches meeting at a vertex at a sharper angle than this are shaded separately.
pub const CREASE_DEG: f64 = 30.0;
/// Largest image side.
pub const MAX_SIDE: u32 = 4096;

/// Per-corner shading vertices and their patch weights (CSR).
pub struct Shading {
    /// Shading vertex of each patch corner.
    pub corner: Vec<[u32; 3]>,
    start: Vec<u32>,
    patch: Vec<u32>,
    weight: Vec<f32>,
}

impl Shading {
    pub fn new(mesh: &Mesh) -> Shading {
        // Incident patches per mesh vertex.
        let nv = mesh.vertices.len();
        let mut inc: Vec<Vec<(u32, u8)>> = vec![Vec::new(); nv];
        for (p, patch) in mesh.patches.iter().enumerate() {
            for (k, &v) in patch.v.iter().enumerate() {
                inc[v as usize].push((p as u32, k as u8));
            }
        }
        let cos_crease = CREASE_DEG.to_radians().cos();
        let mut corner = vec![[0u32; 3]; mesh.len()];
        let mut start = vec![0u32];
        let mut patch = Vec::new();
        let mut weight = Vec::new();
        for list in &inc {
            // Greedy clusters by normal.
            let mut clusters: Vec<(DVec3, Vec<(u32, u8)>)> = Vec::new();
            for &(p, k) in list {
                let n = mesh.patches[p as usize].normal;
                match clusters.iter_mut().find(|(cn, _)| cn.dot(n) >= cos_crease) {
                    Some(c) => c.1.push((p, k)),
                    None => clusters.push((n, vec![(p, k)])),
                }
            }
            for (_, members) in clusters {
                let sv = (start.len() - 1) as u32;
                let total: f64 = members
                    .iter()
                    .map(|&(p, _)| mesh.patches[p as usize].area)
                    .sum();
                for &(p, k) in &members {
                    corner[p as usize][k as usize] = sv;
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
    /// u32 nv, nt, nw                   shading vertices, triangles (= patches), weights
    /// f32 position[nv][3]              m
    /// u32 triangle[nt][3]              shading vertices of patch t, counter-clockwise
    ///                                  seen from its lit (front) side
    /// u32 surface[nt]                  index into the scene's surfaces
    /// u32 start[nv + 1]                CSR: vertex v blends patch[start[v]..start[v+1]]
    /// u32 patch[nw], f32 weight[nw]    with these weights (sum 1 per vertex)
    /// ```
    ///
    /// A vertex colour is `Σ weight · B[patch]` over per-patch radiosity from the radiosity
    /// endpoint, exactly as the server's renderer shades.
    pub fn mesh_bytes(&self, mesh: &Mesh) -> Vec<u8> {
        let (nv, nt, nw) = (self.len(), self.corner.len(), self.patch.len());
        let mut pos = vec![[0f32; 3]; nv];
        for (p, c) in mesh.patches.iter().zip(&self.corner) {
            for k in 0..3 {
                pos[c[k] as usize] = mesh.vertices[p.v[k] as usize].as_vec3().to_array();
            }
        }
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
        words(&mut out, &mut mesh.patches.iter().map(|p| p.surface));
        words(&mut out, &mut self.start.iter().copied());
        words(&mut out, &mut self.patch.iter().copied());
        words(&mut out, &mut self.weight.iter().map(|w| w.to_bits()));
        out
    }

    /// Vertex values from per-patch values (n × 3 interleaved).
    pub fn vertex_values(&self, per_patch: &[f32]) -> Vec<Rgb> {
        (0..self.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|s| {
                let mut acc = [0f32; 3];
                for k in self.start[s] as usize..self.start[s + 1] as usize {
                    let p = self.patch[k] as usize;
                    let w = self.weight[k];
                    for c in 0..3 {
                        acc[c] += w * per_patch[3 * p + c];
                    }
                }
                acc
            })
            .collect()
    }
}

/// A pinhole camera. `fov_deg` is the vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn from_def(c: &CameraDef, width: u32, height: u32) -> Camera {
        let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        Camera {
            position: v(c.position),
            target: v(c.target),
            up: v(c.up),
            fov_deg: c.fov_deg as f32,
            width,
            height,
        }
    }

    /// Checks the numbers; the message names the problem.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(format!(
                "image size {}×{}: width and height must be 1 to {MAX_SIDE}",
                self.width, self.height
            ));
        }
        let finite = [self.position, self.target, self.up]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return Err("camera position, target and up must be finite".into());
        }
        if !(self.fov_deg > 0.5 && self.fov_deg < 179.0) {
            return Err(format!("fov_deg {} must be in (0.5, 179)", self.fov_deg));
        }
        let f = self.target - self.position;
        if f.length() < 1e-6 {
            return Err("camera target must differ from its position".into());
        }
        if f.normalize().cross(self.up.normalize_or_zero()).length() < 1e-4 {
            return Err("camera up must not be parallel to the view direction".into());
        }
        Ok(())
    }

    /// A key for view-buffer caches.
    pub fn key(&self) -> [u32; 12] {
        let b = |x: f32| x.to_bits();
        [
            b(self.position.x),
            b(self.position.y),
            b(self.position.z),
            b(self.target.x),
            b(self.target.y),
            b(self.target.z),
            b(self.up.x),
            b(self.up.y),
            b(self.up.z),
            b(self.fov_deg),
            self.width,
            self.height,
        ]
    }
}

/// Per pixel: the shading vertices it blends and their weights (CSR).
pub struct ViewBuffer {
    pub width: u32,
    pub height: u32,
    start: Vec<u32>,
    sv: Vec<u32>,
    weight: Vec<f32>,
    /// Patch seen at the centre sample of each pixel (u32::MAX: none), for picking.
    pub center_patch: Vec<u32>,
}

/// One image row while resolving: per-pixel counts, vertices, weights, centre patches.
type PixelRow = (Vec<u32>, Vec<u32>, Vec<f32>, Vec<u32>);

/// Average vertex weights per pixel assumed by [`ViewBuffer::estimate_bytes`].
pub const EST_WEIGHTS_PER_PIXEL: u64 = 8;

/// Samples per pixel side.
fn samples_per_side(cam: &Camera) -> u32 {
    if cam.width as u64 * cam.height as u64 > 1_200_000 {
        2
    } else {
        3
    }
}

impl ViewBuffer {
    /// Peak bytes that [`ViewBuffer::build`] allocates for `cam`, estimated: the
    /// supersampled depth and sample buffers (16 bytes per sample, exact) while the rows
    /// are resolved, plus the rows and the joined buffer (8 bytes per shading-vertex weight,
    /// twice, and 8 bytes per pixel of offsets and picking ids). Pixels blend
    /// [`EST_WEIGHTS_PER_PIXEL`] vertex weights on average in this estimate; a view of the
    /// Cornell box averages 2.9 (`tests/hardening.rs` checks the bound).
    pub fn estimate_bytes(cam: &Camera) -> u64 {
        let s = samples_per_side(cam) as u64;
        let px = cam.width as u64 * cam.height as u64;
        px * (16 * s * s + 2 * 8 * EST_WEIGHTS_PER_PIXEL + 8)
    }

    /// Rasterizes `mesh` seen by `cam`.
    pub fn build(mesh: &Mesh, shading: &Shading, cam: &Camera) -> ViewBuffer {
        let s = samples_per_side(cam);
        let (w, h) = (cam.width as usize, cam.height as usize);
        let (sw, sh) = (w * s as usize, h * s as usize);
        let fwd = (cam.target - cam.position).normalize();
        let right = fwd.cross(cam.up).normalize();
        let up = right.cross(fwd);
        let tan = (cam.fov_deg.to_radians() * 0.5).tan();
        let aspect = w as f32 / h as f32;
        let near = 1e-4f32;
        // Camera-space corners of each patch.
        let to_cam = |p: DVec3| {
            let d = p.as_vec3() - cam.position;
            Vec3::new(d.dot(right), d.dot(up), d.dot(fwd))
        };
        let mut depth = vec![f32::INFINITY; sw * sh];
        // Per sample: patch, and barycentrics b1, b2 (b0 = 1 − b1 − b2).
        let mut sample: Vec<(u32, f32, f32)> = vec![(u32::MAX, 0.0, 0.0); sw * sh];
        let project = |c: Vec3| -> (f32, f32) {
            let x = c.x / (c.z * tan * aspect);
            let y = c.y / (c.z * tan);
            ((x * 0.5 + 0.5) * sw as f32, (0.5 - y * 0.5) * sh as f32)
        };
        for (pi, p) in mesh.patches.iter().enumerate() {
            // Back faces are culled: only fronts are ever lit, and the back of a two-sided
            // panel would z-fight with its front.
            if p.normal.as_vec3().dot(cam.position - p.centroid.as_vec3()) <= 0.0 {
                continue;
            }
            let cc = p.v.map(|k| to_cam(mesh.vertices[k as usize]));
            // Clip against the near plane; the polygon keeps barycentric tags.
            let bary = [Vec3::X, Vec3::Y, Vec3::Z];
            let mut poly: Vec<(Vec3, Vec3)> = Vec::with_capacity(4);
            for k in 0..3 {
                let (a, ba) = (cc[k], bary[k]);
                let (b, bb) = (cc[(k + 1) % 3], bary[(k + 1) % 3]);
                if a.z >= near {
                    poly.push((a, ba));
                }
                if (a.z >= near) != (b.z >= near) {
                    let t = (near - a.z) / (b.z - a.z);
                    poly.push((a + (b - a) * t, ba + (bb - ba) * t));
                }
            }
            if poly.len() < 3 {
                continue;
            }
            for k in 1..poly.len() - 1 {
                raster_triangle(
                    [poly[0], poly[k], poly[k + 1]],
                    pi as u32,
                    &project,
                    sw,
                    sh,
                    &mut depth,
                    &mut sample,
                );
            }
        }
        // Resolve samples into per-pixel vertex weights.
        let inv = 1.0 / (s * s) as f32;
        let rows: Vec<PixelRow> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut counts = Vec::with_capacity(w);
                let mut svs = Vec::new();
                let mut wts = Vec::new();
                let mut centre = Vec::with_capacity(w);
                for x in 0..w {
                    let mut local: Vec<(u32, f32)> = Vec::with_capacity(12);
                    for sy in 0..s as usize {
                        for sx in 0..s as usize {
                            let idx = (y * s as usize + sy) * sw + x * s as usize + sx;
                            let (p, b1, b2) = sample[idx];
                            if p == u32::MAX {
                                continue;
                            }
                            let corners = shading.corner[p as usize];
                            for (k, b) in [(0, 1.0 - b1 - b2), (1, b1), (2, b2)] {
                                let v = corners[k];
                                let wgt = b.max(0.0) * inv;
                                match local.iter_mut().find(|e| e.0 == v) {
                                    Some(e) => e.1 += wgt,
                                    None => local.push((v, wgt)),
                                }
                            }
                        }
                    }
                    let mid = (s / 2) as usize;
                    centre.push(sample[(y * s as usize + mid) * sw + x * s as usize + mid].0);
                    counts.push(local.len() as u32);
                    for (v, wgt) in local {
                        svs.push(v);
                        wts.push(wgt);
                    }
                }
                (counts, svs, wts, centre)
            })
            .collect();
        // The samples are resolved: free them before the rows are joined, and join into
        // buffers of the exact size (no doubling).
        drop(depth);
        drop(sample);
        let entries: usize = rows.iter().map(|r| r.1.len()).sum();
        let mut start = Vec::with_capacity(w * h + 1);
        start.push(0u32);
        let mut sv = Vec::with_capacity(entries);
        let mut weight = Vec::with_capacity(entries);
        let mut center_patch = Vec::with_capacity(w * h);
        for (counts, s, wt, c) in rows {
            for n in counts {
                start.push(start.last().copied().unwrap_or(0) + n);
            }
            sv.extend(s);
            weight.extend(wt);
            center_patch.extend(c);
        }
        ViewBuffer {
            width: cam.width,
            height: cam.height,
            start,
            sv,
            weight,
            center_patch,
        }
    }

    /// Linear image (row 0 at the top) of per-vertex values times `scale`.
    pub fn gather(&self, values: &[Rgb], scale: f32) -> Vec<Rgb> {
        let n = (self.width * self.height) as usize;
        (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| self.pixel(i, values, scale))
            .collect()
    }

    /// One pixel's value: the weighted sum of its vertices, times `scale`.
    #[inline]
    fn pixel(&self, i: usize, values: &[Rgb], scale: f32) -> Rgb {
        let mut acc = [0f32; 3];
        for k in self.start[i] as usize..self.start[i + 1] as usize {
            let v = &values[self.sv[k] as usize];
            let w = self.weight[k] * scale;
            acc[0] += w * v[0];
            acc[1] += w * v[1];
            acc[2] += w * v[2];
        }
        acc
    }

    /// 8-bit sRGB image in one pass: gather, exposure, tone curve. `exposure` None means
    /// auto exposure, estimated from every 16th pixel. Returns the pixels and the stops used.
    pub fn gather_tonemapped(
        &self,
        values: &[Rgb],
        scale: f32,
        exposure: Option<f32>,
        tm: ToneMap,
    ) -> (Vec<u8>, f32) {
        tonemap_pixels(
            self.pixels(),
            |i| self.pixel(i, values, scale),
            exposure,
            tm,
        )
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Memory held, bytes (allocated capacity, not length).
    pub fn bytes(&self) -> usize {
        4 * (self.start.capacity()
            + self.sv.capacity()
            + self.weight.capacity()
            + self.center_patch.capacity())
    }
}

/// Linear images of one view, one per light group at unit weight (radiance,
/// lm/(m²·sr)), stored pixel-major. The image for group weights `w` is `Σ_g w_g ⊙ I_g`:
/// with few groups that streams far less memory than a gather over the view buffer.
pub struct GroupImages {
    pub width: u32,
    pub height: u32,
    groups: usize,
    /// `[pixel][group][rgb]`.
    data: Vec<f32>,
}

impl GroupImages {
    /// Whether per-group images are smaller than the view buffer they replace.
    pub fn worthwhile(view: &ViewBuffer, groups: usize) -> bool {
        groups > 0 && groups * 12 * view.pixels() <= view.bytes()
    }

    /// Radiance images (B/π) of every light group of `transfer` at unit weight.
    pub fn radiance(
        view: &ViewBuffer,
        shading: &Shading,
        transfer: &crate::transport::transfer::Transfer,
    ) -> GroupImages {
        let values: Vec<Vec<Rgb>> = transfer
            .groups
            .iter()
            .map(|g| shading.vertex_values(&g.b))
            .collect();
        GroupImages::build(view, &values, std::f32::consts::FRAC_1_PI)
    }

    /// Gathers one image per group from per-group shading-vertex values, times `scale`.
    pub fn build(view: &ViewBuffer, vertex_values: &[Vec<Rgb>], scale: f32) -> GroupImages {
        let g = vertex_values.len();
        let images: Vec<Vec<Rgb>> = vertex_values
            .iter()
            .map(|v| view.gather(v, scale))
            .collect();
        let mut data = vec![0f32; 3 * g * view.pixels()];
        data.par_chunks_mut(3 * g).enumerate().for_each(|(i, px)| {
            for (k, img) in images.iter().enumerate() {
                px[3 * k..3 * k + 3].copy_from_slice(&img[i]);
            }
        });
        GroupImages {
            width: view.width,
            height: view.height,
            groups: g,
            data,
        }
    }

    #[inline]
    fn pixel(&self, i: usize, weights: &[Rgb]) -> Rgb {
        let px = &self.data[3 * self.groups * i..3 * self.groups * (i + 1)];
        let mut acc = [0f32; 3];
        for (v, w) in px.chunks_exact(3).zip(weights) {
            acc[0] += w[0] * v[0];
            acc[1] += w[1] * v[1];
            acc[2] += w[2] * v[2];
        }
        acc
    }

    /// Linear image (row 0 at the top) for per-group RGB weights.
    pub fn linear(&self, weights: &[Rgb]) -> Vec<Rgb> {
        let n = self.width as usize * self.height as usize;
        (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| self.pixel(i, weights))
            .collect()
    }

    /// 8-bit sRGB image for per-group RGB weights, as [`ViewBuffer::gather_tonemapped`].
    pub fn tonemapped(
        &self,
        weights: &[Rgb],
        exposure: Option<f32>,
        tm: ToneMap,
    ) -> (Vec<u8>, f32) {
        let n = self.width as usize * self.height as usize;
        tonemap_pixels(n, |i| self.pixel(i, weights), exposure, tm)
    }

    /// Memory held, bytes (allocated capacity).
    pub fn bytes(&self) -> usize {
        4 * self.data.capacity()
    }

    /// Peak bytes [`GroupImages::build`] allocates for `groups` groups on `view`: one
    /// linear image per group, then the interleaved copy.
    pub fn estimate_bytes(view: &ViewBuffer, groups: usize) -> u64 {
        2 * 12 * groups as u64 * view.pixels() as u64
    }
}

/// 8-bit sRGB pixels `0..n` from a linear pixel source, in one pass: exposure (auto from
/// every 16th pixel when None), tone curve, sRGB. Returns the pixels and the stops used.
fn tonemap_pixels(
    n: usize,
    pixel: impl Fn(usize) -> Rgb + Sync,
    exposure: Option<f32>,
    tm: ToneMap,
) -> (Vec<u8>, f32) {
    let ev = exposure.unwrap_or_else(|| {
        let sample: Vec<Rgb> = (0..n).into_par_iter().step_by(16).map(&pixel).collect();
        auto_exposure(&sample)
    });
    let lut = tone_lut(tm);
    let k = ev.exp2();
    let mut out = vec![0u8; 3 * n];
    out.par_chunks_mut(3 * 4096)
        .enumerate()
        .for_each(|(blk, o)| {
            for (j, o) in o.chunks_exact_mut(3).enumerate() {
                let p = pixel(blk * 4096 + j);
                for c in 0..3 {
                    o[c] = lut[lut_index(p[c] * k)];
                }
            }
        });
    (out, ev)
}

#[allow(clippy::too_many_arguments)]
fn raster_triangle(
    t: [(Vec3, Vec3); 3],
    patch: u32,
    project: &impl Fn(Vec3) -> (f32, f32),
    sw: usize,
    sh: usize,
    depth: &mut [f32],
    sample: &mut [(u32, f32, f32)],
) {
    let s = t.map(|(c, _)| project(c));
    let iz = t.map(|(c, _)| 1.0 / c.z);
    let area = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[2].0 - s[0].0) * (s[1].1 - s[0].1);
    if area.abs() < 1e-12 {
        return;
    }
    let minx = s
        .iter()
        .map(|p| p.0)
        .fold(f32::INFINITY, f32::min)
        .floor()
        .max(0.0) as usize;
    let maxx = (s
        .iter()
        .map(|p| p.0)
        .fold(f32::NEG_INFINITY, f32::max)
        .ceil() as isize)
        .min(sw as isize - 1);
    let miny = s
        .iter()
        .map(|p| p.1)
        .fold(f32::INFINITY, f32::min)
        .floor()
        .max(0.0) as usize;
    let maxy = (s
        .iter()
        .map(|p| p.1)
        .fold(f32::NEG_INFINITY, f32::max)
        .ceil() as isize)
        .min(sh as isize - 1);
    if maxx < 0 || maxy < 0 {
        return;
    }
    let inv_area = 1.0 / area;
    for y in miny..=maxy as usize {
        let py = y as f32 + 0.5;
        for x in minx..=maxx as usize {
            let px = x as f32 + 0.5;
            // Edge functions (screen-space barycentrics), inclusive with a tiny tolerance
            // so shared edges leave no gaps.
            let w0 = ((s[1].0 - px) * (s[2].1 - py) - (s[2].0 - px) * (s[1].1 - py)) * inv_area;
            let w1 = ((s[2].0 - px) * (s[0].1 - py) - (s[0].0 - px) * (s[2].1 - py)) * inv_area;
            let w2 = 1.0 - w0 - w1;
            const E: f32 = -1e-6;
            if w0 < E || w1 < E || w2 < E {
                continue;
            }
            // Perspective-correct interpolation.
            let z_inv = w0 * iz[0] + w1 * iz[1] + w2 * iz[2];
            let z = 1.0 / z_inv;
            let idx = y * sw + x;
            if z >= depth[idx] {
                continue;
            }
            depth[idx] = z;
            let bary = (t[0].1 * (w0 * iz[0]) + t[1].1 * (w1 * iz[1]) + t[2].1 * (w2 * iz[2])) * z;
            sample[idx] = (patch, bary.y, bary.z);
        }
    }
}

/// Tone mapping of linear radiance after exposure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    /// Clip at 1.
    Clamp,
    /// ACES filmic curve (Narkowicz fit): soft shoulder, keeps highlights.
    Filmic,
}

/// Exposure (stops) that maps the log-average luminance of the lit pixels to middle grey
/// (0.18), like a camera's auto exposure. 0 for a black image.
pub fn auto_exposure(img: &[Rgb]) -> f32 {
    // Every 5th pixel is plenty for a mean of logarithms.
    let (sum, count) = img
        .par_chunks(4096)
        .map(|chunk| {
            chunk
                .iter()
                .step_by(5)
                .map(|p| luminance(*p))
                .filter(|&y| y > 0.0)
                .fold((0f64, 0usize), |(s, c), y| (s + (y as f64).ln(), c + 1))
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if count == 0 {
        return 0.0;
    }
    let avg = (sum / count as f64).exp();
    ((0.18 / avg).log2() as f32).clamp(-40.0, 40.0)
}

fn srgb_oetf(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn aces(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// The tone table covers values (after exposure) from 2^LUT_LO_EXP, below which every
/// curve gives code 0, to 2^LUT_HI_EXP = 16, above which every curve gives white.
const LUT_LO_EXP: i32 = -16;
const LUT_HI_EXP: i32 = 4;
/// Mantissa bits kept in the index: steps of 2^-10 ≈ 0.1 %, far below one 8-bit code.
const LUT_MANT_BITS: u32 = 10;
const LUT_SIZE: usize = ((LUT_HI_EXP - LUT_LO_EXP) as usize) << LUT_MANT_BITS;
const LUT_SHIFT: u32 = 23 - LUT_MANT_BITS;

/// Index into the tone table: the top bits of the float (exponent and 10 mantissa bits),
/// i.e. a log-spaced table reached without any arithmetic. Negative and NaN map to 0.
#[inline]
fn lut_index(v: f32) -> usize {
    let lo = 2f32.powi(LUT_LO_EXP).to_bits() >> LUT_SHIFT;
    let b = v.max(0.0).to_bits() >> LUT_SHIFT;
    (b.saturating_sub(lo) as usize).min(LUT_SIZE - 1)
}

/// The tone curve followed by the sRGB transfer function, as 8-bit codes indexed by
/// [`lut_index`]; built once per curve.
fn tone_lut(tm: ToneMap) -> &'static [u8] {
    static LUTS: std::sync::OnceLock<[Vec<u8>; 2]> = std::sync::OnceLock::new();
    let luts = LUTS.get_or_init(|| {
        let lo = 2f32.powi(LUT_LO_EXP).to_bits() >> LUT_SHIFT;
        [ToneMap::Clamp, ToneMap::Filmic].map(|tm| {
            (0..LUT_SIZE as u32)
                .map(|i| {
                    // The middle of the bucket.
                    let v = f32::from_bits(((lo + i) << LUT_SHIFT) | (1 << (LUT_SHIFT - 1)));
                    let t = match tm {
                        ToneMap::Clamp => v.min(1.0),
                        ToneMap::Filmic => aces(v),
                    };
                    (srgb_oetf(t) * 255.0 + 0.5) as u8
                })
                .collect()
        })
    });
    &luts[tm as usize]
}

/// 8-bit sRGB pixels from linear values, scaled by 2^exposure. The whole curve (tone map,
/// then the sRGB transfer function) is one log-spaced table, which keeps the steep dark
/// end finely resolved.
pub fn tonemap(img: &[Rgb], exposure: f32, tm: ToneMap) -> Vec<u8> {
    tonemap_pixels(img.len(), |i| img[i], Some(exposure), tm).0
}

/// False colour: a perceptual blue→green→yellow→red scale of luminance over
/// `[lo, hi]` on a log10 axis, with a legend bar on the right edge labelled in lux.
pub fn false_color(img: &[Rgb], width: u32, height: u32, lo: f32, hi: f32) -> Vec<u8> {
    let (lo, hi) = false_color_range(lo, hi);
    let (l0, l1) = (lo.log10(), hi.log10());
    let mut out: Vec<u8> = img
        .par_iter()
        .flat_map_iter(|p| {
            let y = luminance(*p);
            let t = if y <= 0.0 {
                0.0
            } else {
                ((y.log10() - l0) / (l1 - l0)).clamp(0.0, 1.0)
            };
            scale_color(t).into_iter()
        })
        .collect();
    legend(&mut out, width, height, lo, hi);
    out
}

/// Smallest and largest lux values the false-colour scale shows.
pub const FALSE_COLOR_MIN_LUX: f32 = 1e-6;
pub const FALSE_COLOR_MAX_LUX: f32 = 1e12;

/// A usable false-colour range: both ends clamped to
/// [`FALSE_COLOR_MIN_LUX`]..[`FALSE_COLOR_MAX_LUX`] (NaN counts as the low end), and the high
/// end above the low one.
pub fn false_color_range(lo: f32, hi: f32) -> (f32, f32) {
    let clamp = |v: f32| {
        if v.is_nan() {
            FALSE_COLOR_MIN_LUX
        } else {
            v.clamp(FALSE_COLOR_MIN_LUX, FALSE_COLOR_MAX_LUX)
        }
    };
    let lo = clamp(lo).min(FALSE_COLOR_MAX_LUX / 1.01);
    let hi = clamp(hi).max(lo * 1.01);
    (lo, hi)
}

/// The false-colour legend: a bar 1/24 of the width at the right edge (high values at the
/// top), with lux labels at round values (1, 2, 5 × 10^k) drawn on dark plates.
fn legend(out: &mut [u8], width: u32, height: u32, lo: f32, hi: f32) {
    let bar = (width / 24).max(4);
    let log = |v: f32| v.max(1e-9).log10();
    // Within the clamped range the tick loop runs over at most 19 decades.
    let (lo, hi) = false_color_range(lo, hi);
    let (l0, l1) = (log(lo), log(hi));
    for y in 0..height {
        let t = 1.0 - y as f32 / (height.max(2) - 1) as f32;
        let c = scale_color(t);
        for x in width.saturating_sub(bar)..width {
            let i = 3 * (y * width + x) as usize;
            out[i..i + 3].copy_from_slice(&c);
        }
    }
    let px = ((height + 150) / 300).clamp(1, 4);
    let glyph_h = 7 * px;
    if height < 4 * glyph_h || width < 16 * bar {
        return; // too small for labels
    }
    // Round values within the range, thinned so labels never overlap.
    let mut ticks = vec![];
    for e in (l0.floor() as i32)..=(l1.ceil() as i32) {
        for m in [1.0f32, 2.0, 5.0] {
            let v = m * 10f32.powi(e);
            if log(v) >= l0 - 1e-6 && log(v) <= l1 + 1e-6 {
                ticks.push(v);
            }
        }
    }
    let row = |v: f32| ((1.0 - (log(v) - l0) / (l1 - l0)) * (height - 1) as f32) as i64;
    let mut last: Option<i64> = None;
    let spacing = 2 * glyph_h as i64;
    let mut chosen = vec![];
    for &v in ticks.iter().rev() {
        let r = row(v);
        if last.is_none_or(|l| r - l >= spacing) {
            chosen.push(v);
            last = Some(r);
        }
    }
    for v in chosen {
        let text = format!("{} lx", lux_label(v));
        let tw = text.len() as u32 * 6 * px;
        let x0 = width.saturating_sub(bar + tw + 3 * px) as i64;
        let y0 = (row(v) - glyph_h as i64 / 2).clamp(0, (height - glyph_h) as i64);
        // Dark plate, then the text; a tick mark into the bar.
        fill(
            out,
            width,
            height,
            x0 - px as i64,
            y0 - px as i64,
            tw + 2 * px,
            glyph_h + 2 * px,
            [20, 20, 20],
        );
        draw_text(out, width, height, x0, y0, px, &text, [255, 255, 255]);
        let ty = row(v).clamp(0, height as i64 - 1);
        fill(
            out,
            width,
            height,
            (width - bar) as i64,
            ty,
            bar / 3,
            px,
            [20, 20, 20],
        );
    }
}

/// A lux value as a short label: 0.5, 2, 50, 1k, 20k.
fn lux_label(v: f32) -> String {
    if v >= 1000.0 {
        format!("{}k", trim_number(v / 1000.0))
    } else {
        trim_number(v)
    }
}

fn trim_number(v: f32) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

#[allow(clippy::too_many_arguments)]
fn fill(out: &mut [u8], w: u32, h: u32, x0: i64, y0: i64, fw: u32, fh: u32, c: [u8; 3]) {
    for y in y0.max(0)..(y0 + fh as i64).min(h as i64) {
        for x in x0.max(0)..(x0 + fw as i64).min(w as i64) {
            let i = 3 * (y as usize * w as usize + x as usize);
            out[i..i + 3].copy_from_slice(&c);
        }
    }
}

/// 5×7 glyphs (rows top to bottom, bit 4 = left column) for the legend's characters.
fn glyph(ch: char) -> [u8; 7] {
    match ch {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        _ => [0; 7],
    }
}

/// Draws `text` with its top-left corner at (x0, y0), each font pixel `px` × `px`.
#[allow(clippy::too_many_arguments)]
fn draw_text(out: &mut [u8], w: u32, h: u32, x0: i64, y0: i64, px: u32, text: &str, c: [u8; 3]) {
    for (k, ch) in text.chars().enumerate() {
        let g = glyph(ch);
        for (r, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    let x = x0 + ((k * 6 + col) as u32 * px) as i64;
                    let y = y0 + (r as u32 * px) as i64;
                    fill(out, w, h, x, y, px, px, c);
                }
            }
        }
    }
}

/// The false-colour scale at t in [0, 1] (0 = `lo`, 1 = `hi`).
pub fn scale_color(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.05, 0.05, 0.35],
        [0.0, 0.35, 0.9],
        [0.0, 0.75, 0.55],
        [0.55, 0.85, 0.1],
        [1.0, 0.8, 0.0],
        [0.85, 0.1, 0.05],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = [0, 1, 2].map(|k| STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f);
    c.map(|v| (v * 255.0 + 0.5) as u8)
}

/// Output encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    Png,
    Jpeg,
    /// Linear OpenEXR, f32 RGB radiance in W/(m²·sr)-like units (lm/(m²·sr)).
    Exr,
    /// Linear portable float map, the same values as EXR (the command line only).
    Pfm,
}

impl Format {
    pub fn content_type(self) -> &'static str {
        match self {
            Format::Png => "image/png",
            Format::Jpeg => "image/jpeg",
            Format::Exr => "image/x-exr",
            Format::Pfm => "image/x-portable-floatmap",
        }
    }
}

/// Encodes 8-bit sRGB pixels as PNG (fast compression) or JPEG (quality 90).
pub fn encode_8bit(rgb: &[u8], w: u32, h: u32, format: Format) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    match format {
        Format::Png => image::codecs::png::PngEncoder::new_with_quality(
            &mut out,
            image::codecs::png::CompressionType::Fast,
            image::codecs::png::FilterType::Sub,
        )
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8),
        Format::Jpeg => return encode_jpeg(rgb, w, h),
        Format::Exr | Format::Pfm => return Err("EXR and PFM are written from linear data".into()),
    }
    .map_err(|e| e.to_string())?;
    Ok(out)
}

/// JPEG quality of 8-bit answers.
const JPEG_QUALITY: u8 = 90;

/// Baseline JPEG (quality 90, 4:2:0), encoded in horizontal strips in parallel.
///
/// Each strip is a JPEG of its own with a restart marker after every MCU row, so its
/// entropy-coded data is independent of the others (restarts reset the DC predictors).
/// The strips share every table, so the first strip's headers (with the full height)
/// followed by all strips' entropy data, joined and renumbered with RST markers, is one
/// valid JPEG that decodes to exactly the pixels a single-threaded encode gives.
pub fn encode_jpeg(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, String> {
    let (strips, strip_rows) = jpeg_strips(h, rayon::current_num_threads());
    let encode = |y0: u32, y1: u32, restart: bool| -> Result<Vec<u8>, String> {
        let mut out = Vec::with_capacity((w * (y1 - y0)) as usize / 4);
        let mut enc = jpeg_encoder::Encoder::new(&mut out, JPEG_QUALITY);
        enc.set_sampling_factor(jpeg_encoder::SamplingFactor::F_2_2);
        if restart {
            enc.set_restart_interval(w.div_ceil(16) as u16);
        }
        let rows = &rgb[(3 * w * y0) as usize..(3 * w * y1) as usize];
        enc.encode(
            rows,
            w as u16,
            (y1 - y0) as u16,
            jpeg_encoder::ColorType::Rgb,
        )
        .map_err(|e| e.to_string())?;
        Ok(out)
    };
    if strips <= 1 {
        return encode(0, h, false);
    }
    let parts: Vec<Vec<u8>> = (0..strips)
        .into_par_iter()
        .map(|s| encode(s * strip_rows, ((s + 1) * strip_rows).min(h), true))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(parts.iter().map(Vec::len).sum::<usize>() + 16);
    for (s, part) in parts.iter().enumerate() {
        let (sof, data) = jpeg_layout(part).ok_or("JPEG strip without SOF0/SOS")?;
        let entropy = part
            .get(data..part.len().saturating_sub(2))
            .filter(|_| part.ends_with(&[0xFF, 0xD9]))
            .ok_or("JPEG strip without EOI")?;
        let first_row = s as u32 * strip_rows / 16;
        if s == 0 {
            out.extend_from_slice(&part[..data]);
            out[sof + 5..sof + 7].copy_from_slice(&(h as u16).to_be_bytes());
            out.extend_from_slice(entropy);
        } else {
            out.extend_from_slice(&[0xFF, 0xD0 + ((first_row - 1) % 8) as u8]);
            let mut prev_ff = false;
            for &b in entropy {
                let b = if prev_ff && (0xD0..=0xD7).contains(&b) {
                    0xD0 + ((b - 0xD0) as u32 + first_row) as u8 % 8
                } else {
                    b
                };
                out.push(b);
                prev_ff = b == 0xFF;
            }
        }
    }
    out.extend_from_slice(&[0xFF, 0xD9]);
    Ok(out)
}

/// How to cut an image of height `h` into strips for `threads` threads: the number of
/// strips and the rows per strip (a multiple of the 16-row MCU). Every strip is non-empty:
/// `(strips − 1) · rows < h ≤ strips · rows`.
pub fn jpeg_strips(h: u32, threads: usize) -> (u32, u32) {
    let mcu_rows = h.div_ceil(16).max(1);
    let wanted = (threads.clamp(1, 8) as u32).min(mcu_rows);
    let per = mcu_rows.div_ceil(wanted);
    (mcu_rows.div_ceil(per), per * 16)
}

/// Offsets of the SOF0 marker and of the first entropy-coded byte after SOS.
fn jpeg_layout(j: &[u8]) -> Option<(usize, usize)> {
    let mut i = 2; // after SOI
    let mut sof = None;
    while i + 4 <= j.len() {
        if j[i] != 0xFF {
            return None;
        }
        let len = u16::from_be_bytes([j[i + 2], j[i + 3]]) as usize;
        match j[i + 1] {
            0xC0 => sof = Some(i),
            0xDA => return Some((sof?, i + 2 + len)),
            _ => {}
        }
        i += 2 + len;
    }
    None
}

/// Encodes linear RGB as OpenEXR (32-bit float).
pub fn encode_exr(img: &[Rgb], w: u32, h: u32) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let flat: Vec<f32> = img.iter().flatten().copied().collect();
    let mut out = std::io::Cursor::new(Vec::new());
    image::codecs::openexr::OpenExrEncoder::new(&mut out)
        .write_image(
            bytemuck::cast_slice(&flat),
            w,
            h,
            image::ExtendedColorType::Rgb32F,
        )
        .map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Writes linear RGB as PFM (little-endian, bottom row first), as the reference images.
pub fn encode_pfm(img: &[Rgb], w: u32, h: u32) -> Vec<u8> {
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in (0..h as usize).rev() {
        for p in &img[y * w as usize..(y + 1) * w as usize] {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lux_labels_are_short_and_round() {
        assert_eq!(lux_label(0.5), "0.5");
        assert_eq!(lux_label(2.0), "2");
        assert_eq!(lux_label(500.0), "500");
        assert_eq!(lux_label(1000.0), "1k");
        assert_eq!(lux_label(20000.0), "20k");
    }

    #[test]
    fn legend_labels_are_drawn_in_white_beside_the_bar() {
        let (w, h) = (400u32, 300u32);
        let img = vec![[0.0f32; 3]; (w * h) as usize];
        let out = false_color(&img, w, h, 1.0, 100.0);
        let bar = w / 24;
        let white = |x: u32, y: u32| {
            let i = 3 * (y * w + x) as usize;
            out[i..i + 3] == [255, 255, 255]
        };
        // Labels at 1, 2, 5, 10, 20, 50 and 100 lx fit at this height: white text left of
        // the bar near the top (100 lx) and the bottom (1 lx), none elsewhere in the image.
        let band =
            |y0: u32, y1: u32| (y0..y1).any(|y| (w - bar - 60..w - bar).any(|x| white(x, y)));
        assert!(band(0, 12), "no label at the top");
        assert!(band(h - 12, h), "no label at the bottom");
        assert!(!(0..h).any(|y| (0..w / 2).any(|x| white(x, y))));
    }

    /// The strip-parallel JPEG decodes to exactly the pixels of a one-piece encode.
    #[test]
    fn strip_parallel_jpeg_decodes_like_a_single_encode() {
        for (w, h) in [(1024u32, 768u32), (333, 250), (64, 17)] {
            let rgb: Vec<u8> = (0..w * h)
                .flat_map(|i| {
                    let (x, y) = (i % w, i / w);
                    let n = (i.wrapping_mul(2_654_435_761) >> 27) as u8;
                    [
                        (x * 255 / w) as u8,
                        (y * 255 / h) as u8 ^ n,
                        ((x + y) % 256) as u8,
                    ]
                })
                .collect();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(3)
                .build()
                .unwrap();
            let fast = pool.install(|| encode_jpeg(&rgb, w, h)).unwrap();
            let mut single = Vec::new();
            let mut enc = jpeg_encoder::Encoder::new(&mut single, JPEG_QUALITY);
            enc.set_sampling_factor(jpeg_encoder::SamplingFactor::F_2_2);
            enc.encode(&rgb, w as u16, h as u16, jpeg_encoder::ColorType::Rgb)
                .unwrap();
            let decode = |b: &[u8]| {
                image::load_from_memory_with_format(b, image::ImageFormat::Jpeg)
                    .unwrap()
                    .to_rgb8()
            };
            // Restart markers run RST0, RST1, ..., RST7, RST0, ... once per MCU row boundary.
            let (_, data) = jpeg_layout(&fast).unwrap();
            let rst: Vec<u8> = fast[data..]
                .windows(2)
                .filter(|p| p[0] == 0xFF && (0xD0..=0xD7).contains(&p[1]))
                .map(|p| p[1] - 0xD0)
                .collect();
            assert_eq!(rst.len() as u32, h.div_ceil(16) - 1, "{w}x{h}");
            assert!(
                rst.iter().enumerate().all(|(k, &m)| m as usize == k % 8),
                "{rst:?}"
            );
            let (a, b) = (decode(&fast), decode(&single));
            assert_eq!(a.dimensions(), (w, h));
            assert!(a.as_raw() == b.as_raw(), "{w}x{h}: pixels differ");
        }
    }

    #[test]
    fn jpeg_strip_split_panicked_with_more_threads_than_strips() {
        // Every height and thread count: strips are non-empty and cover the image.
        for threads in 1..=16 {
            for h in 1..=600u32 {
                let (strips, rows) = jpeg_strips(h, threads);
                assert!(strips >= 1 && rows % 16 == 0, "h {h} threads {threads}");
                assert!(
                    (strips - 1) * rows < h && h <= strips * rows,
                    "h {h} threads {threads}"
                );
            }
        }
        // The heights of the report, encoded for real on 1..16 threads.
        for threads in 1..=16 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for h in [1u32, 15, 17, 130, 150, 200] {
                let w = 40;
                let rgb: Vec<u8> = (0..3 * w * h).map(|i| (i % 251) as u8).collect();
                let jpeg = pool.install(|| encode_jpeg(&rgb, w, h)).unwrap();
                let img = image::load_from_memory_with_format(&jpeg, image::ImageFormat::Jpeg)
                    .unwrap()
                    .to_rgb8();
                assert_eq!(img.dimensions(), (w, h), "threads {threads}");
            }
        }
    }

    #[test]
    fn false_color_range_to_1e39_allocated_until_abort() {
        // 1e39 lux is +inf as f32: the legend's tick loop ran over 2^31 decades.
        let img = vec![[1.0f32; 3]; 64 * 48];
        for (lo, hi) in [
            (1.0, f32::INFINITY),
            (f32::NAN, f32::NAN),
            (0.0, 0.0),
            (f32::MAX, f32::MAX),
            (-5.0, -1.0),
            (1e-30, 1e30),
        ] {
            let out = false_color(&img, 64, 48, lo, hi);
            assert_eq!(out.len(), 3 * 64 * 48);
            let (a, b) = false_color_range(lo, hi);
            assert!(
                a.is_finite() && b.is_finite() && b > a && a > 0.0,
                "{lo} {hi}"
            );
        }
    }

    #[test]
    fn view_buffer_estimate_bounds_the_real_size() {
        let cam = Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            width: 4096,
            height: 4096,
        };
        // 4096² at 2×2 samples: 64 bytes of samples and 136 of weights per pixel.
        let e = ViewBuffer::estimate_bytes(&cam);
        assert_eq!(e, 4096 * 4096 * 200);
    }
}
