//! One camera sample of a `final` image: the surface its ray shows, and the light that
//! surface reflects towards the camera, direct (exact), indirect (gathered) and glossy,
//! kept in the parts the filter treats apart.

use glam::DVec3;

use super::filter::Guide;
use super::point::ShadingPoint;
use super::{gather, lights, specular, Tracer};
use crate::color::Rgb;
use crate::geometry::patch_locator::PatchRay;
use crate::sampling::Rng;

/// The storage of one sample's [`LightParts`].
#[derive(Default)]
pub(super) struct LightBuffers {
    direct: Vec<f32>,
    indirect: Vec<f32>,
    expected: Vec<f32>,
}

impl LightBuffers {
    /// Its parts, each `len` zeros.
    pub(super) fn zeroed(&mut self, len: usize) -> LightParts<'_> {
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
pub(super) struct LightParts<'a> {
    /// What needs no filtering: the direct light, highlights, a near mirror's reflections.
    pub(super) direct: &'a mut [f32],
    /// The gathered indirect light (with a wide glossy lobe's), filtered later.
    pub(super) indirect: &'a mut [f32],
    /// The indirect light the solved radiosity gives (no noise): the filter smooths
    /// `indirect` less this.
    pub(super) expected: &'a mut [f32],
}

/// The rays one camera sample traces.
#[derive(Debug, Clone, Copy)]
pub(super) struct RayBudget {
    /// Cosine-weighted gather rays (a whole grid of them, [`gather::ray_grid`]).
    pub(super) gather_rays: usize,
    /// The cells of the gather's grid of directions that this sample takes.
    pub(super) strata: gather::Strata,
    /// Rays drawn from a glossy lobe (a whole square grid of them).
    pub(super) specular_rays: usize,
}

impl Tracer<'_> {
    /// The filter guide of what the camera ray through image point (x, y) (in pixels)
    /// sees.
    pub(super) fn guide_at(&self, x: f64, y: f64) -> Guide {
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

    /// The nearest patch whose front the camera ray along `d` meets.
    pub(super) fn primary(&self, d: DVec3) -> Option<(f32, u32)> {
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
    pub(super) fn sample(
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

/// Rays of the small gather at a point a gather ray landed on close by (3 % of the
/// Cornell box's gather rays). 2 instead of 4 built its 512² view 3 % faster with the
/// same error over six seeds (0.840 % against 0.838 % of the 262,144-spp reference) and
/// left the panel floor's three views unchanged (1.43 %, 0.80 %, 0.82 %); 9 gave no
/// better (0.873 % against 0.874 % for 4, before the blocks' shared grids).
const NEAR_GATHER_RAYS: usize = 2;

/// What a camera sample saw: its reflectance and its filter guide.
#[derive(Default)]
pub(super) struct SampleSeen {
    pub(super) albedo: Rgb,
    pub(super) guide: Guide,
}
