//! The `final` render quality: per-pixel direct light, a one-bounce final gather from the
//! solved radiosity, and the luminaires in view, kept as one linear image per light group.
//!
//! This is the classic "regather" of Lightscape and 3ds Max on top of a radiosity
//! solution, laid out like Radiance's `rcontrib`: every pixel gets, per light group at
//! unit weight,
//!
//! - **direct light, exactly** ([`lights`]): shadow rays to each point luminaire (its
//!   photometric intensity towards the point; over its luminous opening when near), and
//!   for emissive surfaces the exact unoccluded form factor of each emitting triangle times
//!   its visible fraction, estimated with stratified shadow rays;
//! - **indirect light** ([`gather`]): cosine-weighted gather rays that read the group's
//!   *reflected* radiosity `B − E` where they land, interpolated over the shading vertices
//!   (never a patch-constant step). Emission is left out of the gather because the direct
//!   part carries it, so no light is counted twice;
//! - **what the camera sees of the emitters**: emissive surfaces at their luminance `E/π`,
//!   and each luminaire's luminous opening ([`openings`]) at its average luminance towards
//!   the camera, `I/A_proj`.
//!
//! The indirect part is denoised by an edge-avoiding à-trous filter ([`filter`]) whose
//! weights depend on geometry only (normals, positions, surfaces), so every group image
//! stays linear and relighting commutes with it: a lighting state is still
//! `Σ_g w_g ⊙ image_g` ([`GroupImages`]). One set of rays serves every group.
//!
//! Memory: the group images (12 bytes per pixel and group) plus, while building, the
//! direct and indirect accumulators and one filter buffer (36 bytes per pixel and group)
//! and the guides (32 bytes per pixel): [`estimate_bytes`].

mod filter;
mod gather;
mod lights;
mod openings;

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::{Camera, GroupImages, Shading};
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::model::{Cancel, QueryError};
use crate::scene::{LightGroup, Triangle};
use crate::transport::formfactor::Rng;
use crate::transport::transfer::GroupColumns;

use filter::Guide;

/// How much work a `final` image gets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinalSettings {
    /// Jittered primary samples per pixel side (k² per pixel), for antialiasing.
    pub samples_per_side: u32,
    /// Gather rays per pixel, shared among its samples.
    pub gather_rays: u32,
    /// Shadow rays per pixel sample for the dominant emitting triangle (fewer for
    /// triangles that give less light, at least 1).
    pub emitter_rays: u32,
    /// À-trous passes over the indirect light (0: unfiltered).
    pub filter_passes: u32,
}

impl Default for FinalSettings {
    fn default() -> Self {
        let env = |k: &str, d: u32| {
            std::env::var(k)
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(d)
        };
        FinalSettings {
            samples_per_side: env("RELIGHT_FINAL_SPS", 2),
            gather_rays: env("RELIGHT_FINAL_GATHER", 64),
            emitter_rays: env("RELIGHT_FINAL_EMITTER", 16),
            filter_passes: env("RELIGHT_FINAL_FILTER", 2),
        }
    }
}

/// What a `final` image reads of a baked scene.
pub struct FinalScene<'a> {
    pub mesh: &'a Mesh,
    pub shading: &'a Shading,
    /// A BVH over the mesh's patches (ids = patch indices): [`patch_bvh`], for the
    /// gather's nearest hits.
    pub patches: &'a Bvh,
    /// The scene BVH (ids = scene triangles), for shadow rays.
    pub bvh: &'a Bvh,
    /// The scene's input triangles (the emitters' exact shapes).
    pub triangles: &'a [Triangle],
    /// Per patch reflectance.
    pub rho: &'a [Rgb],
    /// Per light group, its solved columns at unit weight.
    pub groups: &'a [GroupColumns],
    /// The scene's light groups (their point luminaires).
    pub lights: &'a [LightGroup],
}

/// Most pixels a `final` image may have (1024 × 1024): its cost grows with the pixels
/// times the rays per pixel, and a request must finish within the server's timeout.
pub const MAX_FINAL_PIXELS: u64 = 1 << 20;

/// Bytes per patch that [`patch_bvh`] allocates, at most (a stored triangle, its id, two
/// nodes and the build's temporaries).
pub const PATCH_BVH_BYTES_PER_PATCH: u64 = 200;

/// A BVH over `mesh`'s patches, ids = patch indices: the final gather's hits then name
/// the patch and the point on it.
pub fn patch_bvh(mesh: &Mesh) -> Bvh {
    let tris: Vec<[Vec3A; 3]> = (0..mesh.len())
        .map(|j| mesh.corners(j).map(|p| Vec3A::from(p.as_vec3())))
        .collect();
    Bvh::new(&tris)
}

/// Peak bytes [`build`] allocates for `groups` light groups on `cam`.
pub fn estimate_bytes(cam: &Camera, groups: usize) -> u64 {
    let px = cam.width as u64 * cam.height as u64;
    px * (48 * groups.max(1) as u64 + 12 + std::mem::size_of::<Guide>() as u64)
}

/// One pixel's accumulators while tracing.
struct PixelSums<'a> {
    /// Per group RGB radiance that needs no filtering (direct light, emitters), cd/m².
    direct: &'a mut [f32],
    /// Per group RGB indirect radiance, cd/m² (filtered later).
    indirect: &'a mut [f32],
    /// Mean reflectance of the pixel's samples.
    albedo: &'a mut Rgb,
}

/// The per-image constants of the tracer.
struct Tracer<'a> {
    scene: &'a FinalScene<'a>,
    lights: lights::GroupLights<'a>,
    reflected: gather::Reflected,
    openings: openings::Openings,
    rays: super::daylight::CameraRays,
    settings: FinalSettings,
    groups: usize,
}

/// Builds the `final` images of every light group of `scene` seen by `cam`, at unit
/// weight. `Err(Cancelled)` once `cancel` is raised (checked per row).
pub fn build(
    scene: &FinalScene<'_>,
    cam: &Camera,
    settings: &FinalSettings,
    cancel: &Cancel,
) -> Result<GroupImages, QueryError> {
    let g = scene.groups.len();
    let lights = lights::GroupLights::new(scene);
    let tracer = Tracer {
        reflected: gather::Reflected::new(scene, &lights),
        openings: openings::Openings::new(scene.lights),
        rays: super::daylight::CameraRays::new(cam),
        lights,
        settings: *settings,
        groups: g,
        scene,
    };
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut direct = vec![0f32; w * h * 3 * g];
    let mut indirect = vec![0f32; w * h * 3 * g];
    let mut albedo = vec![Rgb::ZERO; w * h];
    let mut guides = vec![Guide::default(); w * h];
    let mut saw_emitter = vec![false; w * h];
    let row = 3 * g * w;
    direct
        .par_chunks_mut(row.max(1))
        .zip(indirect.par_chunks_mut(row.max(1)))
        .zip(albedo.par_chunks_mut(w).zip(guides.par_chunks_mut(w)))
        .zip(saw_emitter.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (((dr, ir), (al, gd)), saw))| {
            if cancel.is_cancelled() {
                return;
            }
            for x in 0..w {
                let sums = PixelSums {
                    direct: &mut dr[3 * g * x..3 * g * (x + 1)],
                    indirect: &mut ir[3 * g * x..3 * g * (x + 1)],
                    albedo: &mut al[x],
                };
                (gd[x], saw[x]) = tracer.pixel(x, y, sums);
            }
        });
    cancel.check()?;
    tracer.emitter_rims(&saw_emitter, (w, h), &mut direct);
    let footprint = 2.0 * ((cam.fov_deg as f64).to_radians() * 0.5).tan() / h as f64;
    filter::denoise(
        &mut indirect,
        &albedo,
        &guides,
        (w, h, g),
        footprint as f32,
        settings.filter_passes,
    );
    for (d, i) in direct.iter_mut().zip(&indirect) {
        *d += i;
    }
    Ok(GroupImages::from_parts(cam.width, cam.height, g, direct))
}

/// Primary rays per side of the grid that measures what a pixel sees of emitters where an
/// emitter's edge crosses it: some of its samples met an emitter and some did not, or none
/// did and a neighbour's did. The edge is antialiased to 1/1024 of the pixel, since a
/// sliver of a bright emitter still shows.
const EMITTER_GRID: usize = 32;

impl Tracer<'_> {
    /// Traces pixel (x, y) into `sums`; the guide of its first sample, and whether a
    /// sample met an emitter.
    fn pixel(&self, x: usize, y: usize, sums: PixelSums<'_>) -> (Guide, bool) {
        let k = self.settings.samples_per_side.max(1) as usize;
        let samples = (k * k) as f32;
        let mut rng = Rng::new(y * self.rays.width() + x, 0x5eed);
        let gather_each = (self.settings.gather_rays as usize).div_ceil(k * k);
        let mut guide = Guide::default();
        let g = self.groups;
        let mut scratch = lights::Scratch::default();
        let mut dir_s = vec![0f32; 3 * g];
        let mut ind_s = vec![0f32; 3 * g];
        let mut emitted = vec![0f32; 3 * g];
        let mut emitter_samples = 0;
        for s in 0..k * k {
            let (sx, sy) = (
                ((s % k) as f64 + rng.next_f64()) / k as f64,
                ((s / k) as f64 + rng.next_f64()) / k as f64,
            );
            let d = self.rays.dir_at(x as f64 + sx, y as f64 + sy);
            dir_s.iter_mut().for_each(|v| *v = 0.0);
            ind_s.iter_mut().for_each(|v| *v = 0.0);
            let hit = self.primary(d);
            emitter_samples += usize::from(self.emitted_along(d, hit, &mut emitted));
            let seen = self.sample(
                d,
                hit,
                &mut rng,
                &mut scratch,
                (&mut dir_s, &mut ind_s),
                gather_each,
            );
            if s == 0 {
                guide = seen.guide;
            }
            *sums.albedo += seen.albedo / samples;
            for (a, v) in sums.direct.iter_mut().zip(&dir_s) {
                *a += v / samples;
            }
            for (a, v) in sums.indirect.iter_mut().zip(&ind_s) {
                *a += v / samples;
            }
        }
        if emitter_samples > 0 && emitter_samples < k * k {
            // An emitter's edge in the pixel: measure its coverage on a fine grid instead.
            self.emitted_in_pixel(x, y, sums.direct);
        } else {
            for (a, v) in sums.direct.iter_mut().zip(&emitted) {
                *a += v / samples;
            }
        }
        (guide, emitter_samples > 0)
    }

    /// Adds what pixel (x, y) sees emitted, measured on an [`EMITTER_GRID`]² grid of
    /// primary rays (per group radiance, cd/m²).
    fn emitted_in_pixel(&self, x: usize, y: usize, out: &mut [f32]) {
        let mut emitted = vec![0f32; out.len()];
        let n = EMITTER_GRID;
        for i in 0..n * n {
            let (sx, sy) = (
                ((i % n) as f64 + 0.5) / n as f64,
                ((i / n) as f64 + 0.5) / n as f64,
            );
            let d = self.rays.dir_at(x as f64 + sx, y as f64 + sy);
            self.emitted_along(d, self.primary(d), &mut emitted);
        }
        let m = (n * n) as f32;
        for (a, v) in out.iter_mut().zip(&emitted) {
            *a += v / m;
        }
    }

    /// The pixels beside one whose samples met an emitter, that none of their own samples
    /// met: an emitter's edge may cover a sliver of them that their few samples missed,
    /// so their coverage is measured on the fine grid too ([`Self::emitted_in_pixel`]).
    fn emitter_rims(&self, saw: &[bool], (w, h): (usize, usize), direct: &mut [f32]) {
        let near = |x: usize, y: usize| {
            (y.saturating_sub(1)..=(y + 1).min(h - 1))
                .any(|yy| (x.saturating_sub(1)..=(x + 1).min(w - 1)).any(|xx| saw[yy * w + xx]))
        };
        let stride = 3 * self.groups;
        direct
            .par_chunks_mut((stride * w).max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    if !saw[y * w + x] && near(x, y) {
                        self.emitted_in_pixel(x, y, &mut row[stride * x..stride * (x + 1)]);
                    }
                }
            });
    }

    /// The nearest patch whose front the camera ray along `d` meets.
    fn primary(&self, d: DVec3) -> Option<(f32, u32)> {
        let mesh = self.scene.mesh;
        self.scene.patches.nearest_ranked(
            Vec3A::from(self.rays.origin().as_vec3()),
            Vec3A::from(d.as_vec3()),
            0.0,
            f32::INFINITY,
            |q| u8::from(mesh.patches[q as usize].normal.dot(d) < 0.0),
        )
    }

    /// Adds what the camera ray along `d` (meeting `hit`) sees emitted (per group radiance, cd/m²): an
    /// emissive surface's `E/π` or a luminaire's opening; whether it saw any.
    fn emitted_along(&self, d: DVec3, hit: Option<(f32, u32)>, out: &mut [f32]) -> bool {
        let t_scene = hit.map_or(f64::INFINITY, |(t, _)| t as f64);
        if self.openings.seen(self.rays.origin(), d, t_scene, out) {
            return true;
        }
        let Some((_, p)) = hit else { return false };
        let mut any = false;
        for (o, col) in Rgb::column_mut(out).iter_mut().zip(self.scene.groups) {
            let e = Rgb::column(&col.e)[p as usize];
            *o += e * std::f32::consts::FRAC_1_PI;
            any |= e.iter().any(|&v| v > 0.0);
        }
        any
    }

    /// One camera ray along `d`, which meets `hit`: adds the light its surface reflects per group, direct
    /// (exact) and indirect (gathered) radiance, cd/m². Emission is [`Self::emitted_along`].
    fn sample(
        &self,
        d: DVec3,
        hit: Option<(f32, u32)>,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        out: (&mut [f32], &mut [f32]),
        gather_rays: usize,
    ) -> Seen {
        let (direct, indirect) = out;
        let o = self.rays.origin();
        let t_scene = hit.map_or(f64::INFINITY, |(t, _)| t as f64);
        if self.openings.blocks(o, d, t_scene) {
            return Seen::default();
        }
        let Some((t, p)) = hit else {
            return Seen::default();
        };
        let patch = &self.scene.mesh.patches[p as usize];
        let x = o + d * t as f64;
        let n = patch.normal;
        let rho = self.scene.rho[p as usize];
        let inv_pi = std::f32::consts::FRAC_1_PI;
        // Direct light (lux) and gathered indirect light (lux), then × ρ/π.
        let mut e_direct = std::mem::take(&mut scratch.lux);
        e_direct.clear();
        e_direct.resize(3 * self.groups, 0.0);
        self.lights.direct(
            (x, n, p),
            self.settings.emitter_rays,
            rng,
            scratch,
            &mut e_direct,
        );
        if gather_rays > 0 {
            let mut near =
                |at: DVec3, q: u32, rng: &mut Rng, v: &mut [f32]| self.reflected_at(at, q, rng, v);
            self.reflected.gather(
                self.scene,
                (x, n, p),
                gather_rays,
                rng,
                Some(&mut near),
                indirect,
            );
        }
        // Per group: direct += ρ/π · E_direct, indirect ×= ρ/π.
        let reflect = rho * inv_pi;
        let (direct, indirect) = (Rgb::column_mut(direct), Rgb::column_mut(indirect));
        for ((d, i), &e) in direct.iter_mut().zip(indirect).zip(Rgb::column(&e_direct)) {
            *d += reflect * e;
            *i *= reflect;
        }
        scratch.lux = e_direct;
        Seen {
            albedo: rho,
            guide: Guide {
                position: x.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                surface: patch.surface,
                depth: t,
            },
        }
    }
}

impl Tracer<'_> {
    /// The radiosity reflected at point `at` of patch `q`, per group (lm/m², emission
    /// left out as in the gather's table): `ρ (direct + gathered)`, with a small gather
    /// that reads the patches.
    fn reflected_at(&self, at: DVec3, q: u32, rng: &mut Rng, out: &mut [f32]) {
        let patch = &self.scene.mesh.patches[q as usize];
        let mut scratch = lights::Scratch::default();
        let mut lux = vec![0f32; out.len()];
        self.lights.direct(
            (at, patch.normal, q),
            NEAR_EMITTER_RAYS,
            rng,
            &mut scratch,
            &mut lux,
        );
        self.reflected.gather(
            self.scene,
            (at, patch.normal, q),
            NEAR_GATHER_RAYS,
            rng,
            None,
            &mut lux,
        );
        let rho = self.scene.rho[q as usize];
        let (out, lux) = (Rgb::column_mut(out), Rgb::column(&lux));
        for (k, col) in self.scene.groups.iter().enumerate() {
            let own = if self.lights.explicit(k) { 0.0 } else { 1.0 };
            out[k] = rho * lux[k] + own * Rgb::column(&col.e)[q as usize];
        }
    }
}

/// Rays of the small gather at a point a gather ray landed on close by.
const NEAR_GATHER_RAYS: usize = 9;

/// Shadow rays per emitting triangle for the direct light at such a point: its value is
/// one of the many that a pixel's gather averages, so a few rays suffice.
const NEAR_EMITTER_RAYS: u32 = 2;

/// What a camera sample saw: its reflectance and its filter guide.
#[derive(Default)]
struct Seen {
    albedo: Rgb,
    guide: Guide,
}
