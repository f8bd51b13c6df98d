//! The queries of a lighting state: per-patch radiosity B (lm/m², leaving) or incident
//! illuminance H (lux, arriving), per-surface statistics, illuminance at points and on
//! calculation grids (lux), and the luminaires' flux (lm) and power (W).
//!
//! Group states are weighted sums of precomputed columns (microseconds); a per-patch
//! emission is an exact product with the stored irradiance responses (factored transfer).

use std::collections::BTreeMap;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::compliance::{self, Achieved, Compliance, ObserverUgr};
use super::grid::{self, GridStats};
use super::lighting::{LightState, Lighting};
use super::report::{surface_illuminance, Lux, SurfaceIlluminance};
use super::{Cancel, Model, QueryError};
use crate::color::{Rgb, Rgb64};
use crate::input_limits::MAX_STATE_EMISSION;
use crate::scene::Requirements;
use crate::transport::transfer::{Solution, TransferMode};

/// Which per-patch quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Radiosity B, lm/m² (light leaving the patch).
    Radiosity,
    /// Incident illuminance H, lux (light arriving at the patch).
    Illuminance,
}

/// One grid's statistics for a lighting state, lux.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = GridStats))]
pub struct GridAnswer {
    pub name: String,
    /// Always `"lx"`.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lx))]
    pub unit: &'static str,
    pub count: usize,
    /// Columns × rows for rectangular work planes.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::layout, required = true))]
    pub layout: Option<[usize; 2]>,
    /// Eavg, lx.
    pub avg: f64,
    /// Emin, lx.
    pub min: f64,
    /// Emax, lx.
    pub max: f64,
    /// Emin / Eavg; null when every measured point is at 0 lx (see `note`).
    #[cfg_attr(feature = "server", schema(required = true))]
    pub u0: Option<f64>,
    /// Emin / Emax; null when every measured point is at 0 lx.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub min_max: Option<f64>,
    /// Why `u0` and `min_max` are null (an unlit grid, or no measured point); absent
    /// otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<&'static str>,
    /// Luminous illuminance at each point, lx, in grid order; null for a point left out
    /// of the statistics (inside an object or under a surface at close range).
    #[cfg_attr(feature = "server", schema(value_type = Vec<Option<f64>>))]
    pub values: Vec<Option<f32>>,
    /// Points left out of the statistics (null in `values`).
    pub excluded: usize,
    /// The EN 12464-1 zone, when the grid is declared as one.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub kind: Option<crate::scene::grids::GridKind>,
    /// Distance between neighbouring points, m (work planes and areas); null for
    /// explicit points.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub spacing: Option<f64>,
}

/// Flux and electrical power of the point luminaires in a lighting state.
#[derive(Debug, Clone, Copy, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct LuminairePower {
    /// lm.
    pub luminaire_lumens: f64,
    /// W, dimming assumed proportional; null when a lit luminaire gives no wattage.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub luminaire_watts: Option<f64>,
}

/// What to compute illuminance for.
#[derive(Debug, Clone, Default)]
pub struct IlluminanceQuery {
    /// Surface indices (statistics of the per-patch illuminance).
    pub surfaces: Vec<usize>,
    /// Points with their normals (position m, unit normal).
    pub points: Vec<(DVec3, DVec3)>,
    /// Grid indices.
    pub grids: Vec<usize>,
    /// Maintenance factors; None: the scene's.
    pub maintenance: Option<Factors>,
    /// Requirements per grid index, replacing the scene's for that grid.
    pub requirements: BTreeMap<usize, Requirements>,
}

/// The maintenance factors of a query, each in (0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Factors {
    /// Per light group, in the order of `scene.lights`.
    pub groups: Vec<f64>,
    /// For a per-patch emission (no groups).
    pub emission: f64,
}

/// The answers again under the maintenance factors: maintained = MF × initial, lux.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Maintained {
    /// In request order.
    pub points: Vec<Lux>,
    /// By surface id.
    pub surfaces: BTreeMap<String, SurfaceIlluminance>,
    /// By grid id; its `avg` is Ēm.
    pub grids: BTreeMap<String, GridAnswer>,
}

/// Illuminance answers, lux: at points, per surface and per grid.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = IlluminanceResponse))]
pub struct IlluminanceAnswer {
    /// Always `"lx"`.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lx))]
    pub unit: &'static str,
    /// In request order.
    pub points: Vec<Lux>,
    /// By surface id.
    pub surfaces: BTreeMap<String, SurfaceIlluminance>,
    /// By grid id.
    pub grids: BTreeMap<String, GridAnswer>,
    /// The luminaires' flux and power in this state; null for a per-patch emission.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub power: Option<LuminairePower>,
    /// The maintenance factor MF of each light group, 0..1 (for a per-patch emission, the
    /// scene's under the key `emission`; with luminaires placed for the request, also the
    /// scene's under `placed`, which placed luminaires without a group take).
    pub maintenance_factors: BTreeMap<String, f64>,
    /// The same answers maintained: each group's light × its MF.
    pub maintained: Maintained,
    /// By grid id, the grids asked for that carry requirements: pass or fail, and by how
    /// much.
    pub compliance: BTreeMap<String, Compliance>,
}

impl Model {
    /// Per-group RGB weights of a lighting state.
    pub fn weights(&self, state: &LightState) -> Result<Vec<Rgb>, QueryError> {
        Ok(state.weights(&self.baked.scene)?)
    }

    /// The index of grid `id`.
    pub fn grid_index(&self, id: &str) -> Result<usize, QueryError> {
        self.grids
            .iter()
            .position(|r| r.grid.id == id)
            .ok_or_else(|| {
                let known = self.grids.iter().map(|r| r.grid.id.as_str());
                QueryError::Invalid(format!(
                    "unknown grid '{}' (known: {})",
                    super::error::shorten(id),
                    super::error::known_list(known)
                ))
            })
    }

    /// Refuses per-patch emission unless the transfer is factored (an exact solve) or
    /// hierarchical (sweeps over the links).
    pub fn require_factored(&self) -> Result<(), QueryError> {
        let t = &self.baked.transfer;
        match t.mode {
            TransferMode::Factored if t.factored.is_some() => Ok(()),
            TransferMode::Hierarchical if t.hierarchy.is_some() => Ok(()),
            m => Err(QueryError::NeedsFactored {
                scene: self.baked.scene.id.clone(),
                mode: match m {
                    TransferMode::Factored => "factored (without its factors)",
                    TransferMode::Hierarchical => "hierarchical (without its links)",
                    TransferMode::Columns => "columns",
                },
            }),
        }
    }

    /// One patch's emission, lm/m² per channel, checked against [`MAX_STATE_EMISSION`].
    pub fn emission_value(&self, patch: usize, rgb: [f64; 3]) -> Result<Rgb, QueryError> {
        let n = self.patches();
        if patch >= n {
            return Err(QueryError::Invalid(format!(
                "emission patch index {patch} out of range (the scene has {n} patches)"
            )));
        }
        for x in rgb {
            if !(0.0..=MAX_STATE_EMISSION).contains(&x) {
                return Err(QueryError::Invalid(format!(
                    "emission[{patch}]: values must be in [0, {MAX_STATE_EMISSION:e}] lm/m², got {x}"
                )));
            }
        }
        Ok(Rgb64(rgb).to_f32())
    }

    /// The full solution (emission, radiosity, illuminance per patch).
    pub fn solve(&self, l: &Lighting) -> Result<Solution, QueryError> {
        let t = &self.baked.transfer;
        let unsolvable =
            || QueryError::Invalid("this scene's transfer cannot solve an emission".into());
        match l {
            Lighting::Groups(w) => Ok(t.relight(w)),
            Lighting::Emission(e) => {
                self.check_emission(e)?;
                t.solve(e).ok_or_else(unsolvable)
            }
            Lighting::Placed(p) => Ok(self.placed_parts(p)?.0),
        }
    }

    /// Refuses an emission vector that this scene's transfer cannot solve or that is not
    /// one RGB triple per patch.
    pub fn check_emission(&self, e: &[f32]) -> Result<(), QueryError> {
        self.require_factored()?;
        let n = self.patches();
        if e.len() != 3 * n {
            return Err(QueryError::Invalid(format!(
                "emission has {} entries; the scene has {n} patches (one [r,g,b] per patch)",
                e.len() / 3,
            )));
        }
        Ok(())
    }

    /// Per-patch B (lm/m²) or H (lux) for group weights: one weighted sum.
    pub fn per_patch_groups(&self, w: &[Rgb], q: Quantity, out: &mut [f32]) {
        let t = &self.baked.transfer;
        match q {
            Quantity::Radiosity => t.relight_into(w, out),
            Quantity::Illuminance => t.illuminance_into(w, out),
        }
    }

    /// Per-patch B (lm/m²) or H (lux), n × 3 interleaved.
    pub fn per_patch(&self, l: &Lighting, q: Quantity) -> Result<Vec<f32>, QueryError> {
        if let Lighting::Groups(w) = l {
            let mut out = vec![0f32; 3 * self.patches()];
            self.per_patch_groups(w, q, &mut out);
            return Ok(out);
        }
        let s = self.solve(l)?;
        Ok(match q {
            Quantity::Radiosity => s.b,
            Quantity::Illuminance => s.h,
        })
    }

    /// Illuminance statistics of `surfaces` from per-patch illuminance `h` (lux), by name.
    pub fn surface_stats(
        &self,
        surfaces: &[usize],
        h: &[f32],
    ) -> BTreeMap<String, SurfaceIlluminance> {
        let b = &self.baked;
        surfaces
            .iter()
            .map(|&s| {
                (
                    b.scene.surfaces[s].name.clone(),
                    surface_illuminance(&b.mesh, s, h),
                )
            })
            .collect()
    }

    /// Illuminance (lux, RGB) at point `x` (m) on a receiver facing `n`: the light
    /// gathered from radiosity `b` plus, for group weights, the luminaires' direct light
    /// with shadow rays.
    pub fn point_illuminance(&self, b: &[f32], w: Option<&[Rgb]>, x: DVec3, n: DVec3) -> Rgb64 {
        let k = &self.baked;
        let mut e = crate::transport::probe::illuminance_at(&k.mesh, &k.bvh, b, x, n);
        self.add_luminaires(w.unwrap_or(&[]), x, n, &mut e);
        e
    }

    /// [`Model::point_illuminance`] for a lighting state: the groups' luminaires at their
    /// weights and a request's placed luminaires add their direct light.
    pub fn lit_point_illuminance(&self, l: &Lighting, b: &[f32], x: DVec3, n: DVec3) -> Rgb64 {
        match l {
            Lighting::Placed(p) => {
                let mut e = self.point_illuminance(b, Some(&p.weights), x, n);
                e += crate::transport::direct::weighted_point_illuminance(
                    &self.baked.bvh,
                    p.luminaires(),
                    x,
                    n,
                );
                e
            }
            _ => self.point_illuminance(b, l.weights(), x, n),
        }
    }

    /// Adds to `e` (RGB lux) the direct light of the luminaires of group weights `w` at
    /// point `x` (m) on a receiver facing `n`, with shadow rays.
    pub(super) fn add_luminaires(&self, w: &[Rgb], x: DVec3, n: DVec3, e: &mut Rgb64) {
        let k = &self.baked;
        for (g, &w) in k.scene.lights.iter().zip(w) {
            if g.luminaires.is_empty() || w == Rgb::ZERO {
                continue;
            }
            let d = crate::transport::direct::point_illuminance(&k.bvh, &g.luminaires, x, n);
            *e += w.to_f64() * d;
        }
    }

    /// A grid's answer for group weights: a weighted sum of its per-group responses.
    pub fn grid_answer(&self, gi: usize, w: &[Rgb]) -> GridAnswer {
        let g = &self.grids[gi];
        grid_answer(&g.grid, g.stats(w))
    }

    /// Grid answers for any lighting state `l` already solved as `sol`, keyed by grid id:
    /// a weighted sum of the stored responses for group weights; for luminaires placed
    /// per request, those plus the changes traced and gathered at each point
    /// ([`Model::placed_grid_values`]); for an emission, its emitting patches gathered at
    /// each point and its reflected radiosity through the grid's gather weights.
    pub fn state_grid_answers(
        &self,
        l: &Lighting,
        sol: &crate::transport::transfer::Solution,
        grids: &[usize],
        cancel: &Cancel,
    ) -> Result<BTreeMap<String, GridAnswer>, QueryError> {
        let answers = match l {
            Lighting::Groups(w) => self.grid_answers(grids, w),
            Lighting::Placed(p) => {
                // The changes' radiosity: the state's less the groups'.
                let mut extra = sol.b.clone();
                let base = self.baked.transfer.relight(&p.weights);
                extra.iter_mut().zip(&base.b).for_each(|(x, b)| *x -= b);
                grids
                    .iter()
                    .map(|&gi| {
                        let values = self.placed_grid_values(gi, p, &extra, cancel);
                        let g = &self.grids[gi];
                        (
                            g.grid.id.clone(),
                            grid_answer(&g.grid, grid::stats(values, &g.excluded)),
                        )
                    })
                    .collect()
            }
            Lighting::Emission(_) => grids
                .iter()
                .map(|&gi| {
                    let g = &self.grids[gi];
                    let n = DVec3::from_array(g.grid.normal);
                    // The emitting patches gathered exactly at each point (rays where
                    // they are bright), the reflected radiosity B − E through the grid's
                    // baked gather weights.
                    let reflected: Vec<f32> =
                        sol.b.iter().zip(&sol.e).map(|(b, e)| b - e).collect();
                    let k = &self.baked;
                    let values = g
                        .grid
                        .points
                        .par_iter()
                        .enumerate()
                        .map(|(i, x)| {
                            if cancel.is_cancelled() {
                                return 0.0;
                            }
                            let x = DVec3::from_array(*x);
                            let e = crate::transport::probe::illuminance_at(
                                &k.mesh, &k.bvh, &sol.e, x, n,
                            ) + g.gather.indirect(i, &reflected, &k.mesh, &k.bvh, x, n);
                            e.luminance() as f32
                        })
                        .collect();
                    (
                        g.grid.id.clone(),
                        grid_answer(&g.grid, grid::stats(values, &g.excluded)),
                    )
                })
                .collect(),
        };
        cancel.check()?;
        Ok(answers)
    }

    /// Grid answers for group weights, keyed by grid id.
    pub fn grid_answers(&self, grids: &[usize], w: &[Rgb]) -> BTreeMap<String, GridAnswer> {
        grids
            .iter()
            .map(|&gi| (self.grids[gi].grid.id.clone(), self.grid_answer(gi, w)))
            .collect()
    }

    /// Flux (lm) and power (W) of the point luminaires for group weights. Watts scale
    /// with the luminous level of each group (dimming assumed proportional); a group that
    /// is off counts 0 W even when its luminaires give no wattage.
    pub fn luminaire_power(&self, w: &[Rgb]) -> LuminairePower {
        let mut lumens = 0.0;
        let mut watts = 0.0;
        let mut watts_known = true;
        let groups = self.baked.transfer.groups.iter().zip(&self.groups);
        for ((g, info), wt) in groups.zip(w) {
            if info.luminaires == 0 {
                continue;
            }
            let lm = (wt.to_f64() * g.flux).luminance();
            lumens += lm;
            if lm == 0.0 {
                // Off: no power, known or not.
                continue;
            }
            match info.watts {
                Some(full) if info.lumens > 0.0 => watts += full * lm / g.flux.luminance(),
                _ => watts_known = false,
            }
        }
        LuminairePower {
            luminaire_lumens: lumens,
            luminaire_watts: watts_known.then_some(watts),
        }
    }

    /// Peak bytes an [`IlluminanceQuery`] may allocate (solution and per-point answers).
    pub fn illuminance_bytes(&self, q: &IlluminanceQuery) -> u64 {
        let grid_points: u64 = q.grids.iter().map(|&g| self.grids[g].len() as u64).sum();
        BYTES_PER_PATCH_ANSWER * self.patches() as u64 + 400 * (q.points.len() as u64 + grid_points)
    }

    /// Whether a query is a pure weighted sum (no points, group lighting): microseconds.
    pub fn is_cheap(&self, l: &Lighting, q: &IlluminanceQuery) -> bool {
        matches!(l, Lighting::Groups(_)) && q.points.is_empty() && !self.rates_glare(q)
    }

    /// Illuminance on surfaces, at points and on grids for a lighting state. Points (and
    /// grid points under an emission) are gathered in parallel and stop when `cancel` is
    /// raised.
    pub fn illuminance(
        &self,
        l: &Lighting,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<IlluminanceAnswer, QueryError> {
        match l {
            Lighting::Groups(w) => self.group_illuminance(w, q, cancel),
            Lighting::Emission(_) => self.solved_illuminance(l, q, cancel),
            Lighting::Placed(p) => self.placed_illuminance(p, q, cancel),
        }
    }

    /// [`Model::illuminance`] for group weights `w`: weighted sums, and the points'
    /// gathers from the cache; the same again under the maintenance factors.
    fn group_illuminance(
        &self,
        w: &[Rgb],
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<IlluminanceAnswer, QueryError> {
        let factors = self.factors(q);
        let wm = compliance::maintained_weights(w, &factors.groups);
        let (points, maintained_points) = self.group_points(w, &wm, &q.points, cancel)?;
        let surfaces = |w: &[Rgb]| {
            let mut h = vec![0f32; 3 * self.patches()];
            self.per_patch_groups(w, Quantity::Illuminance, &mut h);
            self.surface_stats(&q.surfaces, &h)
        };
        let maintained = Maintained {
            points: maintained_points,
            surfaces: surfaces(&wm),
            grids: self.grid_answers(&q.grids, &wm),
        };
        let lit = Lighting::Groups(w.to_vec());
        let compliance = self.compliance(q, Some(&lit), &maintained.grids, cancel)?;
        let groups = self.baked.scene.lights.iter().map(|g| g.id.clone());
        Ok(IlluminanceAnswer {
            unit: "lx",
            points,
            surfaces: surfaces(w),
            grids: self.grid_answers(&q.grids, w),
            power: Some(self.luminaire_power(w)),
            maintenance_factors: groups.zip(factors.groups).collect(),
            maintained,
            compliance,
        })
    }

    /// Illuminance at `points` under weights `w` and maintained weights `wm`: one gather
    /// each, and the luminaires' direct light traced once for both.
    fn group_points(
        &self,
        w: &[Rgb],
        wm: &[Rgb],
        points: &[(DVec3, DVec3)],
        cancel: &Cancel,
    ) -> Result<(Vec<Lux>, Vec<Lux>), QueryError> {
        if points.is_empty() {
            return Ok((vec![], vec![]));
        }
        let radiosity = |w: &[Rgb]| {
            let mut b = vec![0f32; 3 * self.patches()];
            self.per_patch_groups(w, Quantity::Radiosity, &mut b);
            b
        };
        let (b, bm) = (radiosity(w), radiosity(wm));
        let gathers = self.gathers(points, cancel)?;
        let k = &self.baked;
        Ok(points
            .iter()
            .zip(gathers.iter())
            .map(|(&(x, n), g)| {
                let (mut e, mut em) = (g.gather(&b), g.gather(&bm));
                for ((group, &wg), &wmg) in k.scene.lights.iter().zip(w).zip(wm) {
                    if group.luminaires.is_empty() || wg == Rgb::ZERO {
                        continue;
                    }
                    let d = crate::transport::direct::point_illuminance(
                        &k.bvh,
                        &group.luminaires,
                        x,
                        n,
                    );
                    e += wg.to_f64() * d;
                    em += wmg.to_f64() * d;
                }
                (Lux::new(e), Lux::new(em))
            })
            .unzip())
    }

    /// The maintenance factors of query `q`: its own, else the scene's.
    pub fn factors(&self, q: &IlluminanceQuery) -> Factors {
        q.maintenance.clone().unwrap_or_else(|| Factors {
            groups: compliance::scene_factors(&self.baked.scene),
            emission: self.baked.scene.maintenance_factor,
        })
    }

    /// The requirements of grid `gi` in query `q` (the request's, else the scene's).
    pub fn requirements(&self, q: &IlluminanceQuery, gi: usize) -> Requirements {
        q.requirements
            .get(&gi)
            .copied()
            .unwrap_or(self.grids[gi].grid.requirements)
    }

    /// The compliance of the query's grids that carry requirements, from their
    /// `maintained` answers; UGR at the task observers and Ra under lighting state `lit`
    /// (None: a per-patch emission, which UGR cannot rate).
    pub(super) fn compliance(
        &self,
        q: &IlluminanceQuery,
        lit: Option<&Lighting>,
        maintained: &BTreeMap<String, GridAnswer>,
        cancel: &Cancel,
    ) -> Result<BTreeMap<String, Compliance>, QueryError> {
        let mut out = BTreeMap::new();
        for &gi in &q.grids {
            let r = self.requirements(q, gi);
            if r.is_empty() {
                continue;
            }
            let grid = &self.grids[gi].grid;
            let m = maintained.get(&grid.id);
            let measured = m.is_some_and(|m| m.count > m.excluded);
            let observers = match (lit, r.ugr_l) {
                (Some(l), Some(_)) => Some(self.task_ugr(grid, l, cancel)?),
                (Some(_), None) => Some(vec![]),
                (None, _) => None,
            };
            let achieved = Achieved {
                em: m.filter(|_| measured).map(|m| m.avg),
                u0: m.filter(|_| measured).and_then(|m| m.u0),
                observers,
                ra: match lit {
                    Some(Lighting::Groups(w)) => compliance::lit_ra(&self.baked.scene, w),
                    Some(Lighting::Placed(p)) => p.lit_ra(&self.baked.scene),
                    Some(Lighting::Emission(_)) | None => Ok(None),
                },
            };
            out.insert(grid.id.clone(), compliance::check(&r, &achieved));
        }
        Ok(out)
    }

    /// UGR at a task area's observers ([`compliance::task_observers`]) under `lighting`.
    pub(crate) fn task_ugr(
        &self,
        grid: &crate::scene::Grid,
        lighting: &Lighting,
        cancel: &Cancel,
    ) -> Result<Vec<ObserverUgr>, QueryError> {
        let observers = compliance::task_observers(grid);
        Ok(self
            .glare(&observers, lighting, cancel)?
            .into_iter()
            .map(|o| ObserverUgr {
                eye: o.eye,
                direction: o.direction,
                ugr: o.ugr,
            })
            .collect())
    }

    /// Whether a query needs observers' views (a UGR requirement on a grid it asks for).
    pub fn rates_glare(&self, q: &IlluminanceQuery) -> bool {
        q.grids
            .iter()
            .any(|&gi| self.requirements(q, gi).ugr_l.is_some())
    }

    /// [`Model::illuminance`] for a per-patch emission: one solve, and every point (grid
    /// points too) gathered from it.
    pub(super) fn solved_illuminance(
        &self,
        l: &Lighting,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<IlluminanceAnswer, QueryError> {
        let (sol, extra_b) = match l {
            Lighting::Placed(p) => {
                let (sol, extra) = self.placed_parts(p)?;
                (sol, Some((p, extra)))
            }
            _ => (self.solve(l)?, None),
        };
        let at = |x: DVec3, n: DVec3| -> Rgb64 {
            if cancel.is_cancelled() {
                Rgb64::ZERO
            } else {
                self.lit_point_illuminance(l, &sol.b, x, n)
            }
        };
        let points: Vec<Lux> = q
            .points
            .par_iter()
            .map(|(x, n)| Lux::new(at(*x, *n)))
            .collect();
        cancel.check()?;
        let grids: BTreeMap<String, GridAnswer> = q
            .grids
            .iter()
            .map(|&gi| {
                let excluded = &self.grids[gi].excluded;
                let g = &self.grids[gi].grid;
                let n = DVec3::from_array(g.normal);
                let values: Vec<f32> = match &extra_b {
                    Some((p, extra)) => self.placed_grid_values(gi, p, extra, cancel),
                    None => g
                        .points
                        .par_iter()
                        .map(|p| at(DVec3::from_array(*p), n).luminance() as f32)
                        .collect(),
                };
                (g.id.clone(), grid_answer(g, grid::stats(values, excluded)))
            })
            .collect();
        cancel.check()?;
        // No groups: one maintenance factor scales everything.
        let mf = self.factors(q).emission;
        let surfaces = self.surface_stats(&q.surfaces, &sol.h);
        let maintained = Maintained {
            points: points.iter().map(|p| p.scaled(mf)).collect(),
            surfaces: surfaces
                .iter()
                .map(|(k, s)| (k.clone(), s.scaled(mf)))
                .collect(),
            grids: grids
                .iter()
                .map(|(k, g)| (k.clone(), g.scaled(mf)))
                .collect(),
        };
        let compliance = self.compliance(q, None, &maintained.grids, cancel)?;
        Ok(IlluminanceAnswer {
            unit: "lx",
            points,
            surfaces,
            grids,
            power: None,
            maintenance_factors: [("emission".to_string(), mf)].into(),
            maintained,
            compliance,
        })
    }
}

/// Bytes a per-patch answer may hold per patch: the solution (b, h, e: 36), the values
/// copied out (12) and JSON text (3 numbers of up to 16 characters, 50).
pub const BYTES_PER_PATCH_ANSWER: u64 = 100;

impl GridAnswer {
    /// Every value × `k` (k ≥ 0): the ratios stay.
    pub fn scaled(&self, k: f64) -> GridAnswer {
        GridAnswer {
            avg: self.avg * k,
            min: self.min * k,
            max: self.max * k,
            values: self
                .values
                .iter()
                .map(|v| v.map(|x| (x as f64 * k) as f32))
                .collect(),
            ..self.clone()
        }
    }
}

pub(crate) fn grid_answer(g: &crate::scene::Grid, s: GridStats) -> GridAnswer {
    GridAnswer {
        name: g.name.clone(),
        unit: "lx",
        count: g.points.len(),
        layout: g.layout,
        avg: s.avg,
        min: s.min,
        max: s.max,
        u0: s.u0,
        min_max: s.min_max,
        note: s.note,
        values: s.values,
        excluded: s.excluded,
        kind: g.kind,
        spacing: g.spacing,
    }
}
