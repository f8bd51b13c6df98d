//! Answers to a few emission columns by GMRES: the balance the sweeps solve,
//! `B − ρH(B) = S` with `H = σ K B` through the links, in fewer passes over the links.
//!
//! The sweeps (Jacobi) shrink the error by about ρ_max per pass, 19–25 passes to 10⁻⁶ on
//! office-floor. The operator `I − ρH` has its spectrum near the real interval
//! `[1 − ρ_max, 1 + |λ_min|]`, where a Krylov method converges at
//! `(√κ − 1)/(√κ + 1)` per pass. Each column keeps its own Arnoldi basis, and one pass
//! over the links serves every column at once. The basis and its images `H(V_k)` are
//! kept, so the answer's irradiance costs no further pass.

use rayon::prelude::*;

use super::sweeps::HierarchySolution;
use super::Hierarchy;
use crate::color::Rgb;

/// Most bytes of a GMRES workspace (the basis and its images, n × c floats each). Above
/// it, [`Hierarchy::solve_krylov`] restarts after fewer steps.
pub const KRYLOV_BYTES: u64 = 256 << 20;
/// Most steps between restarts.
const MAX_BASIS: usize = 40;
/// Fewest steps between restarts worth the workspace; callers use the sweeps when the
/// workspace would allow fewer ([`Hierarchy::krylov_fits`]).
const MIN_BASIS: usize = 8;

/// An approximate inverse of `I − ρH` for [`Hierarchy::solve_krylov_with`]: n × c in,
/// n × c out.
pub type Preconditioner<'a> = dyn Fn(&[f32]) -> Vec<f32> + Sync + 'a;

impl Hierarchy {
    /// Steps between restarts that [`KRYLOV_BYTES`] allows for `c` columns.
    fn krylov_basis(&self, c: usize) -> usize {
        let per_step = 2 * 4 * (self.n * c) as u64;
        ((KRYLOV_BYTES / per_step.max(1)) as usize)
            .saturating_sub(1)
            .min(MAX_BASIS)
    }

    /// Whether `c` columns fit a GMRES workspace of at least [`MIN_BASIS`] steps.
    pub fn krylov_fits(&self, c: usize) -> bool {
        self.krylov_basis(c) >= MIN_BASIS
    }

    /// `H(x)` (n × c) into `h`, with `nodes` as the pull's working buffer.
    fn irradiance_into(&self, x: &[f32], c: usize, nodes: &mut Vec<f32>, h: &mut Vec<f32>) {
        nodes.clear();
        nodes.resize(self.nodes() * c, 0.0);
        nodes[..self.n * c].copy_from_slice(&x[..self.n * c]);
        self.pull(nodes, c);
        self.gather_into(nodes, c, h);
        h.truncate(self.n * c);
    }

    /// Solves `B = S + ρH(B)` for `c` columns of sources `s` (n × c row-major, lm/m²;
    /// column j uses the reflectance channel j % 3) by restarted GMRES on the reflected
    /// radiosity `y = B − S`, which solves `y − ρH(y) = ρH(S)`: the emission is exact, so
    /// a bright emitter does not set the scale of what is left.
    ///
    /// It stops when one pass changes no patch's y by more than `tol` of its own value
    /// (values under [`FLOOR`] of the column's largest are held to the floor), or after
    /// `max_passes` passes over the links. The change is judged per patch because light
    /// that reaches a room through doors converges last and is a small part of any
    /// global norm. `sweeps` in the answer counts the passes (the first is `H(S)`).
    pub fn solve_krylov(
        &self,
        rho: &[Rgb],
        s: &[f32],
        c: usize,
        tol: f64,
        max_passes: usize,
    ) -> HierarchySolution {
        self.solve_krylov_with(rho, s, c, tol, max_passes, None)
    }

    /// [`Hierarchy::solve_krylov`] with a right preconditioner `pre`, an approximate
    /// inverse of `I − ρH` (n × c in, n × c out): GMRES on `(I − ρH) pre` in the
    /// preconditioned basis.
    pub fn solve_krylov_with(
        &self,
        rho: &[Rgb],
        s: &[f32],
        c: usize,
        tol: f64,
        max_passes: usize,
        pre: Option<&Preconditioner<'_>>,
    ) -> HierarchySolution {
        let n = self.n;
        let len = n * c;
        let basis = self.krylov_basis(c).max(1);
        let rho_of = |i: usize, j: usize| rho[i][j % 3];
        let norms = |v: &[f32]| -> Vec<f64> { dots(v, v, c).into_iter().map(f64::sqrt).collect() };
        let mut nodes = Vec::new();
        let mut h0 = Vec::new();
        self.irradiance_into(s, c, &mut nodes, &mut h0);
        let mut passes = 1;
        let y0: Vec<f32> = h0
            .par_chunks(c)
            .enumerate()
            .flat_map_iter(|(i, h)| (0..c).map(move |j| rho_of(i, j) * h[j]))
            .collect();
        // y and H(y) so far (zero at first), and the residual of y.
        let mut y = vec![0f32; len];
        let mut hy = vec![0f32; len];
        let mut r = y0.clone();
        let mut last = y.clone();
        let mut converged = false;
        while !converged && passes < max_passes {
            let beta = norms(&r);
            if beta.iter().all(|&b| b == 0.0) {
                break;
            }
            // Arnoldi with modified Gram–Schmidt, per column; Givens rotations keep the
            // least-squares problem triangular.
            let mut v: Vec<Vec<f32>> = vec![scaled(&r, &beta, c)];
            // The preconditioned basis (v itself without a preconditioner) and its images.
            let mut pv: Vec<Vec<f32>> = Vec::new();
            let mut hv: Vec<Vec<f32>> = Vec::new();
            let mut hess: Vec<Vec<f64>> = Vec::new(); // hess[k][i * c + j]
            let mut rot: Vec<Vec<(f64, f64)>> = Vec::new(); // rot[k][j]
            let mut g: Vec<f64> = beta.clone(); // g[k * c + j]
            let mut coef = Vec::new();
            while v.len() > hv.len() && hv.len() < basis && passes < max_passes {
                let k = hv.len();
                let mut hk = Vec::new();
                let pk = match pre {
                    Some(f) => f(&v[k]),
                    None => v[k].clone(),
                };
                self.irradiance_into(&pk, c, &mut nodes, &mut hk);
                passes += 1;
                // w = A p_k = p_k − ρ H(p_k).
                let mut w: Vec<f32> = pk
                    .par_chunks(c)
                    .zip(hk.par_chunks(c))
                    .enumerate()
                    .flat_map_iter(|(i, (vk, hk))| {
                        (0..c).map(move |j| vk[j] - rho_of(i, j) * hk[j])
                    })
                    .collect();
                hv.push(hk);
                pv.push(pk);
                let (mut col, wn) = orthogonalize(&mut w, &v, c);
                rot.push(givens(&mut col, &rot, &mut g, k, c));
                hess.push(col);
                // The iterate after this pass, and its change since the last.
                coef = back_substitute(&hess, &g, c);
                let mut now = y.clone();
                for (vi, ci) in pv.iter().zip(coef.chunks_exact(c)) {
                    axpy(&mut now, vi, ci, c);
                }
                converged = passes >= 3 && settled(&now, &last, tol, c);
                last = now;
                if converged || wn.iter().all(|&x| x == 0.0) {
                    converged = true;
                    break;
                }
                let inv: Vec<f64> = wn
                    .iter()
                    .map(|&x| if x > 0.0 { 1.0 / x } else { 0.0 })
                    .collect();
                scale_in_place(&mut w, &inv, c);
                v.push(w);
            }
            y.clone_from(&last);
            for (hk, ci) in hv.iter().zip(coef.chunks_exact(c)) {
                axpy(&mut hy, hk, ci, c);
            }
            // The residual of the new y, without a pass: y₀ − y + ρ H(y).
            r = y
                .par_chunks(c)
                .zip(hy.par_chunks(c))
                .zip(y0.par_chunks(c))
                .enumerate()
                .flat_map_iter(|(i, ((y, hy), y0))| {
                    (0..c).map(move |j| y0[j] - y[j] + rho_of(i, j) * hy[j])
                })
                .collect();
        }
        // B = S + y, H = H(S) + H(y).
        let b: Vec<f32> = y.iter().zip(&s[..len]).map(|(y, s)| y + s).collect();
        let h: Vec<f32> = hy.iter().zip(&h0).map(|(a, b)| a + b).collect();
        let residual = sweeps_residual(&b, s, &h, rho, c);
        HierarchySolution {
            b,
            h,
            sweeps: passes,
            residual,
        }
    }
}

/// Fraction of a column's largest value under which a patch's change is judged against
/// the floor rather than its own value: light a millionth of the brightest is dark. (At
/// 10⁻⁹ the answer to one emitting patch on office-floor took 17 passes instead of 13;
/// its dimmest surfaces, at 10⁻⁸, were then within 0.08 % instead of 2.8 %.) A source
/// of both signs (light moved: taken out here, put in there) needs no special case: a
/// patch where the two cancel is held to the floor.
pub const FLOOR: f64 = 1e-6;

/// Whether `now` differs from `last` at no patch by more than `tol` of its value (or of
/// [`FLOOR`] of the column's largest), per column.
fn settled(now: &[f32], last: &[f32], tol: f64, c: usize) -> bool {
    let top = now
        .par_chunks(c * 1024)
        .map(|rows| {
            let mut t = vec![0f32; c];
            for row in rows.chunks_exact(c) {
                for j in 0..c {
                    t[j] = t[j].max(row[j].abs());
                }
            }
            t
        })
        .reduce(
            || vec![0f32; c],
            |a, b| a.iter().zip(&b).map(|(x, y)| x.max(*y)).collect(),
        );
    let floor: Vec<f32> = top.iter().map(|&t| (FLOOR * t as f64) as f32).collect();
    now.par_chunks(c).zip(last.par_chunks(c)).all(|(a, b)| {
        (0..c).all(|j| ((a[j] - b[j]).abs() as f64) <= tol * a[j].abs().max(floor[j]) as f64)
    })
}

/// The least-squares coefficients `R⁻¹ g` per column (row k · c + j).
fn back_substitute(hess: &[Vec<f64>], g: &[f64], c: usize) -> Vec<f64> {
    let steps = hess.len();
    let mut y = vec![0f64; steps * c];
    for j in 0..c {
        for i in (0..steps).rev() {
            let mut acc = g[i * c + j];
            for k in i + 1..steps {
                acc -= hess[k][i * c + j] * y[k * c + j];
            }
            let d = hess[i][i * c + j];
            y[i * c + j] = if d != 0.0 { acc / d } else { 0.0 };
        }
    }
    y
}

/// Modified Gram–Schmidt of `w` against the basis `v`, per column: the Hessenberg
/// column (v.len() + 1 rows × c, the last row `‖w‖`) and `‖w‖` per column.
fn orthogonalize(w: &mut [f32], v: &[Vec<f32>], c: usize) -> (Vec<f64>, Vec<f64>) {
    let k = v.len() - 1;
    let mut col = vec![0f64; (k + 2) * c];
    for (i, vi) in v.iter().enumerate() {
        let d = dots(w, vi, c);
        axpy_neg(w, vi, &d, c);
        col[i * c..(i + 1) * c].copy_from_slice(&d);
    }
    let wn: Vec<f64> = dots(w, w, c).into_iter().map(f64::sqrt).collect();
    col[(k + 1) * c..].copy_from_slice(&wn);
    (col, wn)
}

/// Applies the earlier rotations `rot` to Hessenberg column `k` (`col`), per column, and
/// returns the rotation that zeroes its subdiagonal, applied to `g` as well (which then
/// holds the least-squares residual at row k + 1).
fn givens(
    col: &mut [f64],
    rot: &[Vec<(f64, f64)>],
    g: &mut Vec<f64>,
    k: usize,
    c: usize,
) -> Vec<(f64, f64)> {
    let mut rk = vec![(1f64, 0f64); c];
    g.resize((k + 2) * c, 0.0);
    for j in 0..c {
        for (i, ri) in rot.iter().enumerate() {
            let (cs, sn) = ri[j];
            let (a, b) = (col[i * c + j], col[(i + 1) * c + j]);
            col[i * c + j] = cs * a + sn * b;
            col[(i + 1) * c + j] = -sn * a + cs * b;
        }
        let (a, b) = (col[k * c + j], col[(k + 1) * c + j]);
        let d = a.hypot(b);
        let (cs, sn) = if d > 0.0 { (a / d, b / d) } else { (1.0, 0.0) };
        rk[j] = (cs, sn);
        col[k * c + j] = d;
        col[(k + 1) * c + j] = 0.0;
        let gk = g[k * c + j];
        g[k * c + j] = cs * gk;
        g[(k + 1) * c + j] = -sn * gk;
    }
    rk
}

/// Per column, `Σ a·b` (f64).
fn dots(a: &[f32], b: &[f32], c: usize) -> Vec<f64> {
    a.par_chunks(c * 1024)
        .zip(b.par_chunks(c * 1024))
        .map(|(a, b)| {
            let mut d = vec![0f64; c];
            for (ra, rb) in a.chunks_exact(c).zip(b.chunks_exact(c)) {
                for j in 0..c {
                    d[j] += ra[j] as f64 * rb[j] as f64;
                }
            }
            d
        })
        .reduce(
            || vec![0f64; c],
            |mut x, y| {
                x.iter_mut().zip(y).for_each(|(a, b)| *a += b);
                x
            },
        )
}

/// `y += a ⊙ x` per column.
fn axpy(y: &mut [f32], x: &[f32], a: &[f64], c: usize) {
    let a: Vec<f32> = a.iter().map(|&v| v as f32).collect();
    y.par_chunks_mut(c)
        .zip(x.par_chunks(c))
        .for_each(|(y, x)| (0..c).for_each(|j| y[j] += a[j] * x[j]));
}

/// `y −= a ⊙ x` per column.
fn axpy_neg(y: &mut [f32], x: &[f32], a: &[f64], c: usize) {
    let neg: Vec<f64> = a.iter().map(|v| -v).collect();
    axpy(y, x, &neg, c);
}

fn scale_in_place(v: &mut [f32], a: &[f64], c: usize) {
    let a: Vec<f32> = a.iter().map(|&v| v as f32).collect();
    v.par_chunks_mut(c)
        .for_each(|row| (0..c).for_each(|j| row[j] *= a[j]));
}

/// `r / β` per column (a zero column stays zero).
fn scaled(r: &[f32], beta: &[f64], c: usize) -> Vec<f32> {
    let mut v = r.to_vec();
    let inv: Vec<f64> = beta
        .iter()
        .map(|&b| if b > 0.0 { 1.0 / b } else { 0.0 })
        .collect();
    scale_in_place(&mut v, &inv, c);
    v
}

use super::sweeps::residual as sweeps_residual;
