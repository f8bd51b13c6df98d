//! The sun's light on every patch for one sun direction: its direct light by shadow rays
//! ([`crate::transport::sky_view::patch_sun_direct`]) and its interreflection, solved through
//! the transfer or, in columns mode, carried by fitted sky patches around it.

use glam::DVec3;

use crate::color::luminance;
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
    let (alt, az) = (alt.to_radians(), az.to_radians());
    let dir = |a: f64, z: f64| DVec3::new(a.cos() * z.sin(), a.cos() * z.cos(), a.sin());
    let sd = dir(alt, az);
    let mut near: Vec<(f64, usize)> = sub.patches[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (a, z) = p.centre();
            (-dir(a, z).dot(sd), i + 1)
        })
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let ks: Vec<usize> = near.iter().take(SUN_FIT_PATCHES).map(|x| x.1).collect();
    let m = ks.len();
    let mut g = vec![0f64; m * m];
    let mut r = vec![0f64; m];
    // Reflected-flux weight and sky-patch row of every patch.
    let weight = |i: usize| t.area[i] as f64 * luminance(t.rho[i]) as f64;
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
