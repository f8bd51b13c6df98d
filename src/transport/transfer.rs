//! The baked transfer: everything needed to relight a scene, immutable once built.
//!
//! Three modes:
//! - **factored**: an LU factorization of `(I − ρF)` per distinct reflectance channel,
//!   plus `F` itself. Any per-patch emission vector is solved exactly
//!   ([`Transfer::solve`]); light groups are served from precomputed columns as well.
//! - **columns**: only the response columns of the light groups (from Jacobi iteration to
//!   a relative tolerance of [`COLUMN_TOL`]); `F` is not kept.
//! - **hierarchical**: no n × n matrix at all. The form factors are links of a cluster
//!   hierarchy ([`crate::transport::hierarchy`]), about linear in n; the group columns are
//!   solved by gather/push/pull sweeps to [`HIERARCHY_TOL`], and a per-patch emission is
//!   solved on demand the same way.
//!
//! In every mode every light group g has three interleaved RGB columns (n × 3 floats),
//! computed for the group at intensity 1 and colour (1, 1, 1):
//! `e_g` its emission (lm/m²), `b_g` the radiosity it causes (lm/m²) and `h_g` the
//! incident illuminance it causes (lux). A lighting state with per-group RGB weights
//! `w_g` gives `B = Σ_g w_g ⊙ b_g`, and likewise for H and E: relighting is linear.

use faer::Mat;
use serde::Serialize;

use crate::color::Rgb;
use crate::geometry::mesh::Mesh;
use crate::scene::{Scene, TransferChoice};
use crate::transport::hierarchy::Hierarchy;
use crate::transport::solve::{self, ChannelLu};

/// Relative tolerance of the iterative column solver.
pub const COLUMN_TOL: f64 = 1e-7;
/// Largest patch count for which `auto` picks the factored mode.
pub const AUTO_FACTORED_MAX: usize = 6000;
/// Largest patch count for which `auto` picks the columns mode; above it, hierarchical.
pub const AUTO_COLUMNS_MAX: usize = 15_000;
/// Relative tolerance of the hierarchical sweeps (per column, the largest change over the
/// largest reflected radiosity).
pub const HIERARCHY_TOL: f64 = 1e-6;
/// Most sweeps of a hierarchical solve (the error shrinks by ρ_max per sweep).
pub const HIERARCHY_MAX_SWEEPS: usize = 1000;

/// How a transfer is kept: `factored` (LU factors: any per-patch emission is solved
/// exactly) or `columns` (the light groups' response columns only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum TransferMode {
    Factored,
    Columns,
    Hierarchical,
}

impl TransferMode {
    /// The lowercase name used in scene.toml, the CLI and the API.
    pub fn name(self) -> &'static str {
        match self {
            TransferMode::Factored => "factored",
            TransferMode::Columns => "columns",
            TransferMode::Hierarchical => "hierarchical",
        }
    }

    /// Resolves a scene's choice for `n` patches.
    pub fn resolve(choice: TransferChoice, n: usize) -> TransferMode {
        match choice {
            TransferChoice::Factored => TransferMode::Factored,
            TransferChoice::Columns => TransferMode::Columns,
            TransferChoice::Hierarchical => TransferMode::Hierarchical,
            TransferChoice::Auto if n <= AUTO_FACTORED_MAX => TransferMode::Factored,
            TransferChoice::Auto if n <= AUTO_COLUMNS_MAX => TransferMode::Columns,
            TransferChoice::Auto => TransferMode::Hierarchical,
        }
    }
}

/// Response columns of one light group (each n × 3, interleaved RGB).
#[derive(Clone)]
pub struct GroupColumns {
    /// Emission, lm/m².
    pub e: Vec<f32>,
    /// Radiosity, lm/m².
    pub b: Vec<f32>,
    /// Incident illuminance, lux (direct light from luminaires included).
    pub h: Vec<f32>,
    /// Luminous flux of the group's point luminaires, lm per channel (zero for
    /// emissive-surface groups).
    pub flux: [f64; 3],
    /// The part of `flux` that lands directly on patches (Σ A·D), lm per channel.
    pub landed: [f64; 3],
}

/// Factored-mode data.
#[derive(Clone)]
pub struct Factored {
    /// Distinct channel factorizations.
    pub lus: Vec<ChannelLu>,
    /// Which factorization serves each of R, G, B.
    pub channel_lu: [u8; 3],
    /// The form-factor matrix, row-major n × n.
    pub f: Vec<f32>,
}

/// How the bake-time solve went.
#[derive(Debug, Clone, Copy, Default, Serialize, serde::Deserialize)]
pub struct SolveInfo {
    /// Largest relative residual `‖E − (I − ρF)B‖∞ / ‖E‖∞` over the group columns.
    pub residual: f64,
    /// Jacobi sweeps (columns mode), 0 for the direct solve.
    pub sweeps: usize,
}

/// The baked, immutable transfer of one scene.
#[derive(Clone)]
pub struct Transfer {
    pub mode: TransferMode,
    pub n: usize,
    /// Diffuse reflectance per patch and channel.
    pub rho: Vec<Rgb>,
    /// Patch areas, m².
    pub area: Vec<f32>,
    /// Fraction of each patch's outgoing light that hits no patch (leaves the scene).
    pub escape: Vec<f32>,
    pub groups: Vec<GroupColumns>,
    pub factored: Option<Factored>,
    /// Hierarchical-mode links.
    pub hierarchy: Option<Hierarchy>,
    pub info: SolveInfo,
}

/// The form factors a transfer is built from.
pub enum Coupling {
    /// Row-major n × n (factored and columns modes).
    Dense(Vec<f32>),
    /// Links, with each patch's escape fraction (hierarchical mode).
    Links(Box<Hierarchy>, Vec<f32>),
}

impl Transfer {
    /// Bytes held (allocated capacity of every array).
    pub fn bytes(&self) -> u64 {
        let f32s = |v: &Vec<f32>| 4 * v.capacity() as u64;
        let mut b = 12 * self.rho.capacity() as u64 + f32s(&self.area) + f32s(&self.escape);
        for g in &self.groups {
            b += f32s(&g.e) + f32s(&g.b) + f32s(&g.h);
        }
        if let Some(h) = &self.hierarchy {
            b += h.bytes();
        }
        if let Some(f) = &self.factored {
            b += f32s(&f.f);
            for lu in &f.lus {
                b += 4 * (lu.lu.nrows() * lu.lu.ncols()) as u64
                    + 8 * (lu.perm.capacity() + lu.perm_inv.capacity()) as u64;
            }
        }
        b
    }
}

/// A full solution: per patch RGB emission, radiosity and incident illuminance.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Emission, lm/m², n × 3 interleaved.
    pub e: Vec<f32>,
    /// Radiosity, lm/m².
    pub b: Vec<f32>,
    /// Incident illuminance, lux.
    pub h: Vec<f32>,
    /// Flux of point luminaires in this state, lm per channel.
    pub luminaire_flux: [f64; 3],
    /// Luminaire flux that hits no patch and leaves the scene directly, lm per channel.
    pub direct_escaped: [f64; 3],
}

/// Power balance of a solution, lumens per channel.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Power {
    /// Σ A·E plus the flux of point luminaires.
    pub emitted: [f64; 3],
    /// Σ A·(1 − ρ)·H.
    pub absorbed: [f64; 3],
    /// Σ A·B·(1 − Σ_j F_ij), light that leaves through openings, plus luminaire light
    /// that hits nothing.
    pub escaped: [f64; 3],
}

/// Per-group RGB emission columns for `mesh`, at intensity 1 and colour (1, 1, 1).
pub fn group_emission(scene: &Scene, mesh: &Mesh) -> Vec<Vec<f32>> {
    let n = mesh.len();
    let mut cols = vec![vec![0f32; 3 * n]; scene.lights.len()];
    for (i, p) in mesh.patches.iter().enumerate() {
        if let Some(g) = p.group {
            let ke = scene.materials[p.material as usize].ke;
            let s = scene.lights[g as usize].ke_scale;
            for c in 0..3 {
                cols[g as usize][3 * i + c] = (ke[c] as f64 * s) as f32;
            }
        }
    }
    cols
}

/// Diffuse reflectance per patch and channel.
pub fn patch_rho(scene: &Scene, mesh: &Mesh) -> Vec<Rgb> {
    mesh.patches
        .iter()
        .map(|p| scene.materials[p.material as usize].kd)
        .collect()
}

/// Per patch, the source term `E + ρ D` of all groups at intensity 1 and colour white,
/// mean of R, G and B, lm/m².
pub fn all_sources(scene: &Scene, mesh: &Mesh, direct: &[Option<Vec<f32>>]) -> Vec<f64> {
    let rho = patch_rho(scene, mesh);
    let emission = group_emission(scene, mesh);
    let mut out = vec![0f64; mesh.len()];
    for (gi, col) in emission.iter().enumerate() {
        let d = direct.get(gi).and_then(|d| d.as_deref());
        for (i, o) in out.iter_mut().enumerate() {
            for c in 0..3 {
                let first = d.map_or(0.0, |d| rho[i][c] * d[3 * i + c]);
                *o += (col[3 * i + c] + first) as f64 / 3.0;
            }
        }
    }
    out
}

/// The sources `E + ρ D` as an n × 3G matrix, column 3g + c: emission plus the first
/// reflection of the group's luminaires' direct illuminance D (lux).
fn source_matrix(emission: &[Vec<f32>], direct: &[Option<Vec<f32>>], rho: &[Rgb]) -> Mat<f32> {
    let n = rho.len();
    let mut e = Mat::<f32>::zeros(n, 3 * emission.len());
    for (gi, col) in emission.iter().enumerate() {
        let d = direct.get(gi).and_then(|d| d.as_deref());
        for i in 0..n {
            for c in 0..3 {
                let first = d.map_or(0.0, |d| rho[i][c] * d[3 * i + c]);
                e[(i, 3 * gi + c)] = col[3 * i + c] + first;
            }
        }
    }
    e
}

/// One LU of `(I − ρF)ᵀ` per distinct reflectance channel, and each channel's LU index.
fn factor_channels(
    f: &[f32],
    rho_ch: &[Vec<f32>; 3],
    n: usize,
    progress: &(dyn Fn(f64) + Sync),
) -> (Vec<ChannelLu>, [u8; 3]) {
    let mut channel_lu = [0u8; 3];
    let mut distinct: Vec<usize> = Vec::new();
    for c in 0..3 {
        match distinct.iter().position(|&d| rho_ch[d] == rho_ch[c]) {
            Some(k) => channel_lu[c] = k as u8,
            None => {
                channel_lu[c] = distinct.len() as u8;
                distinct.push(c);
            }
        }
    }
    let mut lus = Vec::new();
    for (k, &c) in distinct.iter().enumerate() {
        lus.push(ChannelLu::factor(f, &rho_ch[c], n));
        progress(0.9 * (k + 1) as f64 / distinct.len() as f64);
    }
    (lus, channel_lu)
}

/// The largest relative residual `‖E − (B − ρ F B)‖∞ / ‖E‖∞` over the columns.
fn max_residual(e: &Mat<f32>, b: &Mat<f32>, h: &Mat<f32>, rho_of_col: &[&[f32]]) -> f64 {
    let n = e.nrows();
    let mut residual = 0f64;
    for (k, rho) in rho_of_col.iter().enumerate() {
        let col = |m: &Mat<f32>| -> Vec<f32> { (0..n).map(|i| m[(i, k)]).collect() };
        residual = residual.max(solve::relative_residual(&col(e), &col(b), &col(h), rho));
    }
    residual
}

impl Transfer {
    /// Solves the scene for its light groups (and factors it in factored mode).
    /// `direct[g]` is the direct illuminance of group g's point luminaires (lux, n × 3 at
    /// unit weight; None without luminaires). It enters as the first reflection: the
    /// group's source is `E + ρ D`, and its incident illuminance `H = D + F B`.
    /// `coupling` is the dense `F` for the factored and columns modes, the links for the
    /// hierarchical mode.
    pub fn build(
        scene: &Scene,
        mesh: &Mesh,
        coupling: Coupling,
        direct: &[Option<Vec<f32>>],
        mode: TransferMode,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Transfer {
        let rho = patch_rho(scene, mesh);
        let area: Vec<f32> = mesh.patches.iter().map(|p| p.area as f32).collect();
        match coupling {
            Coupling::Dense(f) => {
                Self::build_dense(scene, mesh, f, rho, area, direct, mode, progress)
            }
            Coupling::Links(h, escape) => {
                Self::build_links(scene, mesh, *h, escape, rho, area, direct, progress)
            }
        }
    }

    /// The hierarchical mode: the group columns from sweeps over the links.
    #[allow(clippy::too_many_arguments)]
    fn build_links(
        scene: &Scene,
        mesh: &Mesh,
        hier: Hierarchy,
        escape: Vec<f32>,
        rho: Vec<Rgb>,
        area: Vec<f32>,
        direct: &[Option<Vec<f32>>],
        progress: &(dyn Fn(f64) + Sync),
    ) -> Transfer {
        let n = mesh.len();
        let emission = group_emission(scene, mesh);
        let g = emission.len();
        let c = 3 * g;
        // Sources E + ρD, row-major n × 3G.
        let mut src = vec![0f32; n * c];
        for (gi, col) in emission.iter().enumerate() {
            let d = direct.get(gi).and_then(|d| d.as_deref());
            for i in 0..n {
                for ch in 0..3 {
                    let first = d.map_or(0.0, |d| rho[i][ch] * d[3 * i + ch]);
                    src[i * c + 3 * gi + ch] = col[3 * i + ch] + first;
                }
            }
        }
        let sol = if c == 0 {
            None
        } else {
            Some(hier.solve(&rho, &src, c, HIERARCHY_TOL, HIERARCHY_MAX_SWEEPS, progress))
        };
        let pick = |x: &[f32], gi: usize| -> Vec<f32> {
            (0..n)
                .flat_map(|i| (0..3).map(move |ch| x[i * c + 3 * gi + ch]))
                .collect()
        };
        let groups = (0..g)
            .map(|gi| {
                let sol = sol.as_ref().expect("groups imply columns");
                let d = direct.get(gi).and_then(|d| d.as_deref());
                let mut hcol = pick(&sol.h, gi);
                if let Some(d) = d {
                    for (hv, dv) in hcol.iter_mut().zip(d) {
                        *hv += dv;
                    }
                }
                let (flux, landed) =
                    crate::transport::direct::group_flux(&scene.lights[gi], &area, d);
                GroupColumns {
                    e: emission[gi].clone(),
                    b: pick(&sol.b, gi),
                    h: hcol,
                    flux,
                    landed,
                }
            })
            .collect();
        let info = SolveInfo {
            residual: sol.as_ref().map_or(0.0, |s| s.residual),
            sweeps: sol.as_ref().map_or(0, |s| s.sweeps),
        };
        progress(1.0);
        Transfer {
            mode: TransferMode::Hierarchical,
            n,
            rho,
            area,
            escape,
            groups,
            factored: None,
            hierarchy: Some(hier),
            info,
        }
    }

    /// The factored and columns modes, from the dense `F`.
    #[allow(clippy::too_many_arguments)]
    fn build_dense(
        scene: &Scene,
        mesh: &Mesh,
        f: Vec<f32>,
        rho: Vec<Rgb>,
        area: Vec<f32>,
        direct: &[Option<Vec<f32>>],
        mode: TransferMode,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Transfer {
        let n = mesh.len();
        let escape: Vec<f32> = crate::transport::formfactor::row_sums(&f, n)
            .into_iter()
            .map(|s| (1.0 - s).max(0.0) as f32)
            .collect();
        let rho_ch: [Vec<f32>; 3] = std::array::from_fn(|c| rho.iter().map(|r| r[c]).collect());
        let emission = group_emission(scene, mesh);
        let g = emission.len();
        let e = source_matrix(&emission, direct, &rho);
        let rho_of_col: Vec<&[f32]> = (0..3 * g).map(|k| rho_ch[k % 3].as_slice()).collect();

        let (b, lus, sweeps) = match mode {
            TransferMode::Factored => {
                let (lus, channel_lu) = factor_channels(&f, &rho_ch, n, progress);
                let b = solve_refined(&lus, channel_lu, &f, e.as_ref(), &rho_of_col);
                (b, Some((lus, channel_lu)), 0)
            }
            TransferMode::Columns | TransferMode::Hierarchical => {
                let (b, sweeps) =
                    solve::jacobi(&f, n, e.as_ref(), &rho_of_col, COLUMN_TOL, 2000, progress);
                (b, None, sweeps)
            }
        };
        let h = solve::apply_f(&f, n, b.as_ref());
        let residual = max_residual(&e, &b, &h, &rho_of_col);
        let groups = (0..g)
            .map(|gi| {
                let d = direct.get(gi).and_then(|d| d.as_deref());
                let mut hcol = solve::interleave(h.as_ref(), [3 * gi, 3 * gi + 1, 3 * gi + 2]);
                if let Some(d) = d {
                    for (hv, dv) in hcol.iter_mut().zip(d) {
                        *hv += dv;
                    }
                }
                let (flux, landed) =
                    crate::transport::direct::group_flux(&scene.lights[gi], &area, d);
                GroupColumns {
                    e: emission[gi].clone(),
                    b: solve::interleave(b.as_ref(), [3 * gi, 3 * gi + 1, 3 * gi + 2]),
                    h: hcol,
                    flux,
                    landed,
                }
            })
            .collect();
        let factored = lus.map(|(lus, channel_lu)| Factored { lus, channel_lu, f });
        progress(1.0);
        Transfer {
            mode,
            n,
            rho,
            area,
            escape,
            groups,
            factored,
            hierarchy: None,
            info: SolveInfo { residual, sweeps },
        }
    }

    /// Number of light groups.
    pub fn group_count(&self) -> usize {
        self.groups.len()
    }

    /// Radiosity (lm/m², n × 3 interleaved) for per-group RGB weights, into `out`.
    /// This is the hot path of relighting: a weighted sum of a few columns.
    pub fn relight_into(&self, weights: &[Rgb], out: &mut [f32]) {
        weighted_sum(self.groups.iter().map(|g| g.b.as_slice()), weights, out);
    }

    /// Incident illuminance (lux, n × 3 interleaved) for per-group RGB weights, into `out`.
    pub fn illuminance_into(&self, weights: &[Rgb], out: &mut [f32]) {
        weighted_sum(self.groups.iter().map(|g| g.h.as_slice()), weights, out);
    }

    /// Full solution (emission, radiosity, illuminance) for per-group RGB weights.
    pub fn relight(&self, weights: &[Rgb]) -> Solution {
        let len = 3 * self.n;
        let mut s = Solution {
            e: vec![0.0; len],
            b: vec![0.0; len],
            h: vec![0.0; len],
            luminaire_flux: [0.0; 3],
            direct_escaped: [0.0; 3],
        };
        for (g, w) in self.groups.iter().zip(weights) {
            let w = w.map(|x| x as f64);
            s.luminaire_flux = std::array::from_fn(|c| s.luminaire_flux[c] + w[c] * g.flux[c]);
            s.direct_escaped = std::array::from_fn(|c| {
                s.direct_escaped[c] + w[c] * (g.flux[c] - g.landed[c]).max(0.0)
            });
        }
        weighted_sum(
            self.groups.iter().map(|g| g.e.as_slice()),
            weights,
            &mut s.e,
        );
        weighted_sum(
            self.groups.iter().map(|g| g.b.as_slice()),
            weights,
            &mut s.b,
        );
        weighted_sum(
            self.groups.iter().map(|g| g.h.as_slice()),
            weights,
            &mut s.h,
        );
        s
    }

    /// Solution for an arbitrary per-patch emission (lm/m², n × 3 interleaved): exact
    /// with the stored factors (factored mode), or by sweeps over the links to
    /// [`HIERARCHY_TOL`] (hierarchical mode); `None` in columns mode.
    pub fn solve(&self, emission: &[f32]) -> Option<Solution> {
        let n = self.n;
        if emission.len() != 3 * n {
            return None;
        }
        if let Some(h) = &self.hierarchy {
            let sol = h.solve(
                &self.rho,
                emission,
                3,
                HIERARCHY_TOL,
                HIERARCHY_MAX_SWEEPS,
                &|_| {},
            );
            return Some(Solution {
                e: emission.to_vec(),
                b: sol.b,
                h: sol.h,
                luminaire_flux: [0.0; 3],
                direct_escaped: [0.0; 3],
            });
        }
        let fac = self.factored.as_ref()?;
        let mut x = Mat::<f32>::zeros(n, 3);
        for i in 0..n {
            for c in 0..3 {
                x[(i, c)] = emission[3 * i + c];
            }
        }
        fac.solve_cols(x.as_mut());
        let h = solve::apply_f(&fac.f, n, x.as_ref());
        Some(Solution {
            e: emission.to_vec(),
            b: solve::interleave(x.as_ref(), [0, 1, 2]),
            h: solve::interleave(h.as_ref(), [0, 1, 2]),
            luminaire_flux: [0.0; 3],
            direct_escaped: [0.0; 3],
        })
    }

    /// Power balance of a solution, lumens per channel.
    pub fn power(&self, s: &Solution) -> Power {
        let mut p = Power {
            emitted: s.luminaire_flux,
            absorbed: [0.0; 3],
            escaped: s.direct_escaped,
        };
        for i in 0..self.n {
            let a = self.area[i] as f64;
            for c in 0..3 {
                let k = 3 * i + c;
                p.emitted[c] += a * s.e[k] as f64;
                p.absorbed[c] += a * (1.0 - self.rho[i][c] as f64) * s.h[k] as f64;
                p.escaped[c] += a * s.b[k] as f64 * self.escape[i] as f64;
            }
        }
        p
    }
}

/// `out = Σ_g w_g ⊙ col_g` over interleaved RGB columns. Works in blocks of 24 floats
/// (8 patches, a whole number of RGB triples) so the per-channel weights form a fixed
/// pattern and the inner loop vectorizes.
pub fn weighted_sum<'a>(cols: impl Iterator<Item = &'a [f32]>, weights: &[Rgb], out: &mut [f32]) {
    const W: usize = 24;
    let active: Vec<(&[f32], [f32; W])> = cols
        .zip(weights)
        .filter(|(_, w)| w.iter().any(|&x| x != 0.0))
        .map(|(c, w)| (c, std::array::from_fn(|k| w[k % 3])))
        .collect();
    let full = out.len() / W * W;
    let (head, tail) = out.split_at_mut(full);
    for (blk, o) in head.chunks_exact_mut(W).enumerate() {
        let mut acc = [0f32; W];
        let base = blk * W;
        for (c, pat) in &active {
            let src = &c[base..base + W];
            for k in 0..W {
                acc[k] += pat[k] * src[k];
            }
        }
        o.copy_from_slice(&acc);
    }
    for (k, o) in tail.iter_mut().enumerate() {
        let idx = full + k;
        *o = active.iter().map(|(c, pat)| pat[idx % 3] * c[idx]).sum();
    }
}

/// Solves `(I − ρF) X = E` for the columns of `e` (column k uses channel k % 3), with one
/// step of iterative refinement.
pub fn solve_refined(
    lus: &[ChannelLu],
    channel_lu: [u8; 3],
    f: &[f32],
    e: faer::MatRef<'_, f32>,
    rho_of_col: &[&[f32]],
) -> Mat<f32> {
    let n = e.nrows();
    let mut x = e.to_owned();
    solve_cols(lus, channel_lu, x.as_mut());
    // r = E − (X − ρ F X); X += (I − ρF)⁻¹ r
    let fx = solve::apply_f(f, n, x.as_ref());
    let mut r = Mat::<f32>::zeros(n, e.ncols());
    for k in 0..e.ncols() {
        let rho = rho_of_col[k];
        for i in 0..n {
            r[(i, k)] = e[(i, k)] - (x[(i, k)] - rho[i] * fx[(i, k)]);
        }
    }
    solve_cols(lus, channel_lu, r.as_mut());
    for k in 0..e.ncols() {
        for i in 0..n {
            x[(i, k)] += r[(i, k)];
        }
    }
    x
}

/// Solves in place; column k is solved with the factorization of channel k % 3.
fn solve_cols(lus: &[ChannelLu], channel_lu: [u8; 3], mut x: faer::MatMut<'_, f32>) {
    let k = x.ncols();
    let n = x.nrows();
    for c in 0..3 {
        let cols: Vec<usize> = (c..k).step_by(3).collect();
        if cols.is_empty() {
            continue;
        }
        // Gather the channel's columns, solve them together, scatter back.
        let mut m = Mat::<f32>::zeros(n, cols.len());
        for (a, &col) in cols.iter().enumerate() {
            for i in 0..n {
                m[(i, a)] = x[(i, col)];
            }
        }
        lus[channel_lu[c] as usize].solve_in_place(m.as_mut());
        for (a, &col) in cols.iter().enumerate() {
            for i in 0..n {
                x[(i, col)] = m[(i, a)];
            }
        }
    }
}

impl Factored {
    /// Solves in place; column k is solved with the factorization of channel k % 3.
    pub fn solve_cols(&self, x: faer::MatMut<'_, f32>) {
        solve_cols(&self.lus, self.channel_lu, x)
    }
}
