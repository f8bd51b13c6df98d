//! The view buffer: the scene rasterized into per-pixel shading-vertex weights.
//!
//! [`ViewBuffer::build`] runs a z-buffer at S×S samples per pixel (3×3, or 2×2 above 1.2
//! million pixels), culling back faces and clipping at the near plane, then resolves the
//! samples: every pixel keeps the few shading vertices it blends, weighted by barycentric
//! × sample coverage. A relit image is then a gather of vertex values
//! ([`ViewBuffer::gather`], [`ViewBuffer::gather_tonemapped`]).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::camera::Camera;
use super::shading::Shading;
use super::tonemap::{tonemap_pixels, ToneMap};
use crate::color::Rgb;
use crate::geometry::mesh::Mesh;

/// Largest image side.
pub const MAX_SIDE: u32 = 4096;

/// Per pixel: the shading vertices it blends and their weights (CSR).
pub struct ViewBuffer {
    pub(super) width: u32,
    pub(super) height: u32,
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
    /// Cornell box averages 2.9 (`tests/it/hardening/resources.rs` checks the bound).
    pub fn estimate_bytes(cam: &Camera) -> u64 {
        let s = samples_per_side(cam) as u64;
        let px = cam.width as u64 * cam.height as u64;
        px * (16 * s * s + 2 * 8 * EST_WEIGHTS_PER_PIXEL + 8)
    }

    /// Rasterizes `mesh` seen by `cam`.
    pub fn build(mesh: &Mesh, shading: &Shading, cam: &Camera) -> ViewBuffer {
        let s = samples_per_side(cam);
        let (w, h) = (cam.width as usize, cam.height as usize);
        let (depth, sample) = rasterize(mesh, cam, s);
        let rows = resolve_rows(&sample, mesh, shading, w, h, s);
        // The samples are resolved: free them before the rows are joined, and join into
        // buffers of the exact size (no doubling).
        drop(depth);
        drop(sample);
        ViewBuffer::join(rows, cam)
    }

    /// The view buffer of `cam` from its resolved rows, top to bottom.
    fn join(rows: Vec<PixelRow>, cam: &Camera) -> ViewBuffer {
        let (w, h) = (cam.width as usize, cam.height as usize);
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
        let mut acc = Rgb::ZERO;
        for k in self.start[i] as usize..self.start[i + 1] as usize {
            let w = self.weight[k] * scale;
            acc += w * values[self.sv[k] as usize];
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

    /// [`ViewBuffer::gather_tonemapped`] with a per-pixel linear value `extra` added.
    pub fn gather_tonemapped_plus(
        &self,
        values: &[Rgb],
        scale: f32,
        extra: &[Rgb],
        exposure: Option<f32>,
        tm: ToneMap,
    ) -> (Vec<u8>, f32) {
        tonemap_pixels(
            self.pixels(),
            |i| self.pixel(i, values, scale) + extra[i],
            exposure,
            tm,
        )
    }

    /// Number of pixels.
    pub(super) fn pixels(&self) -> usize {
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

/// Per sample: element (u32::MAX: none), and barycentrics b1, b2 (b0 = 1 − b1 − b2).
type Sample = (u32, f32, f32);

/// The z-buffer pass at `s`×`s` samples per pixel: per sample, the depth and the nearest
/// front-facing patch with its perspective-correct barycentrics.
fn rasterize(mesh: &Mesh, cam: &Camera, s: u32) -> (Vec<f32>, Vec<Sample>) {
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
    let mut zb = ZBuffer {
        sw,
        sh,
        depth: vec![f32::INFINITY; sw * sh],
        sample: vec![(u32::MAX, 0.0, 0.0); sw * sh],
    };
    let project = |c: Vec3| -> (f32, f32) {
        let x = c.x / (c.z * tan * aspect);
        let y = c.y / (c.z * tan);
        ((x * 0.5 + 0.5) * sw as f32, (0.5 - y * 0.5) * sh as f32)
    };
    for (ei, e) in mesh.elements.iter().enumerate() {
        // Back faces are culled: only fronts are ever lit, and the back of a two-sided
        // panel would z-fight with its front.
        let f = mesh.facet(ei);
        if f.normal.as_vec3().dot(cam.position - f.centroid.as_vec3()) <= 0.0 {
            continue;
        }
        let cc = e.v.map(|k| to_cam(mesh.vertices[k as usize]));
        let poly = clip_near(cc, near);
        if poly.len() < 3 {
            continue;
        }
        for k in 1..poly.len() - 1 {
            zb.triangle([poly[0], poly[k], poly[k + 1]], ei as u32, &project);
        }
    }
    (zb.depth, zb.sample)
}

/// Clips a camera-space triangle against the near plane z = `near`; the polygon keeps
/// barycentric tags.
fn clip_near(cc: [Vec3; 3], near: f32) -> Vec<(Vec3, Vec3)> {
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
    poly
}

/// Resolves the samples into per-pixel vertex weights, one [`PixelRow`] per image row.
fn resolve_rows(
    sample: &[Sample],
    mesh: &Mesh,
    shading: &Shading,
    w: usize,
    h: usize,
    s: u32,
) -> Vec<PixelRow> {
    let sw = w * s as usize;
    let inv = 1.0 / (s * s) as f32;
    (0..h)
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
                        let (e, b1, b2) = sample[idx];
                        if e == u32::MAX {
                            continue;
                        }
                        let corners = shading.corner[e as usize];
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
                let e = sample[(y * s as usize + mid) * sw + x * s as usize + mid].0;
                centre.push(match mesh.elements.get(e as usize) {
                    Some(el) => el.patch,
                    None => u32::MAX,
                });
                counts.push(local.len() as u32);
                for (v, wgt) in local {
                    svs.push(v);
                    wts.push(wgt);
                }
            }
            (counts, svs, wts, centre)
        })
        .collect()
}

/// The depth and sample buffers of [`rasterize`], `sw` × `sh` samples.
struct ZBuffer {
    sw: usize,
    sh: usize,
    depth: Vec<f32>,
    sample: Vec<Sample>,
}

/// The samples `first..=last` along one axis that screen coordinates `v` span, clipped to
/// `0..n` (`last` negative: all before the first).
#[inline]
fn span(v: [f32; 3], n: usize) -> (usize, isize) {
    let first = v
        .iter()
        .copied()
        .fold(f32::INFINITY, f32::min)
        .floor()
        .max(0.0) as usize;
    let last =
        (v.iter().copied().fold(f32::NEG_INFINITY, f32::max).ceil() as isize).min(n as isize - 1);
    (first, last)
}

impl ZBuffer {
    /// Rasterizes the camera-space triangle `t` (corners with their barycentric tags) of
    /// patch `patch`, keeping the nearest sample; `project` maps camera space to samples.
    fn triangle(
        &mut self,
        t: [(Vec3, Vec3); 3],
        patch: u32,
        project: &impl Fn(Vec3) -> (f32, f32),
    ) {
        let s = t.map(|(c, _)| project(c));
        let iz = t.map(|(c, _)| 1.0 / c.z);
        let area = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[2].0 - s[0].0) * (s[1].1 - s[0].1);
        if area.abs() < 1e-12 {
            return;
        }
        let (minx, maxx) = span(s.map(|p| p.0), self.sw);
        let (miny, maxy) = span(s.map(|p| p.1), self.sh);
        if maxx < 0 || maxy < 0 {
            return;
        }
        let inv_area = 1.0 / area;
        for y in miny..=maxy as usize {
            let py = y as f32 + 0.5;
            for x in minx..=maxx as usize {
                let px = x as f32 + 0.5;
                // Edge functions (screen-space barycentrics), inclusive with a tiny
                // tolerance so shared edges leave no gaps.
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
                let idx = y * self.sw + x;
                if z >= self.depth[idx] {
                    continue;
                }
                self.depth[idx] = z;
                let bary =
                    (t[0].1 * (w0 * iz[0]) + t[1].1 * (w1 * iz[1]) + t[2].1 * (w2 * iz[2])) * z;
                self.sample[idx] = (patch, bary.y, bary.z);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
