//! The daylight of a `final` image: the sun traced exactly, the sky read by gather rays that
//! leave the scene, and rays aimed at the sky patches that a point's patch sees, combined
//! with the cosine-weighted gather rays by multiple importance sampling.

use glam::{DVec3, Vec3A};

use super::point::ShadowOrigin;
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::lifted;
use crate::sampling::Rng;

/// The daylight of one sky state, for a `final` image of it: the sun traced exactly, the
/// sky read by gather rays that leave the scene (through openings and glazing), and the
/// daylight's solved radiosity read where gather rays land.
pub struct FinalSky<'a> {
    /// Per patch the reflected daylight, lm/m² (n × 3): the sky's and the sun's light,
    /// direct and interreflected, times the reflectance.
    pub reflected: &'a [f32],
    /// The sun, when it is up.
    pub sun: Option<crate::render::daylight::SunView>,
    /// Luminance (cd/m²) towards a unit scene direction: the sky's, the ground's below
    /// the horizon (the sun's disc apart).
    pub luminance: &'a (dyn Fn(DVec3) -> f64 + Sync),
    pub glazing: &'a crate::geometry::glazing::Glazing,
    /// A length beyond the scene, metres.
    pub reach: f64,
    /// Where gather rays toward the sky are aimed: per patch, the direct light of every
    /// sky patch at unit luminance (lux per cd/m², n × K, the bake's daylight
    /// coefficients), the sky patches' luminances (cd/m², K), their subdivision and the
    /// site that orients it.
    pub coefficients: &'a [f32],
    pub patch_luminance: &'a [f64],
    pub subdivision: &'a crate::daylight::tregenza::Subdivision,
    pub site: &'a crate::daylight::Site,
}

/// Gather rays per camera sample aimed at the sky patches that the sample's patch sees
/// ([`SkyAim`]), besides the cosine-weighted ones.
const SKY_RAYS: usize = 16;

/// The sky rays of one camera sample: drawn by the sky patches' share of its patch's
/// direct daylight, and combined with the cosine-weighted gather rays that leave the scene
/// by the balance heuristic (multiple importance sampling), so light through a small
/// opening is found by many rays, not by the few cosine rays that happen to pass it.
pub(super) struct SkyAim {
    /// Cumulative shares of the sky patches (K), the last 1.
    cdf: Vec<f64>,
    /// Per sky patch its share (0 … 1).
    share: Vec<f64>,
    /// Sky rays drawn.
    rays: usize,
}

impl<'a> FinalSky<'a> {
    /// The sky rays for a point of patch `p`: None when the patch sees no sky.
    pub(super) fn aim(&self, p: u32) -> Option<SkyAim> {
        let k = self.patch_luminance.len();
        let row = self
            .coefficients
            .get(p as usize * k..(p as usize + 1) * k)?;
        let share: Vec<f64> = row
            .iter()
            .zip(self.patch_luminance)
            .map(|(&c, &l)| c as f64 * l)
            .collect();
        let total: f64 = share.iter().sum();
        if total <= 0.0 || !total.is_finite() {
            return None;
        }
        let share: Vec<f64> = share.iter().map(|v| v / total).collect();
        let mut acc = 0.0;
        let cdf = share
            .iter()
            .map(|v| {
                acc += v;
                acc
            })
            .collect();
        Some(SkyAim {
            cdf,
            share,
            rays: SKY_RAYS,
        })
    }

    /// The density (per sr, over all the aim's rays: `rays × pdf`) with which `aim` draws
    /// direction `d`.
    pub(super) fn aimed_density(&self, aim: &SkyAim, d: DVec3) -> f64 {
        let (alt, az) = self.site.sky_position(d);
        let k = self.subdivision.patch_of(alt.to_radians(), az.to_radians());
        let omega = self.subdivision.patches[k].solid_angle;
        aim.rays as f64 * aim.share[k] / omega
    }

    /// Adds to `out` (group 0's RGB, lux as the gather counts it) the aimed sky rays from
    /// `at`, weighted against `cosine_rays` cosine-weighted rays.
    pub(super) fn aimed(
        &self,
        bvh: &Bvh,
        aim: &SkyAim,
        at: ShadowOrigin,
        cosine_rays: usize,
        rng: &mut Rng,
        out: &mut [f32],
    ) {
        let (n, skip) = (at.normal, at.skip_triangle);
        let o = lifted(at.position, n);
        let mut sum = 0f64;
        for _ in 0..aim.rays {
            let u = rng.next_f64();
            let k = aim.cdf.partition_point(|&c| c < u).min(aim.cdf.len() - 1);
            let patch = &self.subdivision.patches[k];
            let (s0, s1) = (patch.altitude.0.sin(), patch.altitude.1.sin());
            let alt = (s0 + (s1 - s0) * rng.next_f64()).clamp(-1.0, 1.0).asin();
            let az = patch.azimuth + patch.width * (rng.next_f64() - 0.5);
            let d = self.site.direction(alt.to_degrees(), az.to_degrees());
            let cos = n.dot(d);
            if cos <= 0.0 {
                continue;
            }
            let far = o + d * self.reach;
            if bvh.occluded(
                Vec3A::from(o.as_vec3()),
                Vec3A::from(far.as_vec3()),
                [skip, u32::MAX],
            ) {
                continue;
            }
            let l = self.outside(o, d, false) as f64;
            let pc = cosine_rays as f64 * cos / std::f64::consts::PI;
            sum += l * cos / (pc + self.aimed_density(aim, d));
        }
        Rgb::column_mut(out)[0] += Rgb::splat(sum as f32);
    }
}

impl FinalSky<'_> {
    /// The sun's illuminance (lux) at `at`, with shadow rays through `bvh` and the
    /// glazing's transmittance.
    pub(super) fn sun_lux(&self, bvh: &Bvh, at: ShadowOrigin) -> f32 {
        let Some(s) = self.sun else { return 0.0 };
        let (n, skip) = (at.normal, at.skip_triangle);
        let cos = n.dot(s.direction);
        if cos <= 0.0 {
            return 0.0;
        }
        let o = lifted(at.position, n);
        let far = o + s.direction * self.reach;
        if bvh.occluded(
            Vec3A::from(o.as_vec3()),
            Vec3A::from(far.as_vec3()),
            [skip, u32::MAX],
        ) {
            return 0.0;
        }
        (s.normal_illuminance * cos * self.glazing.transmittance(o, far)) as f32
    }

    /// The luminance seen out of the scene from `o` along `d` (cd/m²): the sky's and the
    /// sun's disc, dimmed by the glazing on the way.
    pub(super) fn outside(&self, o: DVec3, d: DVec3, disc: bool) -> f32 {
        let mut l = (self.luminance)(d);
        if let (true, Some(s)) = (disc, self.sun) {
            let radius = (crate::daylight::sky_luminance::SUN_DIAMETER_DEG / 2.0).to_radians();
            if d.dot(s.direction) >= radius.cos() {
                l += s.normal_illuminance / crate::daylight::sky_luminance::Sun::solid_angle();
            }
        }
        (l * self.glazing.transmittance(o, o + d * self.reach)) as f32
    }
}
