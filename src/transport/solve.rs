//! Dense linear algebra for the radiosity system `(I − R F) B = E`, per colour channel.
//!
//! Storage convention: `F` is row-major (`F[i*n + j] = F_ij`). A row-major matrix is the
//! column-major storage of its transpose, so we hand faer `Aᵀ` (column-major) without
//! copying rows around, factor `P Aᵀ = L U`, and solve `A x = b` with faer's transpose
//! solve. The LU is f32 (the system is strictly diagonally dominant, condition number at
//! most (1 + ρ_max)/(1 − ρ_max)); bake-time solves add one step of iterative refinement
//! and report the final relative residual.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve as lusolve};
use faer::perm::PermRef;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// An LU factorization of `Aᵀ = (I − diag(ρ) F)ᵀ` for one reflectance channel.
#[derive(Clone)]
pub struct ChannelLu {
    /// Column-major n×n L\U factors of Aᵀ.
    pub lu: Mat<f32>,
    pub perm: Vec<usize>,
    pub perm_inv: Vec<usize>,
}

fn par() -> Par {
    Par::rayon(0)
}

/// Builds `(I − diag(rho) F)ᵀ` in column-major form: column j is row j of the system.
pub fn system_transposed(f: &[f32], rho: &[f32], n: usize) -> Mat<f32> {
    let mut m = Mat::<f32>::zeros(n, n);
    for j in 0..n {
        let col = m.col_as_slice_mut(j);
        let row = &f[j * n..(j + 1) * n];
        let r = rho[j];
        for (k, (c, &fv)) in col.iter_mut().zip(row).enumerate() {
            *c = if k == j { 1.0 } else { 0.0 } - r * fv;
        }
    }
    m
}

/// Factors the square `a` in place as `P a = L U` (partial pivoting, L\U stored in `a`);
/// returns the row permutation and its inverse.
fn lu_in_place(a: &mut Mat<f32>) -> (Vec<usize>, Vec<usize>) {
    let n = a.nrows();
    let mut perm = vec![0usize; n];
    let mut perm_inv = vec![0usize; n];
    let mut mem = MemBuffer::new(factor::lu_in_place_scratch::<usize, f32>(
        n,
        n,
        par(),
        Default::default(),
    ));
    factor::lu_in_place(
        a.as_mut(),
        &mut perm,
        &mut perm_inv,
        par(),
        MemStack::new(&mut mem),
        Default::default(),
    );
    (perm, perm_inv)
}

impl ChannelLu {
    /// Factors the system for reflectances `rho` (one per patch).
    pub fn factor(f: &[f32], rho: &[f32], n: usize) -> ChannelLu {
        let mut lu = system_transposed(f, rho, n);
        let (perm, perm_inv) = lu_in_place(&mut lu);
        ChannelLu { lu, perm, perm_inv }
    }

    /// Rebuilds a factorization from stored parts (see [`crate::bake::cache`]).
    pub fn from_parts(n: usize, cols: &[f32], perm: Vec<usize>) -> Option<ChannelLu> {
        if cols.len() != n * n || perm.len() != n {
            return None;
        }
        let mut lu = Mat::<f32>::zeros(n, n);
        for j in 0..n {
            lu.col_as_slice_mut(j)
                .copy_from_slice(&cols[j * n..(j + 1) * n]);
        }
        Self::from_lu(lu, perm)
    }

    /// A factorization from its n×n L\U matrix and row permutation; None when the
    /// permutation is not one of 0..n or the matrix is not square of that size.
    pub fn from_lu(lu: Mat<f32>, perm: Vec<usize>) -> Option<ChannelLu> {
        let n = perm.len();
        if lu.nrows() != n || lu.ncols() != n {
            return None;
        }
        let mut perm_inv = vec![usize::MAX; n];
        for (i, &p) in perm.iter().enumerate() {
            if p >= n || perm_inv[p] != usize::MAX {
                return None;
            }
            perm_inv[p] = i;
        }
        Some(ChannelLu { lu, perm, perm_inv })
    }

    /// The factors, column by column (for storage).
    pub fn columns(&self) -> Vec<f32> {
        let n = self.lu.nrows();
        let mut out = Vec::with_capacity(n * n);
        for j in 0..n {
            out.extend_from_slice(self.lu.col_as_slice(j));
        }
        out
    }

    /// Solves `(I − R F) X = RHS` in place for every column of `rhs`.
    pub fn solve_in_place(&self, rhs: MatMut<'_, f32>) {
        let n = self.lu.nrows();
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let mut mem = MemBuffer::new(lusolve::solve_transpose_in_place_scratch::<usize, f32>(
            n,
            rhs.ncols(),
            par(),
        ));
        lusolve::solve_transpose_in_place(
            self.lu.as_ref(),
            self.lu.as_ref(),
            perm,
            rhs,
            par(),
            MemStack::new(&mut mem),
        );
    }
}

impl ChannelLu {
    /// The channel's irradiance response `K = F (I − ρF)⁻¹`, as `Kᵀ` column-major (which
    /// is `K` row-major): `K_ij` at `(j, i)`. `K_ij` is the illuminance (lux) patch i
    /// gathers per lm/m² that patch j emits, every interreflection included, so any
    /// emission `E` gives `H = K E` and `B = E + ρ H` by one product.
    ///
    /// One multi-right-hand-side solve: the factorization is of `M = (I − ρF)ᵀ`, and
    /// `Kᵀ = M⁻¹ Fᵀ`, where `Fᵀ` column-major is the row-major `f` as it is.
    pub fn irradiance_response(&self, f: &[f32]) -> Mat<f32> {
        let n = self.lu.nrows();
        let mut kt = MatRef::from_column_major_slice(f, n, n).to_owned();
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let mut mem = MemBuffer::new(lusolve::solve_in_place_scratch::<usize, f32>(n, n, par()));
        lusolve::solve_in_place(
            self.lu.as_ref(),
            self.lu.as_ref(),
            perm,
            kt.as_mut(),
            par(),
            MemStack::new(&mut mem),
        );
        kt
    }
}

/// Solves `A X = RHS` in place for a general square `a` (column-major), by LU with
/// partial pivoting.
pub fn solve_general_in_place(mut a: Mat<f32>, rhs: MatMut<'_, f32>) {
    let n = a.nrows();
    let (perm, perm_inv) = lu_in_place(&mut a);
    let p = PermRef::new_checked(&perm, &perm_inv, n);
    let mut mem = MemBuffer::new(lusolve::solve_in_place_scratch::<usize, f32>(
        n,
        rhs.ncols(),
        par(),
    ));
    lusolve::solve_in_place(
        a.as_ref(),
        a.as_ref(),
        p,
        rhs,
        par(),
        MemStack::new(&mut mem),
    );
}

/// The irradiance response of reflectances `rho` from `kt`, the response `Kᵀ` of
/// reflectances `rho0` (both as [`ChannelLu::irradiance_response`] stores them), where
/// the two differ on the patches `d` only (k of them): a rank-k update, in O(n² k)
/// instead of the O(n³) of a factorization and a solve.
///
/// With `Δ = diag(ρ − ρ₀)` on `d`, `I − ρF = (I − ρ₀F) − Δ F`, and Woodbury's identity
/// gives `K = K₀ + K₀[:, d] Δ W⁻¹ K₀[d, :]` with `W = I − K₀[d, d] Δ` (k × k). Stored
/// transposed: `Kᵀ = K₀ᵀ + K₀ᵀ[:, d] Z`, where `Wᵀ Z = Δ K₀ᵀ[d, :]` and
/// `Wᵀ = I − Δ K₀ᵀ[d, d]`.
pub fn updated_response(kt: &Mat<f32>, rho0: &[f32], rho: &[f32], d: &[usize]) -> Mat<f32> {
    let n = kt.nrows();
    let k = d.len();
    let delta: Vec<f32> = d.iter().map(|&i| rho[i] - rho0[i]).collect();
    // Wᵀ = I − Δ K₀ᵀ[d, d], and R = Δ K₀ᵀ[d, :] (k × n), which the solve turns into Z.
    let mut wt = Mat::<f32>::zeros(k, k);
    for (b, &j) in d.iter().enumerate() {
        for (a, &i) in d.iter().enumerate() {
            wt[(a, b)] = if a == b { 1.0 } else { 0.0 } - delta[a] * kt[(i, j)];
        }
    }
    let mut z = Mat::<f32>::zeros(k, n);
    for j in 0..n {
        let src = kt.col_as_slice(j);
        for (a, &i) in d.iter().enumerate() {
            z[(a, j)] = delta[a] * src[i];
        }
    }
    solve_general_in_place(wt, z.as_mut());
    // Kᵀ = K₀ᵀ + K₀ᵀ[:, d] Z.
    let mut cols = Mat::<f32>::zeros(n, k);
    for (b, &j) in d.iter().enumerate() {
        cols.col_mut(b).copy_from(kt.col(j));
    }
    let mut out = kt.clone();
    faer::linalg::matmul::matmul(
        out.as_mut(),
        Accum::Add,
        cols.as_ref(),
        z.as_ref(),
        1.0,
        par(),
    );
    out
}

/// `F · X` for row-major `f` (n×n) and column-major `x` (n×k).
pub fn apply_f(f: &[f32], n: usize, x: MatRef<'_, f32>) -> Mat<f32> {
    let fm = MatRef::from_row_major_slice(f, n, n);
    let mut out = Mat::<f32>::zeros(n, x.ncols());
    faer::linalg::matmul::matmul(out.as_mut(), Accum::Replace, fm, x, 1.0, par());
    out
}

/// Residual `‖E − (B − R F B)‖∞ / ‖E‖∞` of one channel's solution.
pub fn relative_residual(e: &[f32], b: &[f32], fb: &[f32], rho: &[f32]) -> f64 {
    let mut num = 0f64;
    let mut den = 0f64;
    for i in 0..e.len() {
        let r = e[i] as f64 - (b[i] as f64 - rho[i] as f64 * fb[i] as f64);
        num = num.max(r.abs());
        den = den.max(e[i].abs() as f64);
    }
    if den == 0.0 {
        0.0
    } else {
        num / den
    }
}

/// Jacobi iteration `B ← E + R F B` for all columns of `e` at once, with per-column
/// reflectance vectors (`rho_of_col[k]` is the ρ vector for column k), until the largest
/// change is below `tol` times the largest value. Returns the solution and the sweeps.
pub fn jacobi(
    f: &[f32],
    n: usize,
    e: MatRef<'_, f32>,
    rho_of_col: &[&[f32]],
    tol: f64,
    max_sweeps: usize,
    progress: &(dyn Fn(f64) + Sync),
) -> (Mat<f32>, usize) {
    let k = e.ncols();
    let mut b = e.to_owned();
    let mut sweeps = 0;
    for s in 0..max_sweeps {
        sweeps = s + 1;
        let fb = apply_f(f, n, b.as_ref());
        let mut max_change = 0f64;
        let mut max_val = 0f64;
        for c in 0..k {
            let rho = rho_of_col[c];
            let (ec, fbc) = (e.col(c), fb.col(c));
            for i in 0..n {
                let nv = ec[i] + rho[i] * fbc[i];
                max_change = max_change.max((nv - b[(i, c)]).abs() as f64);
                max_val = max_val.max(nv.abs() as f64);
                b[(i, c)] = nv;
            }
        }
        progress((s as f64 / 60.0).min(0.99));
        if max_change <= tol * max_val {
            break;
        }
    }
    (b, sweeps)
}

/// Scatters per-column results `x[(i, c)]` for channel c into an interleaved n×3 vector.
pub fn interleave(x: MatRef<'_, f32>, cols: [usize; 3]) -> Vec<f32> {
    let n = x.nrows();
    let mut out = vec![0f32; 3 * n];
    out.par_chunks_mut(3).enumerate().for_each(|(i, o)| {
        for c in 0..3 {
            o[c] = x[(i, cols[c])];
        }
    });
    out
}
