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
//!   the camera, `I/A_proj`;
//! - **glossy reflection** ([`specular`]), on glTF materials with a specular lobe: the
//!   luminaires' and the sun's highlights, and reflection rays that read the solution.
//!
//! The indirect part, less the noise-free irradiance the solved radiosity gives at the
//! pixel's point ([`gather::Reflected::expected`]), is denoised by an edge-avoiding
//! à-trous filter ([`filter`]) whose weights depend on geometry only (normals,
//! positions, surfaces), so every group image stays linear and relighting commutes with it: a lighting state is still
//! `Σ_g w_g ⊙ image_g` ([`GroupImages`]). One set of rays serves every group.
//!
//! Memory: the group images (12 bytes per pixel and group) plus, while building, the
//! direct, indirect, expected and emitted accumulators and one filter buffer (60 bytes
//! per pixel and group), two filter guides per pixel (36 bytes each: the pixel's and its
//! corner ray's), and the light the gather reads (12 bytes per group at every grid
//! corner of the patch lookup, every patch, and four times at every shading vertex):
//! [`estimate_bytes`].

mod emitted;
mod filter;
mod gather;
mod lights;
mod openings;
mod settings;
mod sky;
mod specular;

pub use settings::{FinalSettings, GATHER_REFERENCE_PIXELS};
pub use sky::FinalSky;

use emitted::Coverage;

use glam::DVec3;
use rayon::prelude::*;

use super::{Camera, GroupImages, Shading};
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::geometry::patch_locator::{max_grid_corners, PatchLocator};
use crate::model::{Cancel, QueryError};
use crate::sampling::{shuffle, Rng};
use crate::scene::{LightGroup, Material, Triangle};
use crate::transport::transfer::GroupColumns;

use filter::Guide;

/// What a `final` image reads of a baked scene.
pub struct FinalScene<'a> {
    pub mesh: &'a Mesh,
    pub shading: &'a Shading,
    /// Finds the patch a ray meets on the scene BVH ([`patch_locator`]), for the camera
    /// rays and the gather's nearest hits.
    pub patches: &'a PatchLocator,
    /// The scene BVH (ids = scene triangles), for shadow rays.
    pub bvh: &'a Bvh,
    /// The scene's input triangles (the emitters' exact shapes).
    pub triangles: &'a [Triangle],
    /// The scene's materials, by the triangles' `material` (their specular lobes).
    pub materials: &'a [Material],
    /// Per patch reflectance.
    pub rho: &'a [Rgb],
    /// Per light group, its solved columns at unit weight.
    pub groups: &'a [GroupColumns],
    /// The scene's light groups (their point luminaires).
    pub lights: &'a [LightGroup],
    /// With a sky, [`build`] makes one image, the daylight, instead of the groups'.
    pub sky: Option<FinalSky<'a>>,
}

/// A row's buffers for its pixels' samples, reused from pixel to pixel.
#[derive(Default)]
struct Buffers {
    scratch: lights::Scratch,
    /// Per group RGB: one sample's direct, indirect and expected light, and the emission
    /// the camera sees.
    dir_s: Vec<f32>,
    ind_s: Vec<f32>,
    exp_s: Vec<f32>,
    emitted: Vec<f32>,
    /// The order in which a pixel's samples take the cells of its grid.
    cells: Vec<usize>,
}

/// Pixels per side of a block whose gathers share one grid of directions, each pixel's
/// rays in its own sub-cell of every cell: the block's pixels then sample the hemisphere
/// together on a grid `BLOCK` times finer per axis, and the filter, which averages
/// neighbours, sees their errors cancel. On the Cornell box at 512² (64 rays per pixel,
/// six seeds against the 262,144-spp path tracing) the noise fell from 0.79 % to 0.69 %
/// (0.70 % with blocks of 2), the bias unchanged (0.37 %).
const BLOCK: usize = 4;

/// Mixed into the random sequences of the blocks' shared grids.
const BLOCK_SALT: usize = 0xb10c;

/// Most pixels a `final` image may have (1024 × 1024): its cost grows with the pixels
/// times the rays per pixel, and a request must finish within the server's timeout.
pub const MAX_FINAL_PIXELS: u64 = 1 << 20;

/// Bytes [`patch_locator`] allocates for `mesh` and its scene's `triangles`, at most.
pub fn patch_locator_bytes(mesh: &Mesh, triangles: usize) -> u64 {
    use crate::geometry::patch_locator::{LOCATOR_BYTES_PER_PATCH, LOCATOR_BYTES_PER_TRIANGLE};
    LOCATOR_BYTES_PER_PATCH * mesh.len() as u64 + LOCATOR_BYTES_PER_TRIANGLE * triangles as u64
}

/// The index of `mesh`'s patches by the scene triangles they were cut from: a ray traced
/// on the scene BVH then names the patch it meets and the point on it.
pub fn patch_locator(mesh: &Mesh, triangles: &[Triangle]) -> PatchLocator {
    PatchLocator::new(mesh, triangles)
}

/// Peak bytes [`build`] allocates for `groups` light groups on `cam`, where the gather
/// reads the radiosity at `gather_points` points per group ([`gather_points`]).
pub fn estimate_bytes(cam: &Camera, groups: usize, gather_points: u64) -> u64 {
    let px = cam.width as u64 * cam.height as u64;
    let g = groups.max(1) as u64;
    px * (72 * g + 13 + 2 * std::mem::size_of::<Guide>() as u64)
        + gather::REFLECTED_BYTES_PER_POINT_AND_GROUP * g * gather_points
}

/// The points per group at which a build's gather holds light (12 bytes each): every
/// grid corner of `patches`, every patch of `mesh`, and every shading vertex of `shading`
/// four times (the direct light, the reflected light, the expected irradiance and its
/// interleaved copy). Without the patch lookup (not built yet), a bound from the mesh
/// ([`max_grid_corners`]).
pub fn gather_points(
    patches: Option<&PatchLocator>,
    mesh: &Mesh,
    triangles: usize,
    shading: usize,
) -> u64 {
    let corners = match patches {
        Some(p) => p.corner_count() as u64,
        None => max_grid_corners(mesh.len(), triangles),
    };
    corners + mesh.len() as u64 + 4 * shading as u64
}

/// One pixel's accumulators while tracing.
struct PixelSums<'a> {
    /// Per group RGB radiance that needs no filtering (direct light), cd/m².
    direct: &'a mut [f32],
    /// Per group RGB indirect radiance, cd/m² (filtered later).
    indirect: &'a mut [f32],
    /// Per group RGB indirect radiance the solved radiosity gives (no noise), cd/m²:
    /// the filter smooths `indirect` less this.
    expected: &'a mut [f32],
    /// Per group RGB radiance of the emitters seen, cd/m².
    emitted: &'a mut [f32],
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
    let settings = &settings.for_pixels(cam.width as u64 * cam.height as u64);
    let g = if scene.sky.is_some() {
        1
    } else {
        scene.groups.len()
    };
    let lights = lights::GroupLights::new(scene);
    let reflected = gather::Reflected::new(scene, &lights);
    let tracer = Tracer {
        reflected,
        // The luminaires' openings show in the groups' images, not in the daylight's.
        openings: openings::Openings::new(if scene.sky.is_some() {
            &[]
        } else {
            scene.lights
        }),
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
    let mut emitted = vec![0f32; w * h * 3 * g];
    let mut expected = vec![0f32; w * h * 3 * g];
    let mut coverage = vec![Coverage::None; w * h];
    // What the rays through the pixels' corners see: a pixel whose four corners see
    // different surfaces gets more samples.
    let lattice: Vec<Guide> = (0..(w + 1) * (h + 1))
        .into_par_iter()
        .with_min_len(256)
        .map(|i| tracer.guide_at((i % (w + 1)) as f64, (i / (w + 1)) as f64))
        .collect();
    let split = |x: usize, y: usize| {
        let c = [
            &lattice[y * (w + 1) + x],
            &lattice[y * (w + 1) + x + 1],
            &lattice[(y + 1) * (w + 1) + x],
            &lattice[(y + 1) * (w + 1) + x + 1],
        ];
        c[1..].iter().any(|q| !q.alike(c[0]))
    };
    let row = 3 * g * w;
    direct
        .par_chunks_mut(row.max(1))
        .zip(indirect.par_chunks_mut(row.max(1)))
        .zip(emitted.par_chunks_mut(row.max(1)))
        .zip(albedo.par_chunks_mut(w).zip(guides.par_chunks_mut(w)))
        .zip(coverage.par_chunks_mut(w))
        .zip(expected.par_chunks_mut(row.max(1)))
        .enumerate()
        .for_each(|(y, (((((dr, ir), er), (al, gd)), cov), xr))| {
            if cancel.is_cancelled() {
                return;
            }
            let mut buffers = Buffers::default();
            for x in 0..w {
                let px = 3 * g * x..3 * g * (x + 1);
                let sums = PixelSums {
                    direct: &mut dr[px.clone()],
                    indirect: &mut ir[px.clone()],
                    expected: &mut xr[px.clone()],
                    emitted: &mut er[px],
                    albedo: &mut al[x],
                };
                (gd[x], cov[x]) = tracer.pixel(x, y, split(x, y), sums, &mut buffers);
            }
        });
    cancel.check()?;
    tracer.emitter_rims(&coverage, (w, h), &mut emitted);
    let footprint = 2.0 * ((cam.fov_deg as f64).to_radians() * 0.5).tan() / h as f64;
    // The filter smooths what the gather found beyond what the solution expects.
    indirect
        .par_iter_mut()
        .zip(&expected)
        .for_each(|(i, x)| *i -= x);
    filter::denoise(
        &mut indirect,
        &albedo,
        &guides,
        (w, h, g),
        footprint as f32,
        settings.filter_passes,
    );
    direct
        .par_iter_mut()
        .zip(&indirect)
        .zip(&emitted)
        .zip(&expected)
        .for_each(|(((d, i), e), x)| *d += i + e + x);
    Ok(GroupImages::from_parts(cam.width, cam.height, g, direct))
}

impl Tracer<'_> {
    /// Traces pixel (x, y) into `sums`; the guide of its first sample, and whether a
    /// sample met an emitter. A pixel that is `split` between surfaces (its corners see
    /// different ones: an edge or a silhouette) gets [`EDGE_SAMPLES`]× the samples per
    /// side, sharing the same gather rays among them: there its few samples would decide
    /// the split, and that error is larger than the gather's. The corners decide, not the
    /// pixel's own random samples: a pixel traced again when its samples disagreed, and
    /// kept when they agreed, leans towards the surface that covers more of it.
    fn pixel(
        &self,
        x: usize,
        y: usize,
        split: bool,
        mut sums: PixelSums<'_>,
        buffers: &mut Buffers,
    ) -> (Guide, Coverage) {
        let k = self.settings.samples_per_side.max(1) as usize;
        let mut rng = Rng::new(
            y * self.rays.width() + x,
            0x5eed ^ self.settings.seed as usize,
        );
        let k = if split && k * EDGE_SAMPLES <= MAX_SAMPLES_PER_SIDE {
            k * EDGE_SAMPLES
        } else {
            k
        };
        let traced = self.samples(x, y, k, &mut rng, &mut sums, buffers);
        (traced.guide, traced.emitters)
    }

    /// The filter guide of what the camera ray through image point (x, y) (in pixels)
    /// sees.
    fn guide_at(&self, x: f64, y: f64) -> Guide {
        let d = self.rays.dir_at(x, y);
        let hit = self.primary(d);
        let o = self.rays.origin();
        let t_scene = hit.map_or(f64::INFINITY, |(t, _)| t as f64);
        let Some((t, p)) = hit.filter(|_| !self.openings.blocks(o, d, t_scene)) else {
            return Guide::default();
        };
        let patch = &self.scene.mesh.patches[p as usize];
        Guide {
            position: (o + d * t as f64).as_vec3().to_array(),
            normal: patch.normal.as_vec3().to_array(),
            surface: patch.surface,
            depth: t,
            reach: f32::INFINITY,
        }
    }

    /// Traces `k × k` jittered samples of pixel (x, y) into `sums` (which start at zero).
    fn samples(
        &self,
        x: usize,
        y: usize,
        k: usize,
        rng: &mut Rng,
        sums: &mut PixelSums<'_>,
        buffers: &mut Buffers,
    ) -> Samples {
        let samples = (k * k) as f32;
        let gather_each = (self.settings.gather_rays as usize).div_ceil(k * k);
        // At least a 2 × 2 grid per sample: a split pixel's many samples each see their
        // own point, and a single ray per sample left edges speckled.
        let specular = self.settings.specular_rays as usize;
        let specular_each = if specular == 0 {
            0
        } else {
            specular.div_ceil(k * k).max(4)
        };
        let mut out = Samples::default();
        let g = self.groups;
        let Buffers {
            scratch,
            dir_s,
            ind_s,
            exp_s,
            emitted,
            cells,
        } = buffers;
        for v in [&mut *dir_s, &mut *ind_s, &mut *exp_s, &mut *emitted] {
            v.clear();
            v.resize(3 * g, 0.0);
        }
        let mut emitter_samples = 0;
        // One grid of gather directions for a block of BLOCK × BLOCK pixels: each pixel
        // takes one sub-cell (the same in every cell of its own grid, drawn without
        // replacement within the block, so every pixel's rays are unbiased), and each of
        // its samples one cell of each k × k block of that grid.
        // The cells go to the samples in a random order: a sample's own rays then cover
        // the whole hemisphere on average, so the light of a sample that sees another
        // surface than its pixel's others is unbiased too.
        let mut block_rng = Rng::new(
            (y / BLOCK) * self.rays.width().div_ceil(BLOCK) + x / BLOCK,
            BLOCK_SALT ^ self.settings.seed as usize,
        );
        let shift = (block_rng.next_f64(), block_rng.next_f64());
        let mut subs: [usize; BLOCK * BLOCK] = std::array::from_fn(|i| i);
        shuffle(&mut subs, &mut block_rng);
        let sub = subs[(y % BLOCK) * BLOCK + x % BLOCK];
        let (bx, by) = (sub % BLOCK, sub / BLOCK);
        cells.clear();
        cells.extend(0..k * k);
        shuffle(cells, rng);
        for (s, &cell) in cells.iter().enumerate() {
            let strata = gather::Strata {
                shift,
                interleave: k * BLOCK,
                cell: ((cell % k) * BLOCK + bx, (cell / k) * BLOCK + by),
            };
            let (sx, sy) = (rng.stratum(s % k, k), rng.stratum(s / k, k));
            let d = self.rays.dir_at(x as f64 + sx, y as f64 + sy);
            dir_s.iter_mut().for_each(|v| *v = 0.0);
            ind_s.iter_mut().for_each(|v| *v = 0.0);
            exp_s.iter_mut().for_each(|v| *v = 0.0);
            let hit = self.primary(d);
            emitter_samples += usize::from(self.emitted_along(d, hit, emitted));
            let seen = self.sample(
                d,
                hit,
                rng,
                scratch,
                (dir_s, ind_s, exp_s),
                (gather_each, strata, specular_each),
            );
            if s == 0 {
                out.guide = seen.guide;
            }
            *sums.albedo += seen.albedo / samples;
            for (a, v) in sums.direct.iter_mut().zip(dir_s.iter()) {
                *a += v / samples;
            }
            for (a, v) in sums.indirect.iter_mut().zip(ind_s.iter()) {
                *a += v / samples;
            }
            for (a, v) in sums.expected.iter_mut().zip(exp_s.iter()) {
                *a += v / samples;
            }
        }
        out.emitters = if emitter_samples == 0 {
            Coverage::None
        } else if emitter_samples < k * k {
            // An emitter's edge in the pixel: measure its coverage on a fine grid instead.
            self.emitted_in_pixel(x, y, sums.emitted);
            Coverage::Measured
        } else {
            for (a, v) in sums.emitted.iter_mut().zip(emitted.iter()) {
                *a += v / samples;
            }
            Coverage::All
        };
        out
    }

    /// The nearest patch whose front the camera ray along `d` meets.
    fn primary(&self, d: DVec3) -> Option<(f32, u32)> {
        let o = self.rays.origin();
        self.scene.patches.nearest(self.scene.bvh, o, d, None, true)
    }

    /// One camera ray along `d`, which meets `hit`: adds the light its surface reflects per group, direct
    /// (exact) and indirect (gathered) radiance, cd/m². Emission is [`Self::emitted_along`].
    fn sample(
        &self,
        d: DVec3,
        hit: Option<(f32, u32)>,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        out: (&mut [f32], &mut [f32], &mut [f32]),
        (gather_rays, strata, specular_rays): (usize, gather::Strata, usize),
    ) -> Seen {
        let (direct, indirect, expected) = out;
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
        // A glossy surface's specular lobe towards the camera: the point sources'
        // highlights (exact, no noise) go straight into the unfiltered direct part, as
        // radiance; its sampled light below.
        let lobe = self
            .scene
            .triangles
            .get(patch.source as usize)
            .and_then(|t| self.scene.materials.get(t.material as usize)?.gloss)
            .filter(|_| specular_rays > 0)
            .and_then(|g| specular::Lobe::new(&g, n, d));
        self.lights.direct(
            (x, n, p),
            lights::Rays::Stratified(self.settings.emitter_rays),
            rng,
            scratch,
            &mut e_direct,
            lobe.as_ref().map(|l| (l, &mut *direct)),
        );
        if let Some(sky) = &self.scene.sky {
            let sun = sky.sun_lux(self.scene.bvh, (x, n, patch.source));
            e_direct[..3].iter_mut().for_each(|v| *v += sun);
            if let (Some(lobe), Some(s), true) = (&lobe, &sky.sun, sun > 0.0) {
                let spread = 0.25 * crate::daylight::sky_luminance::SUN_DIAMETER_DEG.to_radians();
                Rgb::column_mut(direct)[0] += sun * lobe.brdf(s.direction, spread);
            }
        }
        let mut reach = f32::INFINITY;
        let aim = self.scene.sky.as_ref().and_then(|s| s.aim(p));
        if gather_rays > 0 {
            // The direct light's buffers are free until the specular lobe's light below.
            let mut near = |at: DVec3, q: u32, rng: &mut Rng, v: &mut [f32]| {
                self.reflected_at(at, q, rng, scratch, v)
            };
            reach = self.reflected.gather(
                self.scene,
                (x, n, p),
                (gather_rays, strata),
                rng,
                (Some(&mut near), aim.as_ref()),
                indirect,
            );
        }
        if let (Some(sky), Some(aim)) = (&self.scene.sky, &aim) {
            let cosine = if gather_rays > 0 {
                gather::ray_count(gather_rays)
            } else {
                0
            };
            let at = (x, n, patch.source);
            sky.aimed(self.scene.bvh, aim, at, cosine, rng, indirect);
        }
        if gather_rays > 0 {
            self.reflected.expected(self.scene, x, p, expected);
        }
        // Per group: direct += ρ/π · E_direct, indirect and expected ×= ρ/π; under a
        // specular lobe, the diffuse part keeps the share the lobe leaves it.
        let rho = match &lobe {
            Some(l) => rho * l.diffuse_share(),
            None => rho,
        };
        let reflect = rho * inv_pi;
        for (((d, i), x), &e) in Rgb::column_mut(direct)
            .iter_mut()
            .zip(Rgb::column_mut(indirect))
            .zip(Rgb::column_mut(expected))
            .zip(Rgb::column(&e_direct))
        {
            *d += reflect * e;
            *i *= reflect;
            *x *= reflect;
        }
        scratch.lux = e_direct;
        // The glossy lobe's sampled light: its reflections and its share of the emitting
        // surfaces. A wide lobe's goes through the filter with the gathered light (its
        // draws scatter over the room), demodulated by the lobe's Fresnel reflectance
        // beside ρ; a near mirror's draws all but agree, and stay sharp.
        let mut albedo = rho;
        if let Some(lobe) = &lobe {
            // A whole grid of rays, which the light samples' weights count.
            let (at, rays) = ((x, n, p), (lobe, gather::square_count(specular_rays)));
            let out = if lobe.filtered() {
                albedo += lobe.reflectance();
                &mut *indirect
            } else {
                &mut *direct
            };
            self.lights.specular_emitters(at, rays, rng, scratch, out);
            let rays = (rays.0, rays.1, &scratch.sampled[..]);
            self.reflected
                .specular(self.scene, &self.lights, at, rays, rng, out);
        }
        Seen {
            albedo,
            guide: Guide {
                position: x.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                surface: patch.surface,
                depth: t,
                reach,
            },
        }
    }
}

impl Tracer<'_> {
    /// The radiosity reflected at point `at` of patch `q`, per group (lm/m², emission
    /// left out as in the gather's table): `ρ (direct + gathered)`, with a small gather
    /// that reads the patches.
    fn reflected_at(
        &self,
        at: DVec3,
        q: u32,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        out: &mut [f32],
    ) {
        let patch = &self.scene.mesh.patches[q as usize];
        let mut lux = std::mem::take(&mut scratch.near);
        lux.clear();
        lux.resize(out.len(), 0.0);
        self.lights.direct(
            (at, patch.normal, q),
            lights::Rays::OneDrawn,
            rng,
            scratch,
            &mut lux,
            None,
        );
        self.reflected.gather(
            self.scene,
            (at, patch.normal, q),
            (NEAR_GATHER_RAYS, gather::Strata::own(rng)),
            rng,
            (None, None),
            &mut lux,
        );
        let rho = self.scene.rho[q as usize];
        let (out, light) = (Rgb::column_mut(out), Rgb::column(&lux));
        if let Some(sky) = &self.scene.sky {
            let sun = sky.sun_lux(self.scene.bvh, (at, patch.normal, patch.source));
            out[0] = rho * (light[0] + Rgb::splat(sun));
        } else {
            for (k, col) in self.scene.groups.iter().enumerate() {
                let own = if self.lights.explicit(k) { 0.0 } else { 1.0 };
                out[k] = rho * light[k] + own * Rgb::column(&col.e)[q as usize];
            }
        }
        scratch.near = lux;
    }
}

/// Rays of the small gather at a point a gather ray landed on close by (3 % of the
/// Cornell box's gather rays). 2 instead of 4 built its 512² view 3 % faster with the
/// same error over six seeds (0.840 % against 0.838 % of the 262,144-spp reference) and
/// left the panel floor's three views unchanged (1.43 %, 0.80 %, 0.82 %); 9 gave no
/// better (0.873 % against 0.874 % for 4, before the blocks' shared grids).
const NEAR_GATHER_RAYS: usize = 2;

/// Samples per side of a pixel whose corners see different surfaces, as a multiple of
/// [`FinalSettings::samples_per_side`].
const EDGE_SAMPLES: usize = 2;

/// Most samples per side of a pixel.
const MAX_SAMPLES_PER_SIDE: usize = 16;

/// What a pixel's samples saw: the first sample's guide, and how many met an emitter.
#[derive(Default)]
struct Samples {
    guide: Guide,
    emitters: Coverage,
}

/// What a camera sample saw: its reflectance and its filter guide.
#[derive(Default)]
struct Seen {
    albedo: Rgb,

    guide: Guide,
}
