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

use microlp::{ComparisonOp, OptimizationDirection, Problem};

/// A target on one grid, lux or ratio bounds.
#[derive(Debug, Clone, Default)]
pub struct Target {
    /// Label for messages (the grid id).
    pub grid: String,
    pub eavg_min: Option<f64>,
    pub emin_min: Option<f64>,
    pub u0_min: Option<f64>,
}

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

/// Levels (one per free group, in [0, 1]) minimising Σ flux_g·x_g subject to `targets`
/// over `terms` (one per target, same order).
pub fn optimize(
    flux: &[f64],
    targets: &[Target],
    terms: &[GridTerms],
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
