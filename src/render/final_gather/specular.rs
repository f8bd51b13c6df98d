//! Glossy highlights: the specular lobe of a glTF material ([`Gloss`]) at a camera
//! sample's point, on top of its diffuse light.
//!
//! The radiosity solution is diffuse, so the lobe shows at the camera's bounce only (the
//! light a glossy surface sends on into the room is its diffuse part, as baked). At a
//! glossy point the `final` image adds, per light group:
//!
//! - **highlights of the point luminaires and the sun**: the lobe's BRDF towards each one
//!   times the shadowed illuminance the direct light computed ([`super::lights`]). A
//!   luminaire's luminous opening (the sun's disc) widens the lobe by half the angle it
//!   subtends, `α' = √(α² + (r/2d)²)`, so a polished floor shows a panel's highlight as a
//!   spot of about the panel's size rather than a point (GGX keeps its integral, so the
//!   highlight's energy is unchanged);
//! - **reflections**: rays drawn from the lobe's distribution of visible normals (Heitz
//!   2018), each weighted by `F · G₂/G₁`, that read where they land the radiance the
//!   solution gives there, `B/π` (Gouraud-interpolated as the gather reads it), with the
//!   emitting surfaces' luminance `E/π` and, under a sky, the sky's luminance through the
//!   openings. The luminaires' openings are not in the scene's geometry: their light
//!   comes through the highlights above, so nothing is counted twice.
//!
//! The diffuse reflection under the lobe keeps `1 − ` the lobe's directional albedo
//! (albedo scaling, from a table of the lobe's albedo drawn once), so a glossy surface
//! reflects no more light than falls on it.
//!
//! Every term is linear in a group's light, so each group image stays linear. The
//! highlights are exact and stay out of the filter; the sampled light (reflections and
//! emitters) of a lobe of α ≥ [`FILTERED_ALPHA`] goes through it with the gathered light,
//! divided by the lobe's Fresnel reflectance beside the diffuse reflectance, because its
//! draws scatter over the room: with 16 rays per pixel a copper plinth (α 0.09) was
//! grainy, and filtered it matches 256 unfiltered rays. A narrower lobe's draws all but
//! agree, and its sharp reflection stays unfiltered. The lobe is glTF's: GGX normals,
//! Smith's height-correlated masking-shadowing, Schlick's Fresnel from `F0`.

use glam::DVec3;

use crate::color::Rgb;
use crate::scene::Gloss;

/// The specular lobe at one point seen from one direction.
pub(super) struct Lobe {
    f0: Rgb,
    f90: Rgb,
    alpha: f64,
    /// The local frame: tangent, bitangent, normal.
    frame: [DVec3; 3],
    /// Towards the viewer, in the local frame (z along the normal, > 0).
    v: DVec3,
}

impl Lobe {
    /// The lobe of `gloss` at a point of normal `n` seen along `d` (from the camera);
    /// None when the point is seen edge-on or from behind.
    pub(super) fn new(gloss: &Gloss, n: DVec3, d: DVec3) -> Option<Lobe> {
        let (t, b) = crate::geometry::frame(n);
        let v = -d.normalize();
        let local = DVec3::new(v.dot(t), v.dot(b), v.dot(n));
        (local.z > 1e-6).then(|| Lobe {
            f0: gloss.f0,
            f90: gloss.f90,
            alpha: (gloss.alpha as f64).clamp(Gloss::MIN_ALPHA as f64, 1.0),
            frame: [t, b, n],
            v: local,
        })
    }

    /// Whether the lobe is wide enough (α ≥ [`FILTERED_ALPHA`]) that its sampled light
    /// goes through the image's filter.
    pub(super) fn filtered(&self) -> bool {
        self.alpha >= FILTERED_ALPHA
    }

    /// The lobe's Fresnel reflectance towards the viewer, `F(cos θᵥ)`: what the filter
    /// divides its light by, beside the diffuse reflectance, so that the light it
    /// smooths is the room's and not the surface's.
    pub(super) fn reflectance(&self) -> Rgb {
        self.fresnel(self.v.z)
    }

    fn to_local(&self, w: DVec3) -> DVec3 {
        DVec3::new(
            w.dot(self.frame[0]),
            w.dot(self.frame[1]),
            w.dot(self.frame[2]),
        )
    }

    /// Schlick's Fresnel at `cos` between the viewer and the microfacet normal,
    /// `F0 + (F90 − F0)(1 − cos)⁵`.
    fn fresnel(&self, cos: f64) -> Rgb {
        let k = (1.0 - cos.clamp(0.0, 1.0)).powi(5) as f32;
        self.f0 + (self.f90 - self.f0) * k
    }

    /// The BRDF (1/sr) from direction `l` (towards the light, world) to the viewer, with
    /// α widened by `spread` (radians: half the angle a source subtends, halved again
    /// for the half vector): `F D G₂ / (4 cos θᵥ cos θₗ)`.
    pub(super) fn brdf(&self, l: DVec3, spread: f64) -> Rgb {
        let l = self.to_local(l.normalize());
        if l.z <= 0.0 {
            return Rgb::ZERO;
        }
        let alpha = (self.alpha * self.alpha + spread * spread).sqrt().min(1.0);
        let a2 = alpha * alpha;
        let h = (self.v + l).normalize();
        let d = ggx(h.z, a2);
        let g2 = 1.0 / (1.0 + lambda(self.v.z, a2) + lambda(l.z, a2));
        let f = self.fresnel(self.v.dot(h));
        f * (d * g2 / (4.0 * self.v.z * l.z)) as f32
    }

    /// The density (1/sr) with which [`Lobe::sample`] draws direction `l` (world):
    /// `G₁(v) D(h) / (4 cos θᵥ)`.
    pub(super) fn pdf(&self, l: DVec3) -> f64 {
        let l = self.to_local(l.normalize());
        if l.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let h = (self.v + l).normalize();
        ggx(h.z, a2) / ((1.0 + lambda(self.v.z, a2)) * 4.0 * self.v.z)
    }

    /// A direction drawn from the lobe (world, towards where the light comes from) for
    /// uniform `u` in [0, 1)², and its weight `BRDF · cos θₗ / pdf = F · G₂/G₁`; None
    /// when the reflected direction falls below the surface (it carries no light).
    pub(super) fn sample(&self, u: (f64, f64)) -> Option<(DVec3, Rgb)> {
        let drawn = draw(self.v, self.alpha, u)?;
        let [t, b, n] = self.frame;
        let l = drawn.direction;
        let world = (t * l.x + b * l.y + n * l.z).normalize();
        Some((world, self.fresnel(drawn.v_dot_h) * drawn.weight as f32))
    }

    /// The lobe's directional albedo towards the viewer: the share of light from all
    /// directions that it reflects, `∫ BRDF cos θₗ dω` per channel. What the diffuse
    /// reflection keeps is the rest ([`Lobe::diffuse_share`]).
    pub(super) fn albedo(&self) -> Rgb {
        let [e, ep] = albedo_terms(self.v.z, self.alpha);
        // Schlick's F = F0 (1 − (1 − v·h)⁵) + F90 (1 − v·h)⁵: the albedo is linear in both.
        self.f0 * (e - ep) as f32 + self.f90 * ep as f32
    }

    /// The share of the diffuse reflection under the lobe: `1 − albedo`, glTF's layering
    /// of a specular lobe over a diffuse base by albedo scaling, so the surface reflects
    /// no more light than falls on it.
    pub(super) fn diffuse_share(&self) -> Rgb {
        let a = self.albedo();
        Rgb(a.0.map(|x| (1.0 - x).clamp(0.0, 1.0)))
    }
}

/// A direction drawn from the lobe, in its local frame ([`draw`]).
struct Drawn {
    /// The reflected direction (local, z the normal).
    direction: DVec3,
    /// `v·h`, between the viewer and the drawn microfacet normal.
    v_dot_h: f64,
    /// `G₂/G₁`.
    weight: f64,
}

/// Draws a direction from GGX's distribution of normals visible from `v` (local, z the
/// normal) of width `a` (Heitz 2018, "Sampling the GGX Distribution of Visible
/// Normals"), for uniform `u`; None below the surface.
fn draw(v: DVec3, a: f64, u: (f64, f64)) -> Option<Drawn> {
    let vh = DVec3::new(a * v.x, a * v.y, v.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        DVec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.0.sqrt();
    let phi = std::f64::consts::TAU * u.1;
    let (p1, mut p2) = (r * phi.cos(), r * phi.sin());
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let h = DVec3::new(a * nh.x, a * nh.y, nh.z.max(1e-9)).normalize();
    let vdoth = v.dot(h);
    let l = 2.0 * vdoth * h - v;
    if l.z <= 0.0 || vdoth <= 0.0 {
        return None;
    }
    let a2 = a * a;
    let (lv, ll) = (lambda(v.z, a2), lambda(l.z, a2));
    Some(Drawn {
        direction: l,
        v_dot_h: vdoth,
        weight: (1.0 + lv) / (1.0 + lv + ll),
    })
}

/// Nodes per axis of the albedo table, over cos θᵥ and α in [0, 1].
const ALBEDO_NODES: usize = 33;

/// Draws per node of the albedo table (a stratified 32 × 32 grid).
const ALBEDO_SIDE: usize = 32;

/// The lobe's albedo at `cos` θᵥ and width `alpha` for F0 = 1 and its Schlick part
/// `∫ (1 − v·h)⁵ …` (Kulla and Conty's split), bilinear in a table drawn once per
/// process (33² nodes, 1,024 draws each).
fn albedo_terms(cos: f64, alpha: f64) -> [f64; 2] {
    static TABLE: std::sync::OnceLock<Vec<[f64; 2]>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let last = (ALBEDO_NODES - 1) as f64;
        (0..ALBEDO_NODES * ALBEDO_NODES)
            .map(|k| {
                let mu = ((k / ALBEDO_NODES) as f64 / last).max(1e-3);
                let a = ((k % ALBEDO_NODES) as f64 / last).max(Gloss::MIN_ALPHA as f64);
                let v = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let mut sum = [0.0; 2];
                let m = ALBEDO_SIDE;
                for i in 0..m * m {
                    let u = ((i / m) as f64 + 0.5) / m as f64;
                    let w = ((i % m) as f64 + 0.5) / m as f64;
                    if let Some(d) = draw(v, a, (u, w)) {
                        sum[0] += d.weight;
                        sum[1] += d.weight * (1.0 - d.v_dot_h).powi(5);
                    }
                }
                sum.map(|x| x / (m * m) as f64)
            })
            .collect()
    });
    let last = (ALBEDO_NODES - 1) as f64;
    let (x, y) = (cos.clamp(0.0, 1.0) * last, alpha.clamp(0.0, 1.0) * last);
    let (i, j) = (
        (x as usize).min(ALBEDO_NODES - 2),
        (y as usize).min(ALBEDO_NODES - 2),
    );
    let (fx, fy) = (x - i as f64, y - j as f64);
    let at = |i: usize, j: usize| table[i * ALBEDO_NODES + j];
    let mut out = [0.0; 2];
    for (c, o) in out.iter_mut().enumerate() {
        *o = (1.0 - fx) * ((1.0 - fy) * at(i, j)[c] + fy * at(i, j + 1)[c])
            + fx * ((1.0 - fy) * at(i + 1, j)[c] + fy * at(i + 1, j + 1)[c]);
    }
    out
}

/// The narrowest lobe (GGX α, perceptual roughness 0.1) whose sampled light is filtered:
/// a narrower one reflects a sharp image that the filter would blur, and its draws all
/// but agree.
pub(super) const FILTERED_ALPHA: f64 = 0.01;

/// GGX's distribution of normals at `cos` from the macro normal, for α² = `a2`.
fn ggx(cos: f64, a2: f64) -> f64 {
    if cos <= 0.0 {
        return 0.0;
    }
    let k = cos * cos * (a2 - 1.0) + 1.0;
    a2 / (std::f64::consts::PI * k * k)
}

/// Smith's Λ for GGX at `cos` from the normal, for α² = `a2`.
fn lambda(cos: f64, a2: f64) -> f64 {
    let c2 = (cos * cos).max(1e-12);
    0.5 * ((1.0 + a2 * (1.0 - c2) / c2).sqrt() - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn lobe(alpha: f32, f0: f32, view_deg: f64) -> Lobe {
        let g = Gloss {
            f0: Rgb::splat(f0),
            f90: Rgb::ONE,
            alpha,
        };
        let t = view_deg.to_radians();
        let d = -DVec3::new(t.sin(), 0.0, t.cos());
        Lobe::new(&g, DVec3::Z, d).unwrap()
    }

    /// Calls `f(ω, dω)` at the midpoints of an `n × n` grid of polar angle and azimuth
    /// over the upper hemisphere (z up), for integrals over solid angle.
    fn hemisphere(n: usize, mut f: impl FnMut(DVec3, f64)) {
        let (half, tau) = (std::f64::consts::FRAC_PI_2, std::f64::consts::TAU);
        for i in 0..n {
            let theta = (i as f64 + 0.5) / n as f64 * half;
            for j in 0..n {
                let phi = (j as f64 + 0.5) / n as f64 * tau;
                let w = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                f(w, theta.sin() * (half / n as f64) * (tau / n as f64));
            }
        }
    }

    /// The sampled directions' mean weight is the lobe's directional albedo: the
    /// integral of BRDF × cos over the hemisphere, computed independently here on a fine
    /// midpoint grid of the BRDF itself. This holds the sampler's density to the BRDF.
    #[test]
    fn sampled_weights_integrate_the_brdf() {
        for (alpha, view) in [(0.09, 0.0), (0.25, 40.0), (0.5, 70.0), (1.0, 20.0)] {
            let l = lobe(alpha, 0.04, view);
            let mut grid = 0.0;
            hemisphere(800, |w, dw| grid += l.brdf(w, 0.0)[0] as f64 * w.z * dw);
            let mut rng = Rng::new(1, 2);
            let n = 400_000;
            let sampled: f64 = (0..n)
                .filter_map(|_| l.sample((rng.next_f64(), rng.next_f64())))
                .map(|(_, w)| w[0] as f64)
                .sum::<f64>()
                / n as f64;
            assert!(
                (sampled - grid).abs() < 0.01 * grid + 2e-4,
                "α {alpha}, view {view}°: sampled {sampled}, grid {grid}"
            );
            // The albedo table, interpolated, holds the same integral.
            let table = l.albedo()[0] as f64;
            assert!(
                (table - grid).abs() < 0.02 * grid + 5e-4,
                "α {alpha}, view {view}°: table {table}, grid {grid}"
            );
        }
    }

    /// The density integrates (on a midpoint grid) to the share of draws that stay above
    /// the surface.
    #[test]
    fn the_density_is_the_samplers() {
        for (alpha, view) in [(0.09, 10.0), (0.3, 60.0), (0.8, 30.0)] {
            let l = lobe(alpha, 0.04, view);
            let mut integral = 0.0;
            hemisphere(800, |w, dw| integral += l.pdf(w) * dw);
            let mut rng = Rng::new(7, 8);
            let n = 200_000;
            let above = (0..n)
                .filter(|_| l.sample((rng.next_f64(), rng.next_f64())).is_some())
                .count() as f64
                / n as f64;
            assert!(
                (integral - above).abs() < 0.01,
                "α {alpha}, view {view}°: ∫pdf {integral}, share drawn above {above}"
            );
        }
    }

    /// The directions drawn fall as the density says: counts in 12 × 12 bins of (polar
    /// angle, azimuth) against the density integrated over each bin (a χ²-style check,
    /// every bin within 5 standard deviations plus 0.1 % of the draws).
    #[test]
    fn drawn_directions_follow_the_density() {
        for (alpha, view) in [(0.09, 30.0), (0.4, 60.0), (1.0, 0.0)] {
            let l = lobe(alpha, 0.04, view);
            let (bins, sub) = (12usize, 24usize);
            let half = std::f64::consts::FRAC_PI_2;
            let tau = std::f64::consts::TAU;
            let bin = |w: DVec3| {
                let theta = w.z.clamp(-1.0, 1.0).acos();
                let phi = w.y.atan2(w.x).rem_euclid(tau);
                let i = ((theta / half * bins as f64) as usize).min(bins - 1);
                let j = ((phi / tau * bins as f64) as usize).min(bins - 1);
                i * bins + j
            };
            let mut expected = vec![0f64; bins * bins];
            hemisphere(bins * sub, |w, dw| expected[bin(w)] += l.pdf(w) * dw);
            let n = 400_000usize;
            let mut counts = vec![0f64; bins * bins];
            let mut rng = Rng::new(9, 10);
            for _ in 0..n {
                if let Some((w, _)) = l.sample((rng.next_f64(), rng.next_f64())) {
                    counts[bin(w)] += 1.0;
                }
            }
            for (b, (&c, &e)) in counts.iter().zip(&expected).enumerate() {
                let e = e * n as f64;
                assert!(
                    (c - e).abs() <= 5.0 * e.sqrt() + 1e-3 * n as f64,
                    "α {alpha}, view {view}°, bin {b}: {c} drawn, {e:.1} expected"
                );
            }
        }
    }

    /// With `KHR_materials_specular`'s F90 below 1, the albedo (from the table, linear
    /// in F0 and F90) still matches the grid integral of the BRDF.
    #[test]
    fn the_albedo_follows_f0_and_f90() {
        let g = Gloss {
            f0: Rgb::new(0.02, 0.3, 0.9),
            f90: Rgb::new(0.5, 0.5, 1.0),
            alpha: 0.2,
        };
        let t = 60f64.to_radians();
        let l = Lobe::new(&g, DVec3::Z, -DVec3::new(t.sin(), 0.0, t.cos())).unwrap();
        let mut grid = [0.0f64; 3];
        hemisphere(600, |w, dw| {
            let f = l.brdf(w, 0.0);
            for (g, f) in grid.iter_mut().zip(f.iter()) {
                *g += *f as f64 * w.z * dw;
            }
        });
        let table = l.albedo();
        for c in 0..3 {
            assert!(
                (table[c] as f64 - grid[c]).abs() < 0.02 * grid[c] + 5e-4,
                "channel {c}: table {table:?}, grid {grid:?}"
            );
        }
    }

    /// A narrow lobe with F0 = 1 is a mirror: every drawn direction is the view's
    /// reflection, at full weight.
    #[test]
    fn a_narrow_white_lobe_is_a_mirror() {
        let l = lobe(Gloss::MIN_ALPHA, 1.0, 35.0);
        let t = 35f64.to_radians();
        let mirror = DVec3::new(-t.sin(), 0.0, t.cos());
        let mut rng = Rng::new(3, 4);
        // GGX's tail: a share α² / (α² + tan² θ) of the microfacet normals tilt past θ,
        // 1.3 % past 0.5° (1° off the mirror direction) at α = 0.001.
        let n = 10_000;
        let mut near = 0;
        for _ in 0..n {
            let (d, w) = l.sample((rng.next_f64(), rng.next_f64())).unwrap();
            if d.dot(mirror) > 1f64.to_radians().cos() {
                near += 1;
                assert!((w[0] - 1.0).abs() < 1e-3, "{w:?}");
            }
        }
        assert!(near >= n * 98 / 100 && near < n, "{near} of {n} within 1°");
    }

    /// The BRDF is reciprocal, and Fresnel reaches 1 at grazing angles.
    #[test]
    fn the_brdf_is_reciprocal() {
        let mut rng = Rng::new(5, 6);
        for _ in 0..200 {
            let mut dir = || {
                let (a, b) = (rng.next_f64(), rng.next_f64());
                let r = (1.0 - a * a).sqrt();
                let phi = std::f64::consts::TAU * b;
                DVec3::new(r * phi.cos(), r * phi.sin(), a.max(0.05))
            };
            let (v, l) = (dir(), dir());
            let g = Gloss {
                f0: Rgb::new(0.9, 0.6, 0.04),
                f90: Rgb::ONE,
                alpha: 0.3,
            };
            let forward = Lobe::new(&g, DVec3::Z, -v).unwrap().brdf(l, 0.02);
            let back = Lobe::new(&g, DVec3::Z, -l).unwrap().brdf(v, 0.02);
            for c in 0..3 {
                assert!(
                    (forward[c] - back[c]).abs() <= 1e-5 * forward[c].max(1e-3),
                    "{forward:?} vs {back:?}"
                );
            }
        }
        let l = lobe(0.3, 0.04, 0.0);
        assert!((l.fresnel(0.0)[0] - 1.0).abs() < 1e-6);
        assert!((l.fresnel(1.0)[0] - 0.04).abs() < 1e-6);
    }
}
