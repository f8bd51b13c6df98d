//! The glow: how bright each patch is expected to be, which the refinement uses to
//! weigh a link's error by what it carries.

use rayon::prelude::*;

use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::transport::formfactor::patch_geometry;

/// Most emitting scene triangles whose first reflection enters the glow estimate
/// ([`emitter_bounce`]): the brightest by flux.
pub const GLOW_EMITTERS: usize = 64;

/// Visibility rays per patch and emitting triangle in [`emitter_bounce`].
const GLOW_RAYS: u32 = 4;

/// The first reflection of the emitting surfaces' light, `ρ̄_i Σ_t M_t F(x_i → t) v_it`
/// (lm/m², channel mean, all groups at intensity 1), estimated at each patch's centroid
/// with the exact point-to-triangle factor and [`GLOW_RAYS`] visibility rays, from the
/// [`GLOW_EMITTERS`] brightest emitting scene triangles. Only the refinement uses it (as
/// part of the glow, where luminaires' direct light already is), so an estimate does.
pub fn emitter_bounce(
    scene: &crate::scene::Scene,
    mesh: &Mesh,
    bvh: &Bvh,
    rho: &[Rgb],
    emission: &[f64],
) -> Vec<f64> {
    // Emitting scene triangles with their exitance (the mean over their patches).
    let mut tri_m: std::collections::BTreeMap<u32, (f64, f64)> = Default::default();
    for (p, &e) in mesh.patches.iter().zip(emission) {
        if e > 0.0 {
            let t = tri_m.entry(p.source).or_default();
            t.0 += e * p.area;
            t.1 += p.area;
        }
    }
    let mut emitters: Vec<(u32, f64, f64)> = tri_m
        .into_iter()
        .filter(|(_, (flux, area))| *flux > 0.0 && *area > 0.0)
        .map(|(t, (flux, area))| (t, flux, flux / area))
        .collect();
    emitters.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    emitters.truncate(GLOW_EMITTERS);
    if emitters.is_empty() {
        return vec![0.0; mesh.len()];
    }
    let geo = patch_geometry(mesh);
    (0..mesh.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let g = &geo[i];
            let r = &rho[i];
            let rho_mean = (r[0] + r[1] + r[2]) as f64 / 3.0;
            if rho_mean <= 0.0 {
                return 0.0;
            }
            let mut rng = crate::sampling::Rng::new(i, usize::MAX - 1);
            let mut h = 0.0;
            for &(t, _, m) in &emitters {
                if t == g.source {
                    continue;
                }
                let c = scene.triangles[t as usize].p;
                let front = (c[1] - c[0]).cross(c[2] - c[0]);
                if front.dot(g.centroid - c[0]) <= 0.0 {
                    continue;
                }
                let f = crate::transport::formfactor::point_to_polygon(g.centroid, g.n, &c);
                if f <= 0.0 {
                    continue;
                }
                let x = glam::Vec3A::from((g.centroid + g.n * (1e-6 * g.size)).as_vec3());
                let free = (0..GLOW_RAYS)
                    .filter(|_| {
                        let y =
                            crate::sampling::sample_triangle(&c, rng.next_f64(), rng.next_f64());
                        !bvh.occluded(x, glam::Vec3A::from(y.as_vec3()), [g.source, t])
                    })
                    .count();
                h += m * f * free as f64 / GLOW_RAYS as f64;
            }
            rho_mean * h
        })
        .collect()
}

/// Each patch's source term over the scene's mean radiosity, estimated as the sources'
/// flux over the area, divided by (1 − ρ̄) for the interreflections (ρ̄ the area mean of
/// the reflectance, at most 0.9).
pub(super) fn glow(mesh: &Mesh, rho: &[Rgb], sources: &[f64]) -> Vec<f32> {
    let (mut flux, mut area, mut rho_a) = (0.0, 0.0, 0.0);
    for ((p, s), r) in mesh.patches.iter().zip(sources).zip(rho) {
        flux += p.area * s;
        area += p.area;
        rho_a += p.area * (r[0] + r[1] + r[2]) as f64 / 3.0;
    }
    if flux <= 0.0 || area <= 0.0 {
        return vec![0.0; mesh.len()];
    }
    let mean = flux / area / (1.0 - (rho_a / area).min(0.9));
    sources.iter().map(|&s| (s / mean) as f32).collect()
}
