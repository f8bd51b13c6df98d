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
//!   luminaires' and the sun's highlights, and reflection rays that read the solution,
//!   weighed against light samples of the emitters ([`glossy`]).
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
mod glossy;
mod lights;
mod openings;
mod point;
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
use crate::geometry::patch_locator::{max_grid_corners, PatchLocator, PatchRay};
use crate::model::{Cancel, QueryError};
use crate::sampling::{shuffle, Rng};
use crate::scene::{LightGroup, Material, Triangle};
use crate::transport::transfer::GroupColumns;

use filter::Guide;
use point::ShadingPoint;

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
    /// Per group RGB: one sample's direct, indirect and expected light.
    light: LightBuffers,
    /// Per group RGB: the emission the camera sees, summed over a pixel's samples.
    emitted: Vec<f32>,
    /// The order in which a pixel's samples take the cells of its grid.
    cells: Vec<usize>,
}

/// The storage of one sample's [`LightParts`].
#[derive(Default)]
struct LightBuffers {
    direct: Vec<f32>,
    indirect: Vec<f32>,
    expected: Vec<f32>,
}

impl LightBuffers {
    /// Its parts, each `len` zeros.
    fn zeroed(&mut self, len: usize) -> LightParts<'_> {
        for v in [&mut self.direct, &mut self.indirect, &mut self.expected] {
            v.clear();
            v.resize(len, 0.0);
        }
        LightParts {
            direct: &mut self.direct,
            indirect: &mut self.indirect,
            expected: &mut self.expected,
        }
    }
}

/// Per group RGB radiance (cd/m²) in the three parts that the image keeps apart until
/// the filter: a camera sample's, or a pixel's sums of them.
struct LightParts<'a> {
    /// What needs no filtering: the direct light, highlights, a near mirror's reflections.
    direct: &'a mut [f32],
    /// The gathered indirect light (with a wide glossy lobe's), filtered later.
    indirect: &'a mut [f32],
    /// The indirect light the solved radiosity gives (no noise): the filter smooths
    /// `indirect` less this.
    expected: &'a mut [f32],
}

/// The rays one camera sample traces.
#[derive(Debug, Clone, Copy)]
struct RayBudget {
    /// Cosine-weighted gather rays (a whole grid of them, [`gather::ray_grid`]).
    gather_rays: usize,
    /// The cells of the gather's grid of directions that this sample takes.
    strata: gather::Strata,
    /// Rays drawn from a glossy lobe (a whole square grid of them).
    specular_rays: usize,
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
    /// The means of its samples' light.
    light: LightParts<'a>,
    /// Per group RGB radiance of the emitters seen, cd/m².
    emitted: &'a mut [f32],
    /// Mean reflectance of the pixel's samples.
    albedo: &'a mut Rgb,
}

/// The image's accumulators while it is built, per pixel: `[pixel][group][rgb]` for the
/// light, one value per pixel for the rest.
struct ImageSums {
    direct: Vec<f32>,
    indirect: Vec<f32>,
    expected: Vec<f32>,
    emitted: Vec<f32>,
    albedo: Vec<Rgb>,
    guides: Vec<Guide>,
    coverage: Vec<Coverage>,
}

/// One row of an [`ImageSums`].
struct RowSums<'a> {
    light: LightParts<'a>,
    emitted: &'a mut [f32],
    albedo: &'a mut [Rgb],
    guides: &'a mut [Guide],
    coverage: &'a mut [Coverage],
}

impl ImageSums {
    fn new(layout: filter::Layout) -> ImageSums {
        let px = layout.width * layout.height;
        let values = px * 3 * layout.groups;
        ImageSums {
            direct: vec![0f32; values],
            indirect: vec![0f32; values],
            expected: vec![0f32; values],
            emitted: vec![0f32; values],
            albedo: vec![Rgb::ZERO; px],
            guides: vec![Guide::default(); px],
            coverage: vec![Coverage::None; px],
        }
    }

    /// Its rows, top to bottom, to trace in parallel (none without groups).
    fn rows(&mut self, layout: filter::Layout) -> Vec<RowSums<'_>> {
        let (w, row) = (layout.width, (3 * layout.groups * layout.width).max(1));
        let mut direct = self.direct.chunks_mut(row);
        let mut indirect = self.indirect.chunks_mut(row);
        let mut expected = self.expected.chunks_mut(row);
        let mut emitted = self.emitted.chunks_mut(row);
        let mut albedo = self.albedo.chunks_mut(w);
        let mut guides = self.guides.chunks_mut(w);
        let mut coverage = self.coverage.chunks_mut(w);
        let mut rows = Vec::with_capacity(layout.height);
        while let (Some(d), Some(i), Some(x), Some(e), Some(a), Some(g), Some(c)) = (
            direct.next(),
            indirect.next(),
            expected.next(),
            emitted.next(),
            albedo.next(),
            guides.next(),
            coverage.next(),
        ) {
            rows.push(RowSums {
                light: LightParts {
                    direct: d,
                    indirect: i,
                    expected: x,
                },
                emitted: e,
                albedo: a,
                guides: g,
                coverage: c,
            });
        }
        rows
    }
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
    let tracer = Tracer::new(scene, cam, settings);
    let layout = filter::Layout {
        width: cam.width as usize,
        height: cam.height as usize,
        groups: tracer.groups,
    };
    let mut sums = ImageSums::new(layout);
    // What the rays through the pixels' corners see: a pixel whose four corners see
    // different surfaces gets more samples.
    let corners = CornerGuides::trace(&tracer, layout);
    sums.rows(layout)
        .into_par_iter()
        .enumerate()
        .for_each(|(y, row)| {
            if cancel.is_cancelled() {
                return;
            }
            tracer.row(y, &corners, row);
        });
    cancel.check()?;
    let footprint = 2.0 * ((cam.fov_deg as f64).to_radians() * 0.5).tan() / layout.height as f64;
    let image = tracer.finish(sums, layout, footprint as f32);
    Ok(GroupImages::from_parts(
        cam.width,
        cam.height,
        tracer.groups,
        image,
    ))
}

/// The filter guides of the camera rays through the pixels' corners.
struct CornerGuides {
    /// Corners per row: the image's width + 1.
    width: usize,
    guides: Vec<Guide>,
}

impl CornerGuides {
    fn trace(tracer: &Tracer<'_>, layout: filter::Layout) -> CornerGuides {
        let (w, h) = (layout.width, layout.height);
        let guides = (0..(w + 1) * (h + 1))
            .into_par_iter()
            .with_min_len(256)
            .map(|i| tracer.guide_at((i % (w + 1)) as f64, (i / (w + 1)) as f64))
            .collect();
        CornerGuides {
            width: w + 1,
            guides,
        }
    }

    /// Whether pixel (x, y)'s four corners see different surfaces: an edge or a
    /// silhouette crosses it.
    fn split(&self, x: usize, y: usize) -> bool {
        let w = self.width;
        let c = [
            &self.guides[y * w + x],
            &self.guides[y * w + x + 1],
            &self.guides[(y + 1) * w + x],
            &self.guides[(y + 1) * w + x + 1],
        ];
        c[1..].iter().any(|q| !q.alike(c[0]))
    }
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a FinalScene<'a>, cam: &Camera, settings: &FinalSettings) -> Tracer<'a> {
        let g = if scene.sky.is_some() {
            1
        } else {
            scene.groups.len()
        };
        let lights = lights::GroupLights::new(scene);
        let reflected = gather::Reflected::new(scene, &lights);
        Tracer {
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
        }
    }
}

impl Tracer<'_> {
    /// Traces row `y` of the image into `row`.
    fn row(&self, y: usize, corners: &CornerGuides, row: RowSums<'_>) {
        let g = self.groups;
        let mut buffers = Buffers::default();
        let RowSums {
            light,
            emitted,
            albedo,
            guides,
            coverage,
        } = row;
        for x in 0..guides.len() {
            let px = 3 * g * x..3 * g * (x + 1);
            let sums = PixelSums {
                light: LightParts {
                    direct: &mut light.direct[px.clone()],
                    indirect: &mut light.indirect[px.clone()],
                    expected: &mut light.expected[px.clone()],
                },
                emitted: &mut emitted[px],
                albedo: &mut albedo[x],
            };
            let seen = self.pixel(x, y, corners.split(x, y), sums, &mut buffers);
            (guides[x], coverage[x]) = (seen.guide, seen.emitters);
        }
    }

    /// The image from its accumulators: the emitters' rims measured, the indirect light
    /// filtered (less what the solution expects), and the parts added up.
    fn finish(&self, sums: ImageSums, layout: filter::Layout, footprint: f32) -> Vec<f32> {
        let ImageSums {
            mut direct,
            mut indirect,
            expected,
            mut emitted,
            albedo,
            guides,
            coverage,
        } = sums;
        self.emitter_rims(&coverage, (layout.width, layout.height), &mut emitted);
        // The filter smooths what the gather found beyond what the solution expects.
        indirect
            .par_iter_mut()
            .zip(&expected)
            .for_each(|(i, x)| *i -= x);
        let passes = self.settings.filter_passes;
        filter::denoise(&mut indirect, &albedo, &guides, layout, footprint, passes);
        direct
            .par_iter_mut()
            .enumerate()
            .for_each(|(j, d)| *d += indirect[j] + emitted[j] + expected[j]);
        direct
    }

    /// Traces pixel (x, y) into `sums`. A pixel that is `split` between surfaces (its
    /// corners see different ones: an edge or a silhouette) gets [`EDGE_SAMPLES`]× the
    /// samples per side, sharing the same gather rays among them: there its few samples
    /// would decide the split, and that error is larger than the gather's. The corners
    /// decide, not the pixel's own random samples: a pixel traced again when its samples
    /// disagreed, and kept when they agreed, leans towards the surface that covers more
    /// of it.
    fn pixel(
        &self,
        x: usize,
        y: usize,
        split: bool,
        mut sums: PixelSums<'_>,
        buffers: &mut Buffers,
    ) -> PixelSeen {
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
        self.samples(x, y, k, &mut rng, &mut sums, buffers)
    }

    /// The filter guide of what the camera ray through image point (x, y) (in pixels)
    /// sees.
    fn guide_at(&self, x: f64, y: f64) -> Guide {
        let d = self.rays.dir_at(x, y);
        let o = self.rays.origin();
        let Some((t, p)) = self.surface_seen(d, self.primary(d)) else {
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
    ) -> PixelSeen {
        let samples = (k * k) as f32;
        let gather_rays = (self.settings.gather_rays as usize).div_ceil(k * k);
        // At least a 2 × 2 grid per sample: a split pixel's many samples each see their
        // own point, and a single ray per sample left edges speckled.
        let specular = self.settings.specular_rays as usize;
        let specular_rays = if specular == 0 {
            0
        } else {
            specular.div_ceil(k * k).max(4)
        };
        let mut out = PixelSeen::default();
        let Buffers {
            scratch,
            light,
            emitted,
            cells,
        } = buffers;
        emitted.clear();
        emitted.resize(3 * self.groups, 0.0);
        let mut emitter_samples = 0;
        let block = self.block_grid(x, y);
        // The cells go to the samples in a random order: a sample's own rays then cover
        // the whole hemisphere on average, so the light of a sample that sees another
        // surface than its pixel's others is unbiased too.
        cells.clear();
        cells.extend(0..k * k);
        shuffle(cells, rng);
        for (s, &cell) in cells.iter().enumerate() {
            let budget = RayBudget {
                gather_rays,
                strata: block.strata(cell, k),
                specular_rays,
            };
            let (sx, sy) = (rng.stratum(s % k, k), rng.stratum(s / k, k));
            let d = self.rays.dir_at(x as f64 + sx, y as f64 + sy);
            let mut sample = light.zeroed(3 * self.groups);
            let hit = self.primary(d);
            emitter_samples += usize::from(self.emitted_along(d, hit, emitted));
            let seen = self.sample(d, hit, rng, scratch, &mut sample, budget);
            if s == 0 {
                out.guide = seen.guide;
            }
            sums.add(&seen, &sample, samples);
        }
        out.emitters = self.emitter_coverage((x, y), emitter_samples, k, emitted, sums.emitted);
        out
    }

    /// The shared grid of gather directions of pixel (x, y)'s block of `BLOCK × BLOCK`
    /// pixels, and the pixel's sub-cell in each of its cells.
    fn block_grid(&self, x: usize, y: usize) -> BlockGrid {
        let mut block_rng = Rng::new(
            (y / BLOCK) * self.rays.width().div_ceil(BLOCK) + x / BLOCK,
            BLOCK_SALT ^ self.settings.seed as usize,
        );
        let shift = (block_rng.next_f64(), block_rng.next_f64());
        let mut subs: [usize; BLOCK * BLOCK] = std::array::from_fn(|i| i);
        shuffle(&mut subs, &mut block_rng);
        let sub = subs[(y % BLOCK) * BLOCK + x % BLOCK];
        BlockGrid {
            shift,
            sub: (sub % BLOCK, sub / BLOCK),
        }
    }

    /// How pixel (x, y) saw emitters, `hits` of its `k × k` samples having met one, and
    /// its emitted light into `out`: the samples' mean `emitted` where all met one, or
    /// measured on a fine grid where an emitter's edge crosses the pixel.
    fn emitter_coverage(
        &self,
        (x, y): (usize, usize),
        hits: usize,
        k: usize,
        emitted: &[f32],
        out: &mut [f32],
    ) -> Coverage {
        let samples = (k * k) as f32;
        if hits == 0 {
            Coverage::None
        } else if hits < k * k {
            // An emitter's edge in the pixel: measure its coverage on a fine grid instead.
            self.emitted_in_pixel(x, y, out);
            Coverage::Measured
        } else {
            for (a, v) in out.iter_mut().zip(emitted.iter()) {
                *a += v / samples;
            }
            Coverage::All
        }
    }

    /// The nearest patch whose front the camera ray along `d` meets.
    fn primary(&self, d: DVec3) -> Option<(f32, u32)> {
        let o = self.rays.origin();
        self.scene
            .patches
            .nearest(self.scene.bvh, PatchRay::camera(o, d))
    }

    /// The patch the camera ray along `d`, which meets `hit`, shows: none where a
    /// luminaire's opening is in front of it.
    fn surface_seen(&self, d: DVec3, hit: Option<(f32, u32)>) -> Option<(f32, u32)> {
        let o = self.rays.origin();
        let t_scene = hit.map_or(f64::INFINITY, |(t, _)| t as f64);
        if self.openings.blocks(o, d, t_scene) {
            return None;
        }
        hit
    }

    /// One camera ray along `d`, which meets `hit`: adds to `light` the light its surface
    /// reflects per group, direct (exact) and indirect (gathered) radiance, cd/m², with
    /// the rays of `budget`. Emission is [`Self::emitted_along`].
    fn sample(
        &self,
        d: DVec3,
        hit: Option<(f32, u32)>,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        light: &mut LightParts<'_>,
        budget: RayBudget,
    ) -> SampleSeen {
        let Some((t, p)) = self.surface_seen(d, hit) else {
            return SampleSeen::default();
        };
        let at = ShadingPoint::on(self.scene.mesh, self.rays.origin() + d * t as f64, p);
        let lobe = self.lobe(at, d, budget.specular_rays);
        // Direct light (lux) and gathered indirect light (lux), then × ρ/π.
        let mut e_direct = std::mem::take(&mut scratch.lux);
        e_direct.clear();
        e_direct.resize(3 * self.groups, 0.0);
        self.direct_light(at, lobe.as_ref(), rng, scratch, &mut e_direct, light.direct);
        let reach = self.indirect_light(at, budget, rng, scratch, light);
        // Under a specular lobe, the diffuse part keeps the share the lobe leaves it.
        let rho = match &lobe {
            Some(l) => self.scene.rho[p as usize] * l.diffuse_share(),
            None => self.scene.rho[p as usize],
        };
        reflect_diffuse(rho * std::f32::consts::FRAC_1_PI, &e_direct, light);
        scratch.lux = e_direct;
        // The glossy lobe's sampled light: its reflections and its share of the emitting
        // surfaces. A wide lobe's goes through the filter with the gathered light (its
        // draws scatter over the room), demodulated by the lobe's Fresnel reflectance
        // beside ρ; a near mirror's draws all but agree, and stay sharp.
        let mut albedo = rho;
        if let Some(lobe) = &lobe {
            if lobe.filtered() {
                albedo += lobe.reflectance();
            }
            self.glossy_light(at, lobe, budget.specular_rays, rng, scratch, light);
        }
        SampleSeen {
            albedo,
            guide: Guide {
                position: at.position.as_vec3().to_array(),
                normal: at.normal.as_vec3().to_array(),
                surface: self.scene.mesh.patches[p as usize].surface,
                depth: t,
                reach,
            },
        }
    }

    /// A glossy surface's specular lobe at `at` towards the camera (looking along `d`),
    /// when the settings trace specular rays.
    fn lobe(&self, at: ShadingPoint, d: DVec3, specular_rays: usize) -> Option<specular::Lobe> {
        let patch = &self.scene.mesh.patches[at.patch as usize];
        self.scene
            .triangles
            .get(patch.source as usize)
            .and_then(|t| self.scene.materials.get(t.material as usize)?.gloss)
            .filter(|_| specular_rays > 0)
            .and_then(|g| specular::Lobe::new(&g, at.normal, d))
    }

    /// Adds to `e_direct` (per group RGB, lux) the direct light at `at`: the groups'
    /// lights, or under a sky the sun. A specular `lobe`'s highlights of the point
    /// luminaires and the sun (exact, no noise) go straight to `highlights`, as
    /// radiance; its sampled light is [`Self::glossy_light`].
    fn direct_light(
        &self,
        at: ShadingPoint,
        lobe: Option<&specular::Lobe>,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        e_direct: &mut [f32],
        highlights: &mut [f32],
    ) {
        self.lights.direct(
            at,
            lights::Rays::Stratified(self.settings.emitter_rays),
            rng,
            scratch,
            e_direct,
            lobe.map(|l| (l, &mut *highlights)),
        );
        if let Some(sky) = &self.scene.sky {
            let sun = sky.sun_lux(self.scene.bvh, at.shadow_origin(self.scene.mesh));
            e_direct[..3].iter_mut().for_each(|v| *v += sun);
            if let (Some(lobe), Some(s), true) = (lobe, &sky.sun, sun > 0.0) {
                let spread = 0.25 * crate::daylight::sky_luminance::SUN_DIAMETER_DEG.to_radians();
                Rgb::column_mut(highlights)[0] += sun * lobe.brdf(s.direction, spread);
            }
        }
    }

    /// Adds to `light` the indirect irradiance (lux) at `at` from the gather rays of
    /// `budget` (and under a sky, its aimed sky rays), and the irradiance the solution
    /// expects there. Returns the harmonic mean distance of the gather's hits (infinite
    /// without gather rays).
    fn indirect_light(
        &self,
        at: ShadingPoint,
        budget: RayBudget,
        rng: &mut Rng,
        scratch: &mut lights::Scratch,
        light: &mut LightParts<'_>,
    ) -> f32 {
        let gather_rays = budget.gather_rays;
        let mut reach = f32::INFINITY;
        let aim = self.scene.sky.as_ref().and_then(|s| s.aim(at.patch));
        if gather_rays > 0 {
            // The direct light's buffers are free until the specular lobe's light below.
            let mut near = |at: DVec3, q: u32, rng: &mut Rng, v: &mut [f32]| {
                self.reflected_at(at, q, rng, scratch, v)
            };
            reach = self.reflected.gather(
                self.scene,
                at,
                (gather_rays, budget.strata),
                rng,
                (Some(&mut near), aim.as_ref()),
                light.indirect,
            );
        }
        if let (Some(sky), Some(aim)) = (&self.scene.sky, &aim) {
            let cosine = if gather_rays > 0 {
                gather::ray_count(gather_rays)
            } else {
                0
            };
            let origin = at.shadow_origin(self.scene.mesh);
            sky.aimed(self.scene.bvh, aim, origin, cosine, rng, light.indirect);
        }
        if gather_rays > 0 {
            self.reflected
                .expected(self.scene, at.position, at.patch, light.expected);
        }
        reach
    }

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
        let point = ShadingPoint::on(self.scene.mesh, at, q);
        let mut lux = std::mem::take(&mut scratch.near);
        lux.clear();
        lux.resize(out.len(), 0.0);
        self.lights
            .direct(point, lights::Rays::OneDrawn, rng, scratch, &mut lux, None);
        self.reflected.gather(
            self.scene,
            point,
            (NEAR_GATHER_RAYS, gather::Strata::own(rng)),
            rng,
            (None, None),
            &mut lux,
        );
        let rho = self.scene.rho[q as usize];
        let (out, light) = (Rgb::column_mut(out), Rgb::column(&lux));
        if let Some(sky) = &self.scene.sky {
            let sun = sky.sun_lux(self.scene.bvh, point.shadow_origin(self.scene.mesh));
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

/// Per group: `light.direct += reflect · e_direct` (lux to radiance), and the indirect
/// and expected irradiance `×= reflect`.
fn reflect_diffuse(reflect: Rgb, e_direct: &[f32], light: &mut LightParts<'_>) {
    let direct = Rgb::column_mut(light.direct);
    let indirect = Rgb::column_mut(light.indirect);
    let expected = Rgb::column_mut(light.expected);
    for (k, &e) in Rgb::column(e_direct).iter().enumerate() {
        direct[k] += reflect * e;
        indirect[k] *= reflect;
        expected[k] *= reflect;
    }
}

impl PixelSums<'_> {
    /// Adds one of its `samples` samples: what it `seen` and its `light`.
    fn add(&mut self, seen: &SampleSeen, light: &LightParts<'_>, samples: f32) {
        *self.albedo += seen.albedo / samples;
        for (a, v) in self.light.direct.iter_mut().zip(light.direct.iter()) {
            *a += v / samples;
        }
        for (a, v) in self.light.indirect.iter_mut().zip(light.indirect.iter()) {
            *a += v / samples;
        }
        for (a, v) in self.light.expected.iter_mut().zip(light.expected.iter()) {
            *a += v / samples;
        }
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

/// One grid of gather directions for a block of `BLOCK × BLOCK` pixels: each pixel takes
/// one sub-cell (the same in every cell of its own grid, drawn without replacement within
/// the block, so every pixel's rays are unbiased), and each of its samples one cell of
/// each `k × k` block of that grid.
struct BlockGrid {
    /// The offset within each cell, shared by the block ([`gather::Strata::shift`]).
    shift: (f64, f64),
    /// This pixel's sub-cell (radial, azimuthal).
    sub: (usize, usize),
}

impl BlockGrid {
    /// The cells a gather of a pixel's `k × k` samples takes, for the sample given `cell`.
    fn strata(&self, cell: usize, k: usize) -> gather::Strata {
        gather::Strata {
            shift: self.shift,
            interleave: k * BLOCK,
            cell: (
                (cell % k) * BLOCK + self.sub.0,
                (cell / k) * BLOCK + self.sub.1,
            ),
        }
    }
}

/// What a pixel's samples saw: the first sample's guide, and how they met emitters.
#[derive(Default)]
struct PixelSeen {
    guide: Guide,
    emitters: Coverage,
}

/// What a camera sample saw: its reflectance and its filter guide.
#[derive(Default)]
struct SampleSeen {
    albedo: Rgb,
    guide: Guide,
}
