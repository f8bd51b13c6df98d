//! Daylight queries, and the point-gather cache every point query shares.
//!
//! A sky relights the scene as a weighted sum of the transfer's sky responses
//! ([`crate::transport::transfer::SkyColumns`]): each patch's illuminance is
//! `H = Σ_k L_k (D_k + I_k)` over the sky patches' mean luminances `L_k`, plus the sun:
//! its direct light with shadow rays at every patch, and its interreflected light through
//! the responses of the sky patches nearest to it. Radiosity is `B = ρ H`.
//!
//! A point's illuminance is exact where accuracy needs it: the direct sky is integrated
//! against the continuous sky luminance over the rays that leave the scene from the point
//! ([`SkyView`]), the sun gets one shadow ray, and the interreflected light is gathered
//! from `B` with the point's cached gather weights.
//!
//! The cache: a set of points (with normals) is gathered once ([`PointGather`]: the
//! point-to-patch weights and the sky view) and kept, keyed by the points' bytes, in a
//! least-recently-used list bounded by [`GatherCache::for_scene`]'s size. Asking the same points again
//! under another sky or light state is a sparse dot product per point.

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex, OnceLock};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::grid::{self, GridStats};
use super::metrics;
pub use super::metrics::DaylightFactors;
use super::query::{GridAnswer, IlluminanceQuery};
use super::report::SurfaceIlluminance;
use super::sky_state::{SkyState, SunPosition};
use super::sun::{fit_sun_spread, SunOnPatches};
use super::{Cancel, Model, QueryError};
use crate::color::{luminance64, Rgb};
use crate::daylight::sky_luminance::Sky;
use crate::daylight::Site;
use crate::transport::probe::gather_weights;
use crate::transport::sky_view::{self, Reach, SkyView};
use crate::transport::transfer::{weighted_sum, SkyColumns};

/// Fewest and most bytes the point-gather cache of one scene holds; in between, room for
/// [`GATHER_CACHE_POINTS`] points of the scene (see [`GatherCache::for_scene`]).
pub const GATHER_CACHE_MIN_BYTES: u64 = 2 << 20;
pub const GATHER_CACHE_MAX_BYTES: u64 = 64 << 20;
/// Points the gather cache is sized for: a 1,000-point grid and a few point sets.
pub const GATHER_CACHE_POINTS: u64 = 1100;
/// Bytes of a point's sky view, at most about (the refined cells of a busy view), and of
/// its daylight coefficients (6 × 146 floats).
const VIEW_BYTES: u64 = (16 << 10) + 24 * 146;

/// What one point sees: its gather weights over the patches and, for a scene with a site,
/// its view of the sky and (made on first use) its daylight coefficients.
#[derive(Debug, Default)]
pub struct PointGather {
    /// (patch, weight): `E = Σ w_j B_j`.
    pub weights: Vec<(u32, f32)>,
    pub view: Option<SkyView>,
    /// Per sky patch k, RGB: the gathered reflection of the sky patch's direct light
    /// `Σ_j w_j ρ_j D_jk` (first 3K values), then of its interreflected light
    /// `Σ_j w_j ρ_j I_kj` (next 3K), lux per cd/m². A new sky is then 6K products per
    /// point.
    coefficients: OnceLock<Vec<f32>>,
    /// The view's [`SkyView::shape_sums`], made on first use.
    shape_sums: OnceLock<[f64; 3]>,
}

impl PointGather {
    /// Bytes held, counting the daylight coefficients of `k` sky patches when it has a
    /// sky view.
    fn bytes(&self, k: usize) -> usize {
        8 * self.weights.capacity() + self.view.as_ref().map_or(0, |v| v.bytes() + 24 * k) + 96
    }

    /// The daylight coefficients (see [`PointGather::coefficients`]).
    fn coefficients(&self, s: &SkyColumns, rho: &[Rgb]) -> &[f32] {
        self.coefficients.get_or_init(|| {
            let k = s.k;
            let mut out = vec![0f32; 6 * k];
            let wr: Vec<(usize, [f32; 3])> = self
                .weights
                .iter()
                .map(|&(j, w)| (j as usize, rho[j as usize].map(|r| r * w)))
                .collect();
            // Direct part: rows of D are contiguous per patch.
            let mut d = vec![0f64; 3 * k];
            for &(j, r) in &wr {
                let row = &s.direct[j * k..(j + 1) * k];
                for (dk, &v) in d.chunks_exact_mut(3).zip(row) {
                    for c in 0..3 {
                        dk[c] += (r[c] * v) as f64;
                    }
                }
            }
            // Interreflected part: columns of I are contiguous per sky patch.
            for (kk, ind) in s.indirect.iter().enumerate() {
                let mut i = [0f64; 3];
                for &(j, r) in &wr {
                    let v = &ind[3 * j..3 * j + 3];
                    for c in 0..3 {
                        i[c] += (r[c] * v[c]) as f64;
                    }
                }
                for c in 0..3 {
                    out[3 * (k + kk) + c] = i[c] as f32;
                }
            }
            for (o, v) in out[..3 * k].iter_mut().zip(&d) {
                *o = *v as f32;
            }
            out
        })
    }

    /// The direct light of the sky and the ground seen from the point, lux: for the
    /// uniform and overcast skies from the view's cached sums, else ray by ray against the
    /// continuous sky.
    fn direct_sky(&self, sky: &SkyState, site: &Site) -> f64 {
        let Some(v) = &self.view else {
            return 0.0;
        };
        let sums = || *self.shape_sums.get_or_init(|| v.shape_sums());
        let pi = std::f64::consts::PI;
        match sky.sky {
            Sky::Uniform { luminance } => {
                let s = sums();
                pi * (luminance * s[0] + sky.ground_luminance * s[2])
            }
            Sky::CieOvercast { zenith } => {
                let s = sums();
                pi * (zenith * s[1] + sky.ground_luminance * s[2])
            }
            _ => v.illuminance(|d| sky.luminance(site, d), sky.ground_luminance),
        }
    }

    /// The reflected daylight at the point, RGB lux: sky patch luminances `l` (cd/m², 0 the
    /// ground) through both parts of the coefficients, and the sun's spread `sun` (patch,
    /// cd/m²) through the interreflected part.
    fn reflected(&self, s: &SkyColumns, rho: &[Rgb], l: &[f64], sun: &[(usize, f64)]) -> [f64; 3] {
        let c = self.coefficients(s, rho);
        let k = s.k;
        let mut e = [0f64; 3];
        for (kk, &lk) in l.iter().enumerate() {
            if lk == 0.0 {
                continue;
            }
            for ch in 0..3 {
                e[ch] += lk * (c[3 * kk + ch] as f64 + c[3 * (k + kk) + ch] as f64);
            }
        }
        for &(kk, lum) in sun {
            for ch in 0..3 {
                e[ch] += lum * c[3 * (k + kk) + ch] as f64;
            }
        }
        e
    }

    /// Σ w_j B_j per channel.
    pub fn gather(&self, b: &[f32]) -> [f64; 3] {
        let mut e = [0.0; 3];
        for &(j, w) in &self.weights {
            let j = 3 * j as usize;
            for c in 0..3 {
                e[c] += w as f64 * b[j + c] as f64;
            }
        }
        e
    }
}

/// A cached point set: its key, its gathers and their bytes.
type Entry = (u64, Arc<Vec<PointGather>>, usize);

/// Sun directions whose direct light on every patch is kept ([`Model::sun_on_patches`]).
pub const SUN_CACHE_ENTRIES: usize = 4;

/// The gather cache and the importance its ray budgets follow; also the sun's direct light
/// on the patches for the last few sun directions.
#[derive(Default)]
pub struct GatherCache {
    importance: OnceLock<Vec<f32>>,
    entries: Mutex<VecDeque<Entry>>,
    limit: u64,
    /// (direction key, the sun on the patches at unit normal illuminance).
    suns: Mutex<VecDeque<(u64, Arc<SunOnPatches>)>>,
}

impl GatherCache {
    /// A cache for a scene of `patches` patches (with sky views when `sky`): room for
    /// [`GATHER_CACHE_POINTS`] points gathering from every patch, within
    /// [`GATHER_CACHE_MIN_BYTES`] … [`GATHER_CACHE_MAX_BYTES`].
    pub fn for_scene(patches: usize, sky: bool) -> GatherCache {
        let per_point = 8 * patches as u64 + if sky { VIEW_BYTES } else { 0 } + 64;
        GatherCache {
            limit: (GATHER_CACHE_POINTS * per_point)
                .clamp(GATHER_CACHE_MIN_BYTES, GATHER_CACHE_MAX_BYTES),
            ..Default::default()
        }
    }

    /// Bytes held at most.
    pub fn limit(&self) -> u64 {
        self.limit
    }
}

/// The sun's light on the patches for one sky (lux): direct (n), interreflected when
/// solved exactly (n × 3), else the sky patches it is spread over for its
/// interreflection, (patch, luminance cd/m²).
#[derive(Default)]
struct SunLight {
    direct: Option<Vec<f32>>,
    interreflected: Option<Vec<f32>>,
    spread: Vec<(usize, f64)>,
}

/// A sky's daylight on every patch: illuminance `h` (lux) and radiosity `b` (lm/m²),
/// n × 3 interleaved.
pub struct PatchDaylight {
    pub h: Vec<f32>,
    pub b: Vec<f32>,
}

/// One grid under a sky: illuminance statistics (lux) and, for the CIE overcast sky,
/// daylight factors.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct DaylightGrid {
    /// Illuminance statistics and values, lx.
    pub illuminance: GridAnswer,
    /// Null unless the sky is `cie_overcast`.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub daylight_factor: Option<DaylightFactors>,
}

/// One point under a sky.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct DaylightPoint {
    /// Luminous illuminance, lx (daylight plus any electric light asked for).
    pub lux: f64,
    /// Per channel, lx.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub rgb: [f64; 3],
    /// 100 · E_daylight / E_horizontal, percent, for the CIE overcast sky; else null.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub daylight_factor: Option<f64>,
}

/// The sky as it was resolved.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SkyInfo {
    /// `uniform`, `cie_overcast`, `cie_clear` or `perez`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// The sun's position (degrees), when given or derived from a time; null otherwise.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub sun: Option<SunPosition>,
    /// The sun's direct normal illuminance, lx (0 without a sun above the horizon).
    pub direct_normal_illuminance: f64,
    /// The sky's diffuse illuminance on an unobstructed horizontal plane, lx.
    pub diffuse_horizontal_illuminance: f64,
    /// Diffuse plus direct on an unobstructed horizontal plane, lx.
    pub global_horizontal_illuminance: f64,
    /// Luminance of the ground outside the model, cd/m².
    pub ground_luminance: f64,
}

/// Daylight answers, lux.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = DaylightResponse))]
pub struct DaylightAnswer {
    /// Always `"lx"`.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lx))]
    pub unit: &'static str,
    pub sky: SkyInfo,
    /// In request order.
    pub points: Vec<DaylightPoint>,
    /// By surface id.
    pub surfaces: BTreeMap<String, SurfaceIlluminance>,
    /// By grid id.
    pub grids: BTreeMap<String, DaylightGrid>,
}

/// The cache key of a point set.
fn key(points: &[(DVec3, DVec3)]) -> u64 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for (x, n) in points {
        for v in x.to_array().iter().chain(&n.to_array()) {
            h.update(&v.to_le_bytes());
        }
    }
    h.digest()
}

/// The entry of a least-recently-used list that `hit` finds, moved to the front.
fn touch<T>(list: &mut VecDeque<T>, hit: impl Fn(&T) -> bool) -> Option<&T> {
    let pos = list.iter().position(hit)?;
    let entry = list.remove(pos).expect("position is in range");
    list.push_front(entry);
    list.front()
}

impl Model {
    /// The scene's site, or why daylight cannot be asked of it.
    pub fn site(&self) -> Result<&Site, QueryError> {
        match (&self.baked.scene.site, &self.baked.transfer.sky) {
            (Some(s), Some(_)) => Ok(s),
            _ => Err(QueryError::Invalid(format!(
                "scene '{}' has no [site] in its scene.toml, so it has no daylight",
                self.baked.scene.id
            ))),
        }
    }

    /// The points of grid `gi` with the grid's normal.
    pub(super) fn grid_receivers(&self, gi: usize) -> Vec<(DVec3, DVec3)> {
        let grid = &self.grids[gi].grid;
        let n = DVec3::from_array(grid.normal);
        grid.points
            .iter()
            .map(|p| (DVec3::from_array(*p), n))
            .collect()
    }

    /// The sun's direct illuminance (lux) at point `x` (m) on a receiver facing `n`: the
    /// sun in unit scene direction `d` at normal illuminance `en`, with one shadow ray
    /// (through the glazing) out to `reach`.
    pub(super) fn sun_at(&self, x: DVec3, n: DVec3, (d, en): (DVec3, f64), reach: Reach) -> f64 {
        sky_view::point_sun_direct(&self.baked.bvh, &self.baked.glazing, x, n, d, en, reach)
    }

    pub(super) fn reach(&self) -> Reach {
        let (lo, hi) = self.baked.scene.bounds();
        Reach::new(lo, hi)
    }

    /// Per-patch importance for the gathers' ray budgets: every group's radiosity at unit
    /// weight and a uniform sky's, each scaled to a largest value of 1.
    fn importance(&self) -> &[f32] {
        self.gathers.importance.get_or_init(|| {
            let t = &self.baked.transfer;
            let mut out = vec![0f32; 3 * t.n];
            let mut add = |col: &[f32]| {
                let max = col.iter().fold(0f32, |m, &v| m.max(v));
                if max > 0.0 {
                    for (o, v) in out.iter_mut().zip(col) {
                        *o += v / max;
                    }
                }
            };
            for g in &t.groups {
                add(&g.b);
            }
            if let Some(s) = &t.sky {
                let l = vec![1.0; s.k];
                add(&self.sky_patches(&l, &SunLight::default(), false).b);
            }
            out
        })
    }

    /// The gathers of `points` (position m, unit normal), from the cache or traced (in
    /// parallel, stopping when `cancel` is raised).
    pub fn gathers(
        &self,
        points: &[(DVec3, DVec3)],
        cancel: &Cancel,
    ) -> Result<Arc<Vec<PointGather>>, QueryError> {
        let k = key(points);
        {
            let mut e = super::lock(&self.gathers.entries);
            if let Some((_, g, _)) = touch(&mut e, |(kk, _, _)| *kk == k) {
                return Ok(g.clone());
            }
        }
        let k_ = &self.baked;
        let importance = self.importance();
        let reach = self.reach();
        let with_view = k_.transfer.sky.is_some() && k_.scene.site.is_some();
        let list: Vec<PointGather> = points
            .par_iter()
            .map(|&(x, n)| {
                if cancel.is_cancelled() {
                    return PointGather::default();
                }
                let weights = gather_weights(&k_.mesh, &k_.bvh, importance, x, n)
                    .into_iter()
                    .map(|(j, w)| (j, w as f32))
                    .collect();
                let view = with_view.then(|| SkyView::trace(&k_.bvh, &k_.glazing, x, n, reach));
                PointGather {
                    weights,
                    view,
                    ..Default::default()
                }
            })
            .collect();
        cancel.check()?;
        let sky_k = k_.transfer.sky.as_ref().map_or(0, |s| s.k);
        let bytes: usize = list.iter().map(|g| g.bytes(sky_k)).sum();
        let list = Arc::new(list);
        let limit = self.gathers.limit as usize;
        if bytes <= limit {
            let mut e = super::lock(&self.gathers.entries);
            e.push_front((k, list.clone(), bytes));
            let mut total: usize = e.iter().map(|x| x.2).sum();
            while total > limit {
                match e.pop_back() {
                    Some(x) => total -= x.2,
                    None => break,
                }
            }
        }
        Ok(list)
    }

    /// Per-patch daylight for sky patch luminances `l` (cd/m², index 0 the ground) and the
    /// sun's light `sun` ([`SunLight`]).
    fn sky_patches(&self, l: &[f64], sun: &SunLight, with_direct_sun: bool) -> PatchDaylight {
        let t = &self.baked.transfer;
        let s = t.sky.as_ref().expect("callers check the site");
        let n = t.n;
        // Interreflected: the sky patches' luminances, plus the sun's share where its
        // interreflection is not solved exactly.
        let mut w: Vec<Rgb> = l.iter().map(|&x| [x as f32; 3]).collect();
        for &(k, lum) in &sun.spread {
            w[k] = w[k].map(|x| x + lum as f32);
        }
        let mut h = vec![0f32; 3 * n];
        weighted_sum(s.indirect.iter().map(|c| c.as_slice()), &w, &mut h);
        if let Some(ind) = &sun.interreflected {
            for (a, b) in h.iter_mut().zip(ind) {
                *a += b;
            }
        }
        let sun_direct = if with_direct_sun {
            sun.direct.as_deref()
        } else {
            None
        };
        // Direct: the sky patches, then the sun.
        for i in 0..n {
            let row = &s.direct[i * s.k..(i + 1) * s.k];
            let mut d: f64 = row.iter().zip(l).map(|(&a, &b)| a as f64 * b).sum();
            if let Some(sd) = sun_direct {
                d += sd[i] as f64;
            }
            for c in 0..3 {
                h[3 * i + c] += d as f32;
            }
        }
        let b = h
            .chunks_exact(3)
            .zip(&t.rho)
            .flat_map(|(hc, r)| [hc[0] * r[0], hc[1] * r[1], hc[2] * r[2]])
            .collect();
        PatchDaylight { h, b }
    }

    /// The sun's direct and interreflected light on every patch (at a normal illuminance
    /// of 1 lx) for the sun in unit scene direction `d`: shadow rays and one solve, kept
    /// for the last [`SUN_CACHE_ENTRIES`] directions.
    fn sun_on_patches(&self, d: DVec3) -> Arc<SunOnPatches> {
        let k = key(&[(d, DVec3::ZERO)]);
        let mut suns = super::lock(&self.gathers.suns);
        if let Some((_, v)) = touch(&mut suns, |(kk, _)| *kk == k) {
            return v.clone();
        }
        drop(suns);
        let direct = sky_view::patch_sun_direct(
            &self.baked.mesh,
            &self.baked.bvh,
            &self.baked.glazing,
            d,
            1.0,
            self.reach(),
        );
        let t = &self.baked.transfer;
        let interreflected = if t.factored.is_some() || t.hierarchy.is_some() {
            let first: Vec<f32> = direct
                .iter()
                .zip(&t.rho)
                .flat_map(|(&e, r)| [e * r[0], e * r[1], e * r[2]])
                .collect();
            t.solve(&first).map(|sol| sol.h)
        } else {
            None
        };
        let spread = match (&interreflected, self.site()) {
            (None, Ok(site)) => fit_sun_spread(t, site, d, &direct),
            _ => vec![],
        };
        let v = Arc::new(SunOnPatches {
            direct,
            interreflected,
            spread,
        });
        let mut suns = super::lock(&self.gathers.suns);
        suns.push_front((k, v.clone()));
        suns.truncate(SUN_CACHE_ENTRIES);
        v
    }

    /// The sun's light on the patches for a sky: its direct illuminance, and its
    /// interreflection solved exactly (factored and hierarchical modes) or else carried by
    /// the sky patches around it ([`fit_sun_spread`]).
    fn sun_light(&self, sky: &SkyState, site: &Site) -> SunLight {
        let Some((d, e)) = sky.sun_direction(site) else {
            return SunLight::default();
        };
        let on = self.sun_on_patches(d);
        let scaled = |v: &[f32]| v.iter().map(|&x| (x as f64 * e) as f32).collect::<Vec<_>>();
        SunLight {
            direct: Some(scaled(&on.direct)),
            interreflected: on.interreflected.as_deref().map(scaled),
            spread: on.spread.iter().map(|&(k, c)| (k, c * e)).collect(),
        }
    }

    /// A sky's daylight on every patch.
    pub fn patch_daylight(&self, sky: &SkyState) -> Result<PatchDaylight, QueryError> {
        self.sky_on_patches(sky, true)
    }

    /// A sky's daylight on every patch without the sun's direct light (its interreflection
    /// stays): what an image shows on its patches while the sun is traced per pixel.
    pub fn patch_daylight_without_sun(&self, sky: &SkyState) -> Result<PatchDaylight, QueryError> {
        self.sky_on_patches(sky, false)
    }

    /// A sky's daylight on every patch, with the sun's direct light or without.
    fn sky_on_patches(
        &self,
        sky: &SkyState,
        with_direct_sun: bool,
    ) -> Result<PatchDaylight, QueryError> {
        let (_, l, sun) = self.sky_light(sky)?;
        Ok(self.sky_patches(&l, &sun, with_direct_sun))
    }

    /// A sky at the scene's site: the site, the mean luminances of the sky patches (cd/m²,
    /// 0 the ground) and the sun's light on the patches.
    fn sky_light(&self, sky: &SkyState) -> Result<(&Site, Vec<f64>, SunLight), QueryError> {
        let site = self.site()?;
        let l = sky.patch_luminances(&sky_view::subdivision());
        Ok((site, l, self.sun_light(sky, site)))
    }

    /// A length beyond the scene, m (for escape rays).
    pub fn reach_length(&self) -> f64 {
        self.reach().length()
    }

    /// Peak bytes a daylight query may allocate.
    pub fn daylight_bytes(&self, q: &IlluminanceQuery) -> u64 {
        let grid_points: u64 = q.grids.iter().map(|&g| self.grids[g].len() as u64).sum();
        let per_point = 8 * self.patches() as u64 + 64 * 1024;
        64 * self.patches() as u64 + per_point * (q.points.len() as u64 + grid_points)
    }

    /// Daylight (plus electric light for group weights `w`) on surfaces, at points and on
    /// grids.
    pub fn daylight(
        &self,
        sky: &SkyState,
        w: Option<&[Rgb]>,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<DaylightAnswer, QueryError> {
        let (site, l, sun_light) = self.sky_light(sky)?;
        let light = PointLight::new(self, sky, site, &l, &sun_light, w);
        let points = light
            .at_points(&q.points, cancel)?
            .into_iter()
            .map(|(e, daylight)| DaylightPoint {
                lux: luminance64(e),
                rgb: e,
                daylight_factor: light.daylight_factor(daylight),
            })
            .collect();
        let mut grids = BTreeMap::new();
        for &gi in &q.grids {
            cancel.check()?;
            let answer = self.daylight_grid(gi, &light, cancel)?;
            grids.insert(self.grids[gi].grid.id.clone(), answer);
        }
        cancel.check()?;
        Ok(DaylightAnswer {
            unit: "lx",
            sky: SkyInfo::of(sky),
            points,
            surfaces: self.daylight_surfaces(&q.surfaces, &l, &sun_light, w),
            grids,
        })
    }

    /// Grid `gi` under the sky of `light`: its illuminance and, for the CIE overcast sky,
    /// its daylight factors.
    fn daylight_grid(
        &self,
        gi: usize,
        light: &PointLight,
        cancel: &Cancel,
    ) -> Result<DaylightGrid, QueryError> {
        let response = &self.grids[gi];
        let pts = self.grid_receivers(gi);
        let (values, dfs): (Vec<f32>, Vec<f32>) = light
            .at_points(&pts, cancel)?
            .into_iter()
            .map(|(e, daylight)| {
                let df = light.daylight_factor(daylight).unwrap_or(0.0);
                (luminance64(e) as f32, df as f32)
            })
            .unzip();
        let excluded = &response.excluded;
        let stats: GridStats = grid::stats(values, excluded);
        let daylight_factor =
            (light.sky.df_reference).map(|_| metrics::daylight_factors(&dfs, excluded));
        Ok(DaylightGrid {
            illuminance: super::query::grid_answer(&response.grid, stats),
            daylight_factor,
        })
    }

    /// Illuminance statistics of `surfaces` under sky patch luminances `l` and the sun's
    /// light, plus the electric light of group weights `w`.
    fn daylight_surfaces(
        &self,
        surfaces: &[usize],
        l: &[f64],
        sun_light: &SunLight,
        w: Option<&[Rgb]>,
    ) -> BTreeMap<String, SurfaceIlluminance> {
        if surfaces.is_empty() {
            return BTreeMap::new();
        }
        // Per-patch illuminance for the surfaces' statistics.
        let mut h = self.sky_patches(l, sun_light, true).h;
        if let Some(w) = w {
            let mut h_el = vec![0f32; 3 * self.patches()];
            self.baked.transfer.illuminance_into(w, &mut h_el);
            for (a, b) in h.iter_mut().zip(&h_el) {
                *a += b;
            }
        }
        self.surface_stats(surfaces, &h)
    }

    /// The sun's reflected light, lm/m² per patch (n × 3), for gathering exactly at points:
    /// its first reflection, plus its interreflection where it is solved (else the
    /// daylight coefficients carry it with the sky's).
    fn sun_reflected(&self, sun_light: &SunLight) -> Option<Vec<f32>> {
        let t = &self.baked.transfer;
        sun_light.direct.as_ref().map(|sd| {
            let ind = sun_light.interreflected.as_deref();
            sd.iter()
                .zip(&t.rho)
                .enumerate()
                .flat_map(|(i, (&e, r))| {
                    let h = |c: usize| e + ind.map_or(0.0, |v| v[3 * i + c]);
                    [h(0) * r[0], h(1) * r[1], h(2) * r[2]]
                })
                .collect()
        })
    }
}

/// What the light at a point needs under one sky: the sky patch luminances and the sun's
/// light, the electric light of group weights `w` when asked.
struct PointLight<'a> {
    model: &'a Model,
    sky: &'a SkyState,
    site: &'a Site,
    cols: &'a SkyColumns,
    /// Sky patch luminances, cd/m² (0 the ground).
    l: &'a [f64],
    /// The sun's spread over the sky patches ([`SunLight::spread`]).
    spread: &'a [(usize, f64)],
    /// [`Model::sun_reflected`].
    sun_b: Option<Vec<f32>>,
    /// The sun's scene direction and normal illuminance.
    sun: Option<(DVec3, f64)>,
    reach: Reach,
    w: Option<&'a [Rgb]>,
    /// The electric light's radiosity, lm/m² (n × 3; empty without `w`).
    b_el: Vec<f32>,
}

impl<'a> PointLight<'a> {
    fn new(
        model: &'a Model,
        sky: &'a SkyState,
        site: &'a Site,
        l: &'a [f64],
        sun_light: &'a SunLight,
        w: Option<&'a [Rgb]>,
    ) -> PointLight<'a> {
        let t = &model.baked.transfer;
        let mut b_el = vec![];
        if let Some(w) = w {
            b_el = vec![0f32; 3 * t.n];
            t.relight_into(w, &mut b_el);
        }
        PointLight {
            model,
            sky,
            site,
            cols: t.sky.as_ref().expect("site() checks the sky responses"),
            l,
            spread: &sun_light.spread,
            sun_b: model.sun_reflected(sun_light),
            sun: sky.sun_direction(site),
            reach: model.reach(),
            w,
            b_el,
        }
    }

    /// The light at point `x` (m) facing `nrm` with gather `g`: (all light, daylight
    /// alone), RGB lux.
    fn at(&self, g: &PointGather, x: DVec3, nrm: DVec3) -> ([f64; 3], f64) {
        let m = self.model;
        let mut e = g.reflected(self.cols, &m.baked.transfer.rho, self.l, self.spread);
        if let Some(b) = &self.sun_b {
            let s = g.gather(b);
            for c in 0..3 {
                e[c] += s[c];
            }
        }
        let mut direct = g.direct_sky(self.sky, self.site);
        if let Some(sun) = self.sun {
            direct += m.sun_at(x, nrm, sun, self.reach);
        }
        for c in &mut e {
            *c += direct;
        }
        let daylight = luminance64(e);
        if let Some(w) = self.w {
            let el = g.gather(&self.b_el);
            m.add_luminaires(w, x, nrm, &mut e);
            for c in 0..3 {
                e[c] += el[c];
            }
        }
        (e, daylight)
    }

    /// The light at `points` (position m, unit normal), gathered in parallel: (all light,
    /// daylight alone) per point, as [`PointLight::at`].
    fn at_points(
        &self,
        points: &[(DVec3, DVec3)],
        cancel: &Cancel,
    ) -> Result<Vec<([f64; 3], f64)>, QueryError> {
        let gathers = self.model.gathers(points, cancel)?;
        Ok(points
            .par_iter()
            .zip(gathers.par_iter())
            .map(|(&(x, nrm), g)| self.at(g, x, nrm))
            .collect())
    }

    /// The daylight factor of `daylight` lux, percent, under the CIE overcast sky.
    fn daylight_factor(&self, daylight: f64) -> Option<f64> {
        self.sky
            .df_reference
            .map(|r| 100.0 * daylight / r.max(1e-9))
    }
}

impl SkyInfo {
    /// The sky as it was resolved.
    fn of(sky: &SkyState) -> SkyInfo {
        let en = sky.sun.map_or(0.0, |s| s.normal_illuminance);
        SkyInfo {
            kind: sky.kind,
            sun: sky.sun_position,
            direct_normal_illuminance: en,
            diffuse_horizontal_illuminance: sky.diffuse_horizontal,
            global_horizontal_illuminance: sky.diffuse_horizontal
                + sky.sun.map_or(0.0, |s| en * s.altitude.sin()),
            ground_luminance: sky.ground_luminance,
        }
    }
}
