//! The point-gather cache every point query shares: a set of points (with normals) is
//! gathered once ([`PointGather`]: the point-to-patch weights and the sky view) and kept,
//! keyed by the points' bytes, in a least-recently-used list bounded by
//! [`GatherCache::for_scene`]'s size. Asking the same points again under another sky or
//! light state is a sparse dot product per point. The cache also keeps the sun's light on
//! the patches for the last few sun directions ([`SUN_CACHE_ENTRIES`]).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use super::patches::SunLight;
use crate::color::{Rgb, Rgb64};
use crate::daylight::sky_luminance::Sky;
use crate::daylight::Site;
use crate::model::daylight::sun_on_patches::SunOnPatches;
use crate::model::sky_state::SkyState;
use crate::model::{Cancel, Model, QueryError};
use crate::transport::probe::gather_weights;
use crate::transport::sky_view::SkyView;
use crate::transport::transfer::SkyColumns;

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
    /// `Σ_j w_j ρ_j D_jk` (first K triples), then of its interreflected light
    /// `Σ_j w_j ρ_j I_kj` (next K), lux per cd/m². A new sky is then 2K products per
    /// point.
    coefficients: OnceLock<Vec<Rgb>>,
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
    fn coefficients(&self, s: &SkyColumns, rho: &[Rgb]) -> &[Rgb] {
        self.coefficients.get_or_init(|| {
            let k = s.k;
            let mut out = vec![Rgb::ZERO; 2 * k];
            let wr: Vec<(usize, Rgb)> = self
                .weights
                .iter()
                .map(|&(j, w)| (j as usize, rho[j as usize] * w))
                .collect();
            // Direct part: rows of D are contiguous per patch.
            let mut d = vec![Rgb64::ZERO; k];
            for &(j, r) in &wr {
                let row = &s.direct[j * k..(j + 1) * k];
                for (dk, &v) in d.iter_mut().zip(row) {
                    *dk += (r * v).to_f64();
                }
            }
            let (direct, interreflected) = out.split_at_mut(k);
            for (o, v) in direct.iter_mut().zip(&d) {
                *o = v.to_f32();
            }
            // Interreflected part: columns of I are contiguous per sky patch.
            for (o, ind) in interreflected.iter_mut().zip(&s.indirect) {
                let ind = Rgb::column(ind);
                let mut i = Rgb64::ZERO;
                for &(j, r) in &wr {
                    i += (r * ind[j]).to_f64();
                }
                *o = i.to_f32();
            }
            out
        })
    }

    /// The direct light of the sky and the ground seen from the point, lux: for the
    /// uniform and overcast skies from the view's cached sums, else ray by ray against the
    /// continuous sky.
    pub(super) fn direct_sky(&self, sky: &SkyState, site: &Site) -> f64 {
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
    pub(super) fn reflected(
        &self,
        s: &SkyColumns,
        rho: &[Rgb],
        l: &[f64],
        sun: &[(usize, f64)],
    ) -> Rgb64 {
        let (direct, interreflected) = self.coefficients(s, rho).split_at(s.k);
        let mut e = Rgb64::ZERO;
        for (kk, &lk) in l.iter().enumerate() {
            if lk == 0.0 {
                continue;
            }
            e += lk * (direct[kk].to_f64() + interreflected[kk].to_f64());
        }
        for &(kk, lum) in sun {
            e += lum * interreflected[kk].to_f64();
        }
        e
    }

    /// Σ w_j B_j per channel, for per-patch radiosity `b` (n × 3 interleaved).
    pub fn gather(&self, b: &[f32]) -> Rgb64 {
        let b = Rgb::column(b);
        let mut e = Rgb64::ZERO;
        for &(j, w) in &self.weights {
            e += w as f64 * b[j as usize].to_f64();
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

    /// The sun's light on the patches for the sun in unit scene direction `d`, kept for
    /// the last [`SUN_CACHE_ENTRIES`] directions; `trace` makes it when it is not kept.
    pub(super) fn sun(&self, d: DVec3, trace: impl FnOnce() -> SunOnPatches) -> Arc<SunOnPatches> {
        let k = key(&[(d, DVec3::ZERO)]);
        let mut suns = crate::model::lock(&self.suns);
        if let Some((_, v)) = touch(&mut suns, |(kk, _)| *kk == k) {
            return v.clone();
        }
        drop(suns);
        let v = Arc::new(trace());
        let mut suns = crate::model::lock(&self.suns);
        suns.push_front((k, v.clone()));
        suns.truncate(SUN_CACHE_ENTRIES);
        v
    }
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
            let mut e = crate::model::lock(&self.gathers.entries);
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
            let mut e = crate::model::lock(&self.gathers.entries);
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
}
