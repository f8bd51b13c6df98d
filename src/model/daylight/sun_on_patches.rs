//! The sun's light on every patch for one sun direction: its direct light by shadow rays
//! ([`crate::transport::sky_view::patch_sun_direct`]) and its interreflection, solved through
//! the transfer or, in columns mode, carried by fitted sky patches around it.

use glam::DVec3;

use crate::daylight::tregenza::Subdivision;
use crate::daylight::Site;
use crate::transport::sky_view;

/// The sun's light on every patch at a normal illuminance of 1 lx.
pub struct SunOnPatches {
    /// Direct illuminance, lux (n).
    pub direct: Vec<f32>,
    /// Illuminance of its interreflected light, lux (n × 3): the patches' first
    /// reflection `ρS` of the direct light `S` solved through the transfer,
    /// `F (I − ρF)⁻¹ ρS`. None in columns mode, which keeps no operator to solve with:
    /// there the sun's interreflection is spread over its nearest sky patches (whose
    /// visibility may differ from the sun's).
    pub interreflected: Option<Vec<f32>>,
    /// Columns mode: the sun's interreflection as luminances (cd/m² per lux of normal
    /// illuminance) of the sky patches around it, (patch, luminance), fitted so that
    /// their direct light on the patches matches the sun's, flux-weighted
    /// ([`fit_sun_spread`]): where the sun is hidden from every patch but its neighbouring
    /// sky is not (a facade in front of a window), they carry nothing.
    pub spread: Vec<(usize, f64)>,
}

/// The unit vector of sky position (`altitude`, `azimuth`), radians, in the sky's own frame
/// (x east, y north, z up).
pub(crate) fn sky_direction(altitude: f64, azimuth: f64) -> DVec3 {
    DVec3::new(
        altitude.cos() * azimuth.sin(),
        altitude.cos() * azimuth.cos(),
        altitude.sin(),
    )
}

/// The sky patches of `sub` (not the ground) by closeness to sky position (`altitude`,
/// `azimuth`), radians: (cosine of the angle to the patch centre, patch), nearest first.
pub(crate) fn nearest_sky_patches(
    sub: &Subdivision,
    altitude: f64,
    azimuth: f64,
) -> Vec<(f64, usize)> {
    let to = sky_direction(altitude, azimuth);
    let mut near: Vec<(f64, usize)> = sub.patches[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (a, z) = p.centre();
            (sky_direction(a, z).dot(to), i + 1)
        })
        .collect();
    near.sort_by(|a, b| b.0.total_cmp(&a.0));
    near
}

/// Sky patches around the sun that [`fit_sun_spread`] may use.
const SUN_FIT_PATCHES: usize = 9;

/// Non-negative luminances `c_k` of the [`SUN_FIT_PATCHES`] sky patches nearest to the sun
/// (unit scene direction `d`) whose direct light `Σ_k c_k D_k` best matches the sun's
/// direct light `sun` (at 1 lx normal illuminance) on the patches, in the least squares
/// of the reflected flux (weights area × ρ; coordinate descent on the normal equations),
/// then scaled so that the flux they reflect first equals the sun's.
pub(super) fn fit_sun_spread(
    t: &crate::transport::transfer::Transfer,
    site: &Site,
    d: DVec3,
    sun: &[f32],
) -> Vec<(usize, f64)> {
    let Some(s) = t.sky.as_ref() else {
        return vec![];
    };
    let sub = sky_view::subdivision();
    let (alt, az) = site.sky_position(d);
    let near = nearest_sky_patches(&sub, alt.to_radians(), az.to_radians());
    let ks: Vec<usize> = near.iter().take(SUN_FIT_PATCHES).map(|x| x.1).collect();
    let m = ks.len();
    let mut g = vec![0f64; m * m];
    let mut r = vec![0f64; m];
    // Reflected-flux weight and sky-patch row of every patch.
    let weight = |i: usize| t.area[i] as f64 * t.rho[i].luminance() as f64;
    let rows = s.direct.chunks_exact(s.k);
    for (i, (row, &si)) in rows.clone().zip(sun).enumerate() {
        let w = weight(i);
        if w <= 0.0 {
            continue;
        }
        for a in 0..m {
            let da = row[ks[a]] as f64;
            if da == 0.0 {
                continue;
            }
            r[a] += w * da * si as f64;
            for b in 0..m {
                g[a * m + b] += w * da * row[ks[b]] as f64;
            }
        }
    }
    let mut c = vec![0f64; m];
    for _ in 0..500 {
        for a in 0..m {
            let gaa = g[a * m + a];
            if gaa <= 0.0 {
                continue;
            }
            let gc: f64 = (0..m).map(|b| g[a * m + b] * c[b]).sum();
            c[a] = (c[a] + (r[a] - gc) / gaa).max(0.0);
        }
    }
    // The fit matches the pattern; the reflected flux it carries is made exact.
    let (mut want, mut got) = (0f64, 0f64);
    for (i, (row, &si)) in rows.zip(sun).enumerate() {
        let w = weight(i);
        want += w * si as f64;
        got += w * ks
            .iter()
            .zip(&c)
            .map(|(&k, &ck)| ck * row[k] as f64)
            .sum::<f64>();
    }
    let scale = if got > 0.0 { want / got } else { 0.0 };
    ks.into_iter()
        .zip(c)
        .filter(|(_, c)| *c > 0.0)
        .map(|(k, c)| (k, c * scale))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sky_directions_are_east_north_up() {
        let half_pi = std::f64::consts::FRAC_PI_2;
        assert!((sky_direction(0.0, 0.0) - DVec3::Y).length() < 1e-15);
        assert!((sky_direction(0.0, half_pi) - DVec3::X).length() < 1e-15);
        assert!((sky_direction(half_pi, 1.0) - DVec3::Z).length() < 1e-15);
        let d = sky_direction(0.3, 4.0);
        assert!((d.length() - 1.0).abs() < 1e-15);
        assert!((d.z - 0.3f64.sin()).abs() < 1e-15);
    }

    #[test]
    fn nearest_sky_patches_start_with_the_patch_around_the_position() {
        let sub = sky_view::subdivision();
        for k in [1, 17, 60, 100, 130, 145] {
            let (alt, az) = sub.patches[k].centre();
            let (alt, az) = (alt - 0.01, az + 0.01);
            let near = nearest_sky_patches(&sub, alt, az);
            assert_eq!(near.len(), sub.patches.len() - 1);
            assert_eq!(near[0].1, k);
            assert_eq!(sub.patch_of(alt, az), k);
            assert!(near.windows(2).all(|w| w[0].0 >= w[1].0));
            assert!(near.iter().all(|&(_, k)| k >= 1), "never the ground");
        }
    }
}
