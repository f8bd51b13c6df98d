//! Dimming levels that meet illuminance targets with the least flux.
//!
//! Each free light group g gets a level x_g in [0, 1] (its intensity; colour as modelled).
//! A grid point's illuminance is linear in the levels, `E_i(x) = F_i + Σ_g x_g E_ig`, with
//! F_i the contribution of the groups held fixed. Every target is a linear constraint:
//!
//! - `Eavg ≥ t`:  Σ_g x_g avg_g ≥ t − avg_F
//! - `Emin ≥ t`:  for every point i, Σ_g x_g E_ig ≥ t − F_i
//! - `U0 ≥ u` (Emin/Eavg): for every point i, E_i ≥ u·Eavg, i.e.
//!   Σ_g x_g (E_ig − u·avg_g) ≥ u·avg_F − F_i
//!
//! The objective, the emitted flux Σ_g Φ_g x_g, is linear too: a small LP (a few groups,
//! a few thousand rows), solved exactly by the simplex method (microlp).
//!
//! A UGR ceiling (`UGR ≤ U` at a grid's task observers, CIE 117) is not linear but convex.
//! Each luminaire belongs to one group, so at an observer `Σ L² ω / p² = A_F + Σ_g A_g x_g²`
//! and the background `L_b = B_F + Σ_g B_g x_g`, and `UGR ≤ U` is
//! `f(x) = A_F + Σ_g A_g x_g² − c (B_F + Σ_g B_g x_g) ≤ 0` with `c = 4 · 10^(U/8)`: a convex
//! quadratic (A_g ≥ 0). Kelley's cutting planes honour it exactly: solve the LP, and while
//! an observer's `f` is positive at the solution, add its tangent plane there
//! (`f(x*) + ∇f(x*)·(x − x*) ≤ 0`, which every feasible point satisfies) and solve again.
//! An infeasible LP then proves that no levels meet the targets and the ceiling together.

use std::collections::BTreeMap;

use microlp::{ComparisonOp, OptimizationDirection, Problem};
use serde::Serialize;

use super::placed::{LuminaireChange, Placed};
use super::query::{GridAnswer, LuminairePower};
use super::{Lighting, Model, QueryError};
use crate::color::Rgb;

/// Bounds on one grid (lux, or a ratio for U₀; `None` is not asked). The grid is named by
/// its id (`G = String`, the label in messages) or by its index ([`GridTarget`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Target<G = String> {
    pub grid: G,
    pub eavg_min: Option<f64>,
    pub emin_min: Option<f64>,
    pub u0_min: Option<f64>,
    /// The highest UGR allowed at the grid's task observers
    /// ([`super::compliance::task_observers`]).
    pub ugr_max: Option<f64>,
}

/// A target by grid index.
pub type GridTarget = Target<usize>;

impl<G> Target<G> {
    /// The same bounds on a grid named `grid`.
    pub fn named<H>(&self, grid: H) -> Target<H> {
        Target {
            grid,
            eavg_min: self.eavg_min,
            emin_min: self.emin_min,
            u0_min: self.u0_min,
            ugr_max: self.ugr_max,
        }
    }
}

/// One observer's glare as a function of the free levels x (see the module docs):
/// `Σ L² ω / p² = a_fixed + Σ_g a_g x_g²` and `L_b = b_fixed + Σ_g b_g x_g` (cd/m²).
#[derive(Debug, Clone)]
pub struct GlareModel {
    pub a: Vec<f64>,
    pub a_fixed: f64,
    pub b: Vec<f64>,
    pub b_fixed: f64,
    /// The ceiling U.
    pub ugr_max: f64,
}

impl GlareModel {
    /// `c = 4 · 10^(U/8)`: UGR ≤ U ⇔ Σ ≤ c L_b.
    fn c(&self) -> f64 {
        4.0 * 10f64.powf(self.ugr_max / 8.0)
    }

    /// f(x) relative to c L_b(x) (how far over the ceiling, as a fraction) and its
    /// gradient, both divided by c·(b_fixed + Σ b_g) to keep the LP's rows near unit scale.
    fn excess(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let c = self.c();
        let scale = c * (self.b_fixed + self.b.iter().sum::<f64>()).max(1e-12);
        let mut f = self.a_fixed - c * self.b_fixed;
        let mut grad = Vec::with_capacity(x.len());
        for ((&a, &b), &xg) in self.a.iter().zip(&self.b).zip(x) {
            f += a * xg * xg - c * b * xg;
            grad.push((2.0 * a * xg - c * b) / scale);
        }
        (f / scale, grad)
    }

    /// The UGR at levels x; None when no luminaire is in view or the background is black.
    pub fn ugr(&self, x: &[f64]) -> Option<f64> {
        let sum = self.a_fixed + self.a.iter().zip(x).map(|(a, x)| a * x * x).sum::<f64>();
        let lb = self.b_fixed + self.b.iter().zip(x).map(|(b, x)| b * x).sum::<f64>();
        (sum > 0.0 && lb > 0.0).then(|| 8.0 * (0.25 / lb * sum).log10())
    }
}

/// Most rounds of cutting planes before the optimizer gives up.
const MAX_CUT_ROUNDS: usize = 200;
/// The relative excess over the ceiling that counts as met: 10^(ΔUGR/8) − 1 ≤ 1e-5, so
/// ΔUGR ≤ 4e-5.
const CUT_TOLERANCE: f64 = 1e-5;

/// One grid's point values, lx: per free group at level 1, and the fixed part.
pub struct GridTerms {
    pub free: Vec<Vec<f64>>,
    pub fixed: Vec<f64>,
}

/// Why no levels were found.
#[derive(Debug, thiserror::Error)]
pub enum OptimizeError {
    #[error("{0}")]
    Unreachable(String),
    #[error("the LP solver failed: {0}")]
    Solver(String),
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Levels (one per free variable, in [0, 1]) minimising Σ flux_g·x_g subject to
/// `targets` over `terms` (one per target, same order) and every UGR ceiling in `glare`.
/// `choices` lists sets of variables of which at most one may be lit (the photometries
/// offered at one candidate position): each gets a binary "installed" y with x ≤ y and
/// Σ y ≤ 1 over the set, a mixed-integer program solved exactly by branch and bound.
pub fn optimize(
    flux: &[f64],
    targets: &[Target],
    terms: &[GridTerms],
    glare: &[(String, GlareModel)],
    choices: &[Vec<usize>],
) -> Result<Vec<f64>, OptimizeError> {
    // Tangent planes of the glare constraints: (gradient, right-hand side).
    let mut cuts: Vec<(Vec<f64>, f64)> = Vec::new();
    for _ in 0..MAX_CUT_ROUNDS {
        let x = match solve_lp(flux, targets, terms, &cuts, choices) {
            Ok(x) => x,
            Err(OptimizeError::Unreachable(_)) if !cuts.is_empty() => {
                return Err(OptimizeError::Unreachable(glare_unreachable(glare)))
            }
            Err(e) => return Err(e),
        };
        let mut cut = false;
        for (_, m) in glare {
            let (f, grad) = m.excess(&x);
            if f > CUT_TOLERANCE {
                // f(x*) + ∇f·(x − x*) ≤ 0  ⇔  ∇f·x ≤ ∇f·x* − f(x*).
                let rhs = grad.iter().zip(&x).map(|(g, x)| g * x).sum::<f64>() - f;
                cuts.push((grad, rhs));
                cut = true;
            }
        }
        if !cut {
            return Ok(x);
        }
    }
    Err(OptimizeError::Solver(format!(
        "the UGR ceiling did not converge in {MAX_CUT_ROUNDS} rounds"
    )))
}

/// Why a UGR ceiling cannot be honoured with the illuminance targets.
fn glare_unreachable(glare: &[(String, GlareModel)]) -> String {
    let ceilings: Vec<String> = glare
        .iter()
        .map(|(label, m)| format!("UGR ≤ {} at {label}", m.ugr_max))
        .collect();
    let mut unique = ceilings.clone();
    unique.dedup();
    format!(
        "the targets can be met, but not together with {}: every level that reaches the \
         illuminance makes the luminaires in view too bright against their background \
         (dimming all groups by k lowers UGR only by 8·log₁₀(1/k)); use luminaires with \
         a lower luminance or add indirect light",
        unique.join(", ")
    )
}

/// The LP of the illuminance targets plus the glare `cuts` (rows `g·x ≤ rhs`), and the
/// binary choices of `choices`.
fn solve_lp(
    flux: &[f64],
    targets: &[Target],
    terms: &[GridTerms],
    cuts: &[(Vec<f64>, f64)],
    choices: &[Vec<usize>],
) -> Result<Vec<f64>, OptimizeError> {
    let g = flux.len();
    let mut lp = Problem::new(OptimizationDirection::Minimize);
    // A tiny tie-break keeps the optimum unique when some groups emit nothing.
    let vars: Vec<_> = flux
        .iter()
        .map(|&f| lp.add_var(f.max(0.0) + 1e-9, (0.0, 1.0)))
        .collect();
    for (t, m) in targets.iter().zip(terms) {
        let avg_g: Vec<f64> = (0..g).map(|k| mean(&m.free[k])).collect();
        let avg_f = mean(&m.fixed);
        if let Some(e) = t.eavg_min {
            let expr: Vec<_> = (0..g).map(|k| (vars[k], avg_g[k])).collect();
            lp.add_constraint(expr, ComparisonOp::Ge, e - avg_f);
        }
        for i in 0..m.fixed.len() {
            if let Some(e) = t.emin_min {
                let expr: Vec<_> = (0..g).map(|k| (vars[k], m.free[k][i])).collect();
                lp.add_constraint(expr, ComparisonOp::Ge, e - m.fixed[i]);
            }
            if let Some(u) = t.u0_min {
                let expr: Vec<_> = (0..g)
                    .map(|k| (vars[k], m.free[k][i] - u * avg_g[k]))
                    .collect();
                lp.add_constraint(expr, ComparisonOp::Ge, u * avg_f - m.fixed[i]);
            }
        }
    }
    for (grad, rhs) in cuts {
        let expr: Vec<_> = (0..g).map(|k| (vars[k], grad[k])).collect();
        lp.add_constraint(expr, ComparisonOp::Le, *rhs);
    }
    for set in choices {
        let installed: Vec<_> = set
            .iter()
            .map(|&k| {
                let y = lp.add_binary_var(0.0);
                lp.add_constraint([(vars[k], 1.0), (y, -1.0)], ComparisonOp::Le, 0.0);
                (y, 1.0)
            })
            .collect();
        lp.add_constraint(installed, ComparisonOp::Le, 1.0);
    }
    match lp.solve() {
        Ok(microlp::SolveOutcome::Solution(s)) => {
            Ok(vars.iter().map(|&v| s[v].clamp(0.0, 1.0)).collect())
        }
        Ok(_) => Err(OptimizeError::Solver("interrupted".into())),
        Err(microlp::Error::Infeasible) => {
            Err(OptimizeError::Unreachable(explain(targets, terms, g)))
        }
        Err(e) => Err(OptimizeError::Solver(e.to_string())),
    }
}

/// A reason the targets cannot all be met: what full power reaches.
fn explain(targets: &[Target], terms: &[GridTerms], g: usize) -> String {
    let mut why = Vec::new();
    let mut ratios = Vec::new();
    for (t, m) in targets.iter().zip(terms) {
        let full: Vec<f64> = (0..m.fixed.len())
            .map(|i| m.fixed[i] + (0..g).map(|k| m.free[k][i]).sum::<f64>())
            .collect();
        let avg = mean(&full);
        let min = full.iter().copied().fold(f64::INFINITY, f64::min);
        if let Some(e) = t.eavg_min.filter(|&e| e > avg * (1.0 + 1e-9)) {
            why.push(format!(
                "{}: Eavg ≥ {e} lx is out of reach, every free group at 100 % gives {avg:.1} lx",
                t.grid
            ));
        }
        if let Some(e) = t.emin_min.filter(|&e| e > min * (1.0 + 1e-9)) {
            why.push(format!(
                "{}: Emin ≥ {e} lx is out of reach, every free group at 100 % gives {min:.1} lx",
                t.grid
            ));
        }
        if let Some(u) = t.u0_min {
            ratios.push(format!(
                "{}: U0 ≥ {u} (every free group at 100 % gives U0 = {:.3}; dimming changes the balance between groups, not the light's spread within one)",
                t.grid,
                if avg > 0.0 { min / avg } else { 0.0 }
            ));
        }
    }
    if why.is_empty() {
        why = ratios;
    }
    if why.is_empty() {
        "the targets cannot all be met at once".into()
    } else {
        format!("the targets cannot be met: {}", why.join("; "))
    }
}

/// Largest illuminance bound accepted, lx.
pub const MAX_TARGET_LUX: f64 = 1e6;

impl GridTarget {
    /// Checks the bounds; `at` names the target in messages (`targets[0]`).
    pub fn check(&self, at: &str) -> Result<(), QueryError> {
        let bad = |m: String| Err(QueryError::Invalid(m));
        for (key, v, max) in [
            ("eavg_min", self.eavg_min, MAX_TARGET_LUX),
            ("emin_min", self.emin_min, MAX_TARGET_LUX),
            ("u0_min", self.u0_min, 1.0),
        ] {
            if let Some(x) = v.filter(|x| !(0.0..=max).contains(x)) {
                return bad(format!("{at}.{key} = {x}: must be in 0..{max}"));
            }
        }
        if self.eavg_min.is_none()
            && self.emin_min.is_none()
            && self.u0_min.is_none()
            && self.ugr_max.is_none()
        {
            return bad(format!(
                "{at} sets no bound: give eavg_min, emin_min or u0_min"
            ));
        }
        if let Some(u) = self.ugr_max.filter(|u| !(5.0..=40.0).contains(u)) {
            return bad(format!("{at}.ugr_max = {u}: must be in 5..40"));
        }
        if self.ugr_max.is_some() && !(self.eavg_min > Some(0.0) || self.emin_min > Some(0.0)) {
            return bad(format!(
                "{at}: ugr_max needs a positive eavg_min or emin_min as well: with no light level asked, all lights off would use the least flux"
            ));
        }
        if self.u0_min.is_some() && !(self.eavg_min > Some(0.0) || self.emin_min > Some(0.0)) {
            return bad(format!(
                "{at}: u0_min needs a positive eavg_min or emin_min as well: a ratio alone sets no light level, and all lights off would use the least flux"
            ));
        }
        Ok(())
    }
}

/// A luminaire the optimizer may install: one photometry at one of the request's
/// candidate positions, at unit weight and in no group ([`Model::optimize_layout`]).
#[derive(Debug, Clone)]
pub struct Candidate {
    /// The index of its position among the request's: at most one per position is lit.
    pub position: usize,
    pub change: LuminaireChange,
}

/// A candidate the optimizer installs.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct InstalledAnswer {
    /// `c<position>_<photometry>`: the indices of its position and file in the request.
    pub id: String,
    /// m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub position: [f64; 3],
    /// Its photometric file.
    pub photometry: String,
    /// Its dimming level in (0, 1].
    pub level: f64,
    /// Luminous flux at that level, lm.
    pub lumens: f64,
    /// Electrical power at that level, W (dimming assumed proportional); null when its
    /// file gives none.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub watts: Option<f64>,
}

/// One group's level in an optimized state.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct LevelAnswer {
    /// Dimming factor (for free groups, the optimized level in [0, 1]).
    pub intensity: f64,
    /// The group's colour (its default).
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub color: Rgb,
    /// Whether the optimizer chose this level.
    pub free: bool,
}

/// What a grid achieves under the optimized levels (lux; U₀ a ratio).
#[derive(Debug, Clone, Copy, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Achieved {
    /// Eavg, lx.
    pub avg: f64,
    /// Emin, lx.
    pub min: f64,
    /// U₀ = Emin / Eavg; null when the grid is unlit (every point at 0 lx).
    #[cfg_attr(feature = "server", schema(required = true))]
    pub u0: Option<f64>,
    /// The highest UGR of the grid's task observers, when a ceiling was asked; null
    /// otherwise or when no luminaire is in view.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub ugr: Option<f64>,
}

/// One target with what the levels achieve.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct TargetAnswer {
    /// Grid id.
    pub grid: String,
    /// Least Eavg asked, lx; null when not asked.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub eavg_min: Option<f64>,
    /// Least Emin asked, lx; null when not asked.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub emin_min: Option<f64>,
    /// Least U₀ asked; null when not asked.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub u0_min: Option<f64>,
    /// Highest UGR asked; null when not asked.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub ugr_max: Option<f64>,
    #[cfg_attr(feature = "server", schema(inline))]
    pub achieved: Achieved,
    /// Whether `achieved` meets every bound.
    pub met: bool,
}

/// The optimizer's answer: the levels, flux, power and achieved statistics.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = OptimizeResponse))]
pub struct OptimizeAnswer {
    /// Every group's level, keyed by group id.
    #[cfg_attr(feature = "server", schema(inline))]
    pub lights: BTreeMap<String, LevelAnswer>,
    /// The candidates to install, with their levels (empty without candidates).
    pub installed: Vec<InstalledAnswer>,
    /// Total luminous flux of the state, lm.
    pub lumens: f64,
    pub power: LuminairePower,
    /// One per target, in request order.
    #[cfg_attr(feature = "server", schema(inline))]
    pub targets: Vec<TargetAnswer>,
    /// The targets' grids in the optimized state, by grid id.
    pub grids: BTreeMap<String, GridAnswer>,
    /// Time to build and solve the LP, ms.
    pub solve_ms: f64,
}

impl Model {
    /// Peak bytes of [`Model::optimize`] for these free groups and targets, with
    /// luminaires placed for the request when `placed` (a solve per part, kept).
    pub fn optimize_bytes(&self, free: usize, targets: &[GridTarget], placed: bool) -> u64 {
        let rows: u64 = targets
            .iter()
            .map(|t| self.grids[t.grid].len() as u64)
            .sum();
        let solves = if placed {
            (free as u64 + 2) * super::query::BYTES_PER_PATCH_ANSWER * self.patches() as u64
        } else {
            0
        };
        2 * rows * (free as u64 + 2) * 64 + (1 << 20) + solves
    }

    /// Levels of the `free` groups (the others keep `base`) that meet `targets` with the
    /// least flux. Groups and grids are given by index, each at most once. `changes` are
    /// luminaires placed, moved or removed for the request ([`Placed::changes`]): one in a
    /// free group dims with it, any other is held at its weight.
    pub fn optimize(
        &self,
        base: &[Rgb],
        changes: &[LuminaireChange],
        free: &[usize],
        targets: &[GridTarget],
    ) -> Result<OptimizeAnswer, QueryError> {
        self.optimize_layout(base, changes, free, targets, &[])
    }

    /// [`Model::optimize`] that also chooses which `candidates` to install and at what
    /// level: at most one photometry per candidate position, each installed one dimmed in
    /// [0, 1] like a free group (a mixed-integer program, solved exactly).
    pub fn optimize_layout(
        &self,
        base: &[Rgb],
        changes: &[LuminaireChange],
        free: &[usize],
        targets: &[GridTarget],
        candidates: &[Candidate],
    ) -> Result<OptimizeAnswer, QueryError> {
        let t0 = std::time::Instant::now();
        let scene = &self.baked.scene;
        let mut parts = Parts::new(self, base, changes, free)?;
        for c in candidates {
            let state = Placed {
                weights: vec![Rgb::ZERO; scene.lights.len()],
                changes: vec![c.change.clone()],
            };
            parts.free.push(Part::new(self, state)?);
        }
        let choices = choices_by_position(candidates, free.len());
        let terms: Vec<GridTerms> = targets
            .iter()
            .map(|t| {
                // Only the points the statistics measure constrain the levels.
                let gr = &self.grids[t.grid];
                let measured = |v: Vec<f64>| -> Vec<f64> {
                    v.into_iter()
                        .zip(&gr.excluded)
                        .filter(|(_, &x)| !x)
                        .map(|(v, _)| v)
                        .collect()
                };
                GridTerms {
                    free: parts
                        .free
                        .iter()
                        .map(|p| measured(self.part_values(t.grid, p)))
                        .collect(),
                    fixed: measured(self.part_values(t.grid, &parts.fixed)),
                }
            })
            .collect();
        let labelled: Vec<Target> = targets
            .iter()
            .map(|t| t.named(self.grids[t.grid].grid.id.clone()))
            .collect();
        let flux: Vec<f64> = parts.free.iter().map(|p| self.part_lumens(p)).collect();
        let glare = self.glare_models(&parts, targets)?;
        let levels = optimize(&flux, &labelled, &terms, &glare, &choices)?;
        let state = parts.at(&levels);
        let w = state.weights.clone();
        let solve_ms = t0.elapsed().as_secs_f64() * 1e3;
        let grid_ix: Vec<usize> = targets.iter().map(|t| t.grid).collect();
        let lit = if state.changes.is_empty() {
            Lighting::Groups(w.clone())
        } else {
            Lighting::Placed(state.clone())
        };
        let grids = match &lit {
            Lighting::Placed(_) => {
                let q = super::query::IlluminanceQuery {
                    grids: grid_ix,
                    ..Default::default()
                };
                self.illuminance(&lit, &q, &super::Cancel::default())?.grids
            }
            _ => self.grid_answers(&grid_ix, &w),
        };
        let mut answers = Vec::with_capacity(targets.len());
        for (t, gt) in labelled.iter().zip(targets) {
            // The achieved UGR, rated anew at the optimized state.
            let ugr = match t.ugr_max {
                Some(_) => self.worst_ugr(gt.grid, &lit)?,
                None => None,
            };
            answers.push(target_answer(t, &grids, ugr));
        }
        let (lumens, power) = match &lit {
            Lighting::Placed(p) => (self.lumens(&w) + p.flux().luminance(), p.power(scene)),
            _ => (self.lumens(&w), self.luminaire_power(&w)),
        };
        let installed = installed_answers(candidates, &levels[free.len()..]);
        Ok(OptimizeAnswer {
            lights: self.levels(&w, free, &levels[..free.len()]),
            installed,
            lumens,
            power,
            targets: answers,
            grids,
            solve_ms,
        })
    }

    /// Luminous illuminance (lx) at every point of grid `gi` under a part's state.
    fn part_values(&self, gi: usize, p: &Part) -> Vec<f64> {
        match &p.extra_b {
            None => self.grids[gi]
                .values(&p.state.weights)
                .iter()
                .map(|&v| v as f64)
                .collect(),
            Some(extra) => self
                .placed_grid_values(gi, &p.state, extra, &super::Cancel::default())
                .iter()
                .map(|&v| v as f64)
                .collect(),
        }
    }

    /// The luminous flux (lm) a part emits: its groups' and its changes'.
    fn part_lumens(&self, p: &Part) -> f64 {
        self.lumens(&p.state.weights) + p.state.flux().luminance()
    }

    /// The glare models of the targets' UGR ceilings, one per task observer: the fixed
    /// part as it is, each free part (a group at level 1 in its colour, with its changes).
    fn glare_models(
        &self,
        parts: &Parts,
        targets: &[GridTarget],
    ) -> Result<Vec<(String, GlareModel)>, QueryError> {
        let cancel = super::Cancel::default();
        let mut out = Vec::new();
        for t in targets {
            let Some(ugr_max) = t.ugr_max else { continue };
            let grid = &self.grids[t.grid].grid;
            let observers = super::compliance::task_observers(grid);
            let rate = |p: &Part| -> Result<Vec<(f64, f64)>, QueryError> {
                Ok(self
                    .glare(&observers, &p.lighting(), &cancel)?
                    .iter()
                    .map(|o| {
                        let sum = o.luminaires.iter().map(|l| l.term).sum::<f64>();
                        (sum, o.background_luminance)
                    })
                    .collect())
            };
            let fixed = rate(&parts.fixed)?;
            let mut per_group = Vec::with_capacity(parts.free.len());
            for p in &parts.free {
                per_group.push(rate(p)?);
            }
            for (k, &(a_fixed, b_fixed)) in fixed.iter().enumerate() {
                out.push((
                    grid.id.clone(),
                    GlareModel {
                        a: per_group.iter().map(|p| p[k].0).collect(),
                        a_fixed,
                        b: per_group.iter().map(|p| p[k].1).collect(),
                        b_fixed,
                        ugr_max,
                    },
                ));
            }
        }
        Ok(out)
    }

    /// The highest UGR of grid `gi`'s task observers under `lit`.
    fn worst_ugr(&self, gi: usize, lit: &Lighting) -> Result<Option<f64>, QueryError> {
        let rated = self.task_ugr(&self.grids[gi].grid, lit, &super::Cancel::default())?;
        Ok(super::compliance::highest(&rated))
    }

    /// Every group's level for weights `w`: free groups report their optimized level,
    /// fixed ones their luminous level relative to their default colour.
    fn levels(&self, w: &[Rgb], free: &[usize], levels: &[f64]) -> BTreeMap<String, LevelAnswer> {
        let scene = &self.baked.scene;
        scene
            .lights
            .iter()
            .enumerate()
            .map(|(g, l)| {
                let intensity = match free.iter().position(|&f| f == g) {
                    Some(k) => levels[k],
                    None => {
                        let y = l.color.luminance() as f64;
                        if y > 0.0 {
                            w[g].luminance() as f64 / y
                        } else {
                            0.0
                        }
                    }
                };
                let free = free.contains(&g);
                let answer = LevelAnswer {
                    intensity,
                    color: l.color,
                    free,
                };
                (l.id.clone(), answer)
            })
            .collect()
    }

    /// Total luminous flux of group weights `w`, lm.
    pub fn lumens(&self, w: &[Rgb]) -> f64 {
        w.iter()
            .zip(&self.groups)
            .map(|(wt, info)| wt.to_f64().luminance() * info.lumens)
            .sum()
    }
}

/// One linear part of an optimized state: the held part, or one free group at level 1 in
/// its colour with the request's changes of its luminaires.
struct Part {
    state: Placed,
    /// The changes' radiosity (lm/m², n × 3) when it has changes, solved once.
    extra_b: Option<Vec<f32>>,
}

impl Part {
    fn new(m: &Model, state: Placed) -> Result<Part, QueryError> {
        let extra_b = if state.changes.is_empty() {
            None
        } else {
            Some(m.placed_parts(&state)?.1)
        };
        Ok(Part { state, extra_b })
    }

    /// Its lighting state.
    fn lighting(&self) -> Lighting {
        if self.state.changes.is_empty() {
            Lighting::Groups(self.state.weights.clone())
        } else {
            Lighting::Placed(self.state.clone())
        }
    }
}

/// The candidates lit at `levels` (one per candidate), with their levels, lumens and watts.
fn installed_answers(candidates: &[Candidate], levels: &[f64]) -> Vec<InstalledAnswer> {
    candidates
        .iter()
        .zip(levels)
        .filter(|(_, &x)| x > 1e-9)
        .map(|(c, &x)| {
            let l = &c.change.luminaire;
            InstalledAnswer {
                id: l.id.clone(),
                position: l.position.to_array(),
                photometry: c.change.photometry.clone().unwrap_or_default(),
                level: x,
                lumens: l.lumens * x,
                watts: l.watts.map(|w| w * x),
            }
        })
        .collect()
}

/// The sets of variables of which at most one may be lit: the candidates of each position
/// (variables numbered after the `groups` free groups).
fn choices_by_position(candidates: &[Candidate], groups: usize) -> Vec<Vec<usize>> {
    let mut choices: Vec<Vec<usize>> = Vec::new();
    for (k, c) in candidates.iter().enumerate() {
        match choices
            .iter_mut()
            .find(|set| candidates[set[0] - groups].position == c.position)
        {
            Some(set) => set.push(groups + k),
            None => choices.push(vec![groups + k]),
        }
    }
    choices
}

/// A state split into its held part and one part per free group: the state at levels x is
/// `fixed + Σ_g x_g free_g`.
struct Parts {
    fixed: Part,
    free: Vec<Part>,
}

impl Parts {
    fn new(
        m: &Model,
        base: &[Rgb],
        changes: &[LuminaireChange],
        free: &[usize],
    ) -> Result<Parts, QueryError> {
        let lights = &m.baked.scene.lights;
        let is_free = |g: Option<usize>| g.is_some_and(|g| free.contains(&g));
        // Fixed groups keep the given state; free ones are 0 in the fixed part.
        let fixed = Placed {
            weights: (0..lights.len())
                .map(|g| if is_free(Some(g)) { Rgb::ZERO } else { base[g] })
                .collect(),
            changes: changes
                .iter()
                .filter(|c| !is_free(c.group))
                .cloned()
                .collect(),
        };
        let free = free
            .iter()
            .map(|&g| {
                let color = lights[g].color;
                let mut weights = vec![Rgb::ZERO; lights.len()];
                weights[g] = color;
                let changes = changes
                    .iter()
                    .filter(|c| c.group == Some(g))
                    .map(|c| LuminaireChange {
                        weight: color * if c.taken_out { -1.0 } else { 1.0 },
                        ..c.clone()
                    })
                    .collect();
                Part::new(m, Placed { weights, changes })
            })
            .collect::<Result<_, _>>()?;
        Ok(Parts {
            fixed: Part::new(m, fixed)?,
            free,
        })
    }
    /// The state at `levels` (one per free part): `fixed + Σ x · free`, each change of a
    /// part at its weight times the part's level (none from a part left at 0).
    fn at(&self, levels: &[f64]) -> Placed {
        let mut state = self.fixed.state.clone();
        for (p, &x) in self.free.iter().zip(levels) {
            for (w, wg) in state.weights.iter_mut().zip(&p.state.weights) {
                *w += *wg * x as f32;
            }
            if x > 1e-9 {
                state
                    .changes
                    .extend(p.state.changes.iter().map(|c| LuminaireChange {
                        weight: c.weight * x as f32,
                        ..c.clone()
                    }));
            }
        }
        state
    }
}

fn target_answer(
    t: &Target,
    grids: &BTreeMap<String, GridAnswer>,
    ugr: Option<f64>,
) -> TargetAnswer {
    let (avg, min, u0) = grids
        .get(&t.grid)
        .map_or((0.0, 0.0, None), |s| (s.avg, s.min, s.u0));
    let tol = 1e-6;
    let met = t.eavg_min.is_none_or(|e| avg >= e * (1.0 - tol))
        && t.emin_min.is_none_or(|e| min >= e * (1.0 - tol))
        && t.u0_min.is_none_or(|u| u0.is_some_and(|u0| u0 >= u - tol))
        && t.ugr_max.is_none_or(|u| ugr.is_none_or(|g| g <= u + 1e-3));
    TargetAnswer {
        grid: t.grid.clone(),
        eavg_min: t.eavg_min,
        emin_min: t.emin_min,
        u0_min: t.u0_min,
        ugr_max: t.ugr_max,
        achieved: Achieved { avg, min, u0, ugr },
        met,
    }
}
