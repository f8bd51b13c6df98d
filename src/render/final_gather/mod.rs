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
//!
//! Here the recipe: [`build`] traces the corner guides, then the rows (in parallel), and
//! finishes the image; `pixel` traces a pixel's samples, `sample` one camera sample
//! (direct, indirect and glossy light).

mod emitted;
mod filter;
mod gather;
mod glossy;
mod lights;
mod openings;
mod pixel;
mod point;
mod sample;
mod settings;
mod sky;
mod specular;

pub use settings::{FinalSettings, GATHER_REFERENCE_PIXELS};
pub use sky::FinalSky;

use emitted::Coverage;
use pixel::{Buffers, PixelSums};
use sample::LightParts;

use rayon::prelude::*;

use super::{Camera, GroupImages, Shading};
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::geometry::patch_locator::{max_grid_corners, PatchLocator};
use crate::model::{Cancel, QueryError};
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
    /// How the emission of `groups` lights a point.
    pub emitters: EmitterLight,
}

/// How the emitting surfaces of a [`FinalScene`]'s groups light a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EmitterLight {
    /// Each group's emitting triangles, exactly ([`lights`]): a group's emission lies on
    /// its own patches (`Patch::group`), uniform over each input triangle (a material's).
    PerGroup,
    /// Every emitting patch's triangle, exactly, whatever its group: one lighting state
    /// made of the groups' emission at their weights, so still uniform per triangle.
    AnyPatch,
    /// Every emitting patch's own facets, exactly: a per-patch emission vector may light
    /// part of a triangle. More than [`lights::MAX_EMITTER_TRIANGLES`] such facets leave
    /// the emission to the gather, which then reads `B` with the emission in it.
    Patches,
}

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
}
