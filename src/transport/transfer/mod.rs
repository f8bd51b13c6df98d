//! The baked transfer: everything needed to relight a scene, immutable once built.
//!
//! Three modes:
//! - **factored**: the irradiance response `K = F (I − ρF)⁻¹` per distinct reflectance
//!   channel, n × n. Any per-patch emission vector is answered exactly by one product
//!   ([`Transfer::solve`]), in time proportional to its nonzero patches when it is
//!   sparse; light groups are served from precomputed columns as well.
//! - **columns**: only the response columns of the light groups (from Jacobi iteration to
//!   a relative tolerance of [`COLUMN_TOL`]); `F` is not kept.
//! - **hierarchical**: no n × n matrix at all. The form factors are links of a cluster
//!   hierarchy ([`crate::transport::hierarchy`]), about linear in n; the group columns are
//!   solved by gather/push/pull sweeps to [`HIERARCHY_TOL`], and a per-patch emission is
//!   solved on demand through the same links by GMRES to [`EMISSION_TOL`].
//!
//! In every mode every light group g has three interleaved RGB columns (n × 3 floats),
//! computed for the group at intensity 1 and colour (1, 1, 1):
//! `e_g` its emission (lm/m²), `b_g` the radiosity it causes (lm/m²) and `h_g` the
//! incident illuminance it causes (lux). A lighting state with per-group RGB weights
//! `w_g` gives `B = Σ_g w_g ⊙ b_g`, and likewise for H and E: relighting is linear.

use faer::Mat;
use serde::Serialize;

use crate::color::{Rgb, Rgb64};
use crate::geometry::mesh::Mesh;
use crate::scene::{Scene, TransferChoice};
use crate::transport::hierarchy::{Coarse, Hierarchy, Preconditioner};

mod build;
pub use build::{all_sources, group_emission, group_sources, patch_rho, solve_refined};

/// Relative tolerance of the iterative column solver.
pub const COLUMN_TOL: f64 = 1e-7;
/// Largest patch count for which `auto` picks the factored mode; above it, hierarchical.
/// `auto` never picks the columns mode, which answers light groups only: every mode it
/// picks answers any per-patch emission (and so request-time light) as well.
pub const AUTO_FACTORED_MAX: usize = 6000;
/// Relative tolerance of the hierarchical sweeps (per column, the largest change over the
/// largest reflected radiosity).
pub const HIERARCHY_TOL: f64 = 1e-6;
/// Most sweeps of a hierarchical solve (the error shrinks by ρ_max per sweep).
pub const HIERARCHY_MAX_SWEEPS: usize = 1000;
/// Tolerance of an emission answer in hierarchical mode (GMRES preconditioned by the
/// coarse transfer, [`Hierarchy::solve_krylov_with`]): the last pass over the links
/// changed no patch's reflected radiosity by more than this fraction of its value (down
/// to 10⁻⁶ of the brightest). On office-floor that leaves every surface of at least 1 m²
/// within 0.2 % of a solve converged to 10⁻⁹, however dim (one emitting patch: its
/// farthest rooms at 10⁻⁸ of the brightest), and at 1 % one pass more holds them to
/// 0.02 % (`examples/emission_solvers.rs`).
pub const EMISSION_TOL: f64 = 3e-2;
/// Most passes over the links of one emission answer in hierarchical mode (about 70 ms
/// each on office-floor's 74.9 million links).
pub const EMISSION_MAX_PASSES: usize = 100;
/// Emission states that [`Transfer::solve_many`] is handed at once by the batch queries
/// (`Model::solve_each`). 128 states are 384 right-hand sides: enough for the triangular
/// solves and `F · B` to run as matrix–matrix products, while the working memory stays
/// near [`SOLVE_BYTES_PER_STATE`] · n · 128 (50 MB for the 5,498-patch Cornell box).
pub const SOLVE_CHUNK: usize = 128;
/// Memory of [`Transfer::solve_many`] per state and patch, bytes, an upper estimate over
/// the modes: the emission vector (12), the working columns (factored: E, a
/// per-response copy of it and H, 36; hierarchical: the sources, B and the gather
/// over about 2n nodes, and H, 72) and the answer's e, b and h (36).
pub const SOLVE_BYTES_PER_STATE: u64 = 12 + 72 + 36;

/// How a transfer is kept: `factored` (irradiance responses: any per-patch emission is
/// answered exactly) or `columns` (the light groups' response columns only).
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
    pub flux: Rgb64,
    /// The part of `flux` that lands directly on patches (Σ A·D), lm per channel.
    pub landed: Rgb64,
}

/// The direct light of the sky patches at unit luminance, the input of a daylight bake.
#[derive(Clone)]
pub struct SkyDirect {
    /// Sky patches, the ground first ([`crate::transport::sky_view::subdivision`]).
    pub k: usize,
    /// Per patch and sky patch, lux per cd/m² (n × K, row-major).
    pub direct: Vec<f32>,
}

/// The sky's responses: per sky patch at unit luminance (cd/m²), the direct illuminance
/// and the illuminance of the interreflected light. A sky with patch luminances `L_k`
/// gives each patch `H = Σ_k L_k (D_k + I_k)` (lux) and `B = ρ H` (lm/m²).
#[derive(Clone)]
pub struct SkyColumns {
    pub k: usize,
    /// Direct: per patch and sky patch, lux per cd/m² (n × K, row-major, luminous: the sky
    /// is white).
    pub direct: Vec<f32>,
    /// Interreflected: per sky patch, n × 3 interleaved, lux per cd/m².
    pub indirect: Vec<Vec<f32>>,
}

impl SkyColumns {
    pub fn new(d: SkyDirect, indirect: Vec<Vec<f32>>) -> SkyColumns {
        SkyColumns {
            k: d.k,
            direct: d.direct,
            indirect,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        4 * (self.direct.capacity() + self.indirect.iter().map(|c| c.capacity()).sum::<usize>())
            as u64
    }
}

/// Factored-mode data: per distinct reflectance channel, the irradiance response
/// `K = F (I − ρF)⁻¹` ([`solve::ChannelLu::irradiance_response`]).
#[derive(Clone)]
pub struct Factored {
    /// Distinct channel responses, each `Kᵀ` column-major (n × n): `K_ij`, the
    /// illuminance (lux) at patch i per lm/m² emitted by patch j, at `(j, i)`.
    pub responses: Vec<Mat<f32>>,
    /// Which response serves each of R, G, B.
    pub channel: [u8; 3],
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
    /// Hierarchical mode: the later bounces between clusters, which precondition the
    /// emission answers ([`Hierarchy::coarse`]). Built from the links at load.
    pub coarse: Option<Coarse>,
    /// Per calculation grid of the scene (in `scene.grids` order) and per light group:
    /// the illuminance at each grid point (lux, points × 3 interleaved) at unit weight
    /// ([`crate::transport::probe::grid_columns`]).
    pub grids: Vec<Vec<Vec<f32>>>,
    /// Per calculation grid: the gather's weights per point, which answer any radiosity.
    pub grid_gathers: Vec<crate::transport::probe::GridGather>,
    /// The sky patches' responses, for a scene with a site.
    pub sky: Option<SkyColumns>,
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
        b += self.coarse.as_ref().map_or(0, |c| c.bytes());
        b += self.grids.iter().flatten().map(f32s).sum::<u64>();
        b += self.sky.as_ref().map_or(0, |s| s.bytes());
        if let Some(f) = &self.factored {
            for k in &f.responses {
                b += 4 * (k.nrows() * k.ncols()) as u64;
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
    pub luminaire_flux: Rgb64,
    /// Luminaire flux that hits no patch and leaves the scene directly, lm per channel.
    pub direct_escaped: Rgb64,
}

/// Power balance of a solution, lumens per channel.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Power {
    /// Σ A·E plus the flux of point luminaires.
    pub emitted: Rgb64,
    /// Σ A·(1 − ρ)·H.
    pub absorbed: Rgb64,
    /// Σ A·B·(1 − Σ_j F_ij), light that leaves through openings, plus luminaire light
    /// that hits nothing.
    pub escaped: Rgb64,
}

impl Transfer {
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
            luminaire_flux: Rgb64::ZERO,
            direct_escaped: Rgb64::ZERO,
        };
        for (g, w) in self.groups.iter().zip(weights) {
            let w = w.to_f64();
            s.luminaire_flux += w * g.flux;
            s.direct_escaped += w * (g.flux - g.landed).map(|v| v.max(0.0));
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
    /// with the stored responses (factored mode), or by sweeps over the links to
    /// [`HIERARCHY_TOL`] (hierarchical mode); `None` in columns mode.
    pub fn solve(&self, emission: &[f32]) -> Option<Solution> {
        self.solve_many(&[emission])?.pop()
    }

    /// Solutions for many per-patch emissions at once (each n × 3 interleaved), in order;
    /// `None` in columns mode or when a vector is not 3n long. In factored mode the m
    /// emissions form one n × 3m matrix E (column 3j + c is state j's channel c):
    /// `H = K E` by one product per distinct channel response ([`Factored::irradiance`]),
    /// and `B = E + ρ H`. In
    /// hierarchical mode the 3m columns are swept together (until all have converged).
    /// The working memory is about [`SOLVE_BYTES_PER_STATE`] · n bytes per state; callers
    /// bound m (see [`SOLVE_CHUNK`]).
    pub fn solve_many(&self, emissions: &[&[f32]]) -> Option<Vec<Solution>> {
        let n = self.n;
        if emissions.iter().any(|e| e.len() != 3 * n) {
            return None;
        }
        let m = emissions.len();
        if m == 0 {
            return Some(vec![]);
        }
        let c = 3 * m;
        let solution = |e: &[f32], b: Vec<f32>, h: Vec<f32>| Solution {
            e: e.to_vec(),
            b,
            h,
            luminaire_flux: Rgb64::ZERO,
            direct_escaped: Rgb64::ZERO,
        };
        if let Some(hier) = &self.hierarchy {
            // Sources row-major n × 3m: patch i's channel ch of state j at i·3m + 3j + ch,
            // so patch i's triple of state j at i·m + j.
            let mut s = vec![0f32; n * c];
            let rows = Rgb::column_mut(&mut s);
            for (j, e) in emissions.iter().enumerate() {
                for (i, &v) in Rgb::column(e).iter().enumerate() {
                    rows[i * m + j] = v;
                }
            }
            let sol = if hier.krylov_fits(c) {
                let pre = self
                    .coarse
                    .as_ref()
                    .map(|k| move |v: &[f32]| k.precondition(&hier.area, v, c));
                hier.solve_krylov_with(
                    &self.rho,
                    &s,
                    c,
                    EMISSION_TOL,
                    EMISSION_MAX_PASSES,
                    pre.as_ref().map(|f| f as &Preconditioner<'_>),
                )
            } else {
                hier.solve(
                    &self.rho,
                    &s,
                    c,
                    HIERARCHY_TOL,
                    HIERARCHY_MAX_SWEEPS,
                    &|_| {},
                )
            };
            let pick = |x: &[f32], j: usize| -> Vec<f32> {
                Rgb::column(x)
                    .chunks_exact(m)
                    .flat_map(|row| row[j].0)
                    .collect()
            };
            return Some(
                emissions
                    .iter()
                    .enumerate()
                    .map(|(j, e)| solution(e, pick(&sol.b, j), pick(&sol.h, j)))
                    .collect(),
            );
        }
        let fac = self.factored.as_ref()?;
        // An interleaved n × 3 vector is a row-major n × 3 matrix.
        let mut x = Mat::<f32>::zeros(n, c);
        for (j, e) in emissions.iter().enumerate() {
            x.as_mut()
                .subcols_mut(3 * j, 3)
                .copy_from(faer::MatRef::from_row_major_slice(e, n, 3));
        }
        let rho_ch: [Vec<f32>; 3] =
            std::array::from_fn(|ch| self.rho.iter().map(|r| r[ch]).collect());
        let rho_of_col: Vec<&[f32]> = (0..c).map(|k| rho_ch[k % 3].as_slice()).collect();
        let (x, h) = fac.radiosity(x.as_ref(), &rho_of_col);
        let out = |y: &Mat<f32>, j: usize| {
            let mut v = vec![0f32; 3 * n];
            faer::MatMut::from_row_major_slice_mut(&mut v, n, 3).copy_from(y.subcols(3 * j, 3));
            v
        };
        Some(
            emissions
                .iter()
                .enumerate()
                .map(|(j, e)| solution(e, out(&x, j), out(&h, j)))
                .collect(),
        )
    }

    /// Power balance of a solution, lumens per channel.
    pub fn power(&self, s: &Solution) -> Power {
        let mut p = Power {
            emitted: s.luminaire_flux,
            absorbed: Rgb64::ZERO,
            escaped: s.direct_escaped,
        };
        let (e, b, h) = (Rgb::column(&s.e), Rgb::column(&s.b), Rgb::column(&s.h));
        for i in 0..self.n {
            let a = self.area[i] as f64;
            p.emitted += a * e[i].to_f64();
            p.absorbed += a * (Rgb64::ONE - self.rho[i].to_f64()) * h[i].to_f64();
            p.escaped += a * b[i].to_f64() * self.escape[i] as f64;
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

/// Emissions whose nonzero patches are at most this share of all patches are answered
/// column by column of K ([`Factored::irradiance`]): work k·n for k such patches, where
/// the product reads all n².
const SPARSE_SHARE: usize = 8;

impl Factored {
    /// Radiosity `B = E + ρ K E` (lm/m²) and incident illuminance `H = K E` (lux) for
    /// per-patch emissions `e` (n × c, column k with reflectances `rho_of_col[k]`).
    pub fn radiosity(
        &self,
        e: faer::MatRef<'_, f32>,
        rho_of_col: &[&[f32]],
    ) -> (Mat<f32>, Mat<f32>) {
        let h = self.irradiance(e);
        let mut b = e.to_owned();
        for (k, rho) in rho_of_col.iter().enumerate() {
            for (i, v) in b.as_mut().col_mut(k).iter_mut().enumerate() {
                *v += rho[i] * h[(i, k)];
            }
        }
        (b, h)
    }

    /// `H = K X` (lux) for per-patch emissions `x` (lm/m², n × c, column k in channel
    /// k % 3). Dense columns go through one matrix product per distinct response; when
    /// at most n / [`SPARSE_SHARE`] rows of `x` are nonzero, each patch's H sums only
    /// the nonzero entries' terms (its row of K is a contiguous column of `Kᵀ`): work n
    /// per nonzero entry.
    pub fn irradiance(&self, x: faer::MatRef<'_, f32>) -> Mat<f32> {
        use rayon::prelude::*;
        let (n, c) = (x.nrows(), x.ncols());
        let lit: Vec<usize> = (0..n)
            .filter(|&i| (0..c).any(|k| x[(i, k)] != 0.0))
            .collect();
        let mut h = Mat::<f32>::zeros(n, c);
        for (u, kt) in self.responses.iter().enumerate() {
            let cols: Vec<usize> = (0..c)
                .filter(|&k| self.channel[k % 3] as usize == u)
                .collect();
            if cols.is_empty() {
                continue;
            }
            if lit.len() * SPARSE_SHARE <= n {
                // The nonzero entries (lit patch, answer column, value), and the answers
                // row-major n × |cols|, one patch per row.
                let terms: Vec<(usize, usize, f32)> = lit
                    .iter()
                    .flat_map(|&j| {
                        cols.iter()
                            .enumerate()
                            .map(move |(a, &k)| (j, a, x[(j, k)]))
                            .filter(|t| t.2 != 0.0)
                    })
                    .collect();
                let mut rows = vec![0f32; n * cols.len()];
                rows.par_chunks_mut(cols.len())
                    .enumerate()
                    .for_each(|(i, out)| {
                        let k_row = kt.col_as_slice(i);
                        for &(j, a, v) in &terms {
                            out[a] += k_row[j] * v;
                        }
                    });
                for (a, &k) in cols.iter().enumerate() {
                    for i in 0..n {
                        h[(i, k)] = rows[i * cols.len() + a];
                    }
                }
                continue;
            }
            let mut xs = Mat::<f32>::zeros(n, cols.len());
            for (a, &k) in cols.iter().enumerate() {
                xs.as_mut().col_mut(a).copy_from(x.col(k));
            }
            let mut hs = Mat::<f32>::zeros(n, cols.len());
            faer::linalg::matmul::matmul(
                hs.as_mut(),
                faer::Accum::Replace,
                kt.as_ref().transpose(),
                xs.as_ref(),
                1.0,
                faer::Par::rayon(0),
            );
            for (a, &k) in cols.iter().enumerate() {
                h.as_mut().col_mut(k).copy_from(hs.col(a));
            }
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A factored transfer over a synthetic coupling: n patches, row sums of F below 1,
    /// reflectances with R and B equal (one shared factorization) and G distinct.
    fn factored(n: usize) -> (Transfer, Vec<f32>) {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut f: Vec<f32> = (0..n * n).map(|_| next()).collect();
        for i in 0..n {
            f[i * n + i] = 0.0;
            let sum: f32 = f[i * n..(i + 1) * n].iter().sum();
            let scale = 0.9 / sum;
            f[i * n..(i + 1) * n].iter_mut().for_each(|x| *x *= scale);
        }
        let rho: Vec<Rgb> = (0..n)
            .map(|i| {
                let r = 0.2 + 0.7 * (i % 7) as f32 / 7.0;
                Rgb::new(r, 0.1 + 0.8 * next(), r)
            })
            .collect();
        let rho_ch: [Vec<f32>; 3] = std::array::from_fn(|c| rho.iter().map(|r| r[c]).collect());
        let factored = build::factor_responses(&f, &rho_ch, n, &|_| {});
        assert_eq!(factored.responses.len(), 2);
        let t = Transfer {
            mode: TransferMode::Factored,
            n,
            rho,
            area: vec![1.0; n],
            escape: vec![0.1; n],
            groups: vec![],
            factored: Some(factored),
            hierarchy: None,
            coarse: None,
            grids: vec![],
            grid_gathers: vec![],
            sky: None,
            info: SolveInfo::default(),
        };
        (t, f)
    }

    /// A channel that differs from the first on a few patches gets its response by a
    /// rank-k update of the first's: the same as its own factorization's, to f32
    /// rounding.
    #[test]
    fn a_colour_on_a_few_patches_updates_the_first_channels_response() {
        let n = 240;
        let (t, f) = factored(n);
        let mut rho_ch: [Vec<f32>; 3] =
            std::array::from_fn(|c| t.rho.iter().map(|r| r[c]).collect());
        // Green = red except on every 9th patch (27 patches), blue = red.
        rho_ch[1] = rho_ch[0]
            .iter()
            .enumerate()
            .map(|(i, &r)| if i % 9 == 0 { 0.9 - 0.8 * r } else { r })
            .collect();
        rho_ch[2] = rho_ch[0].clone();
        let fac = build::factor_responses(&f, &rho_ch, n, &|_| {});
        assert_eq!(fac.channel, [0, 1, 0]);
        let direct =
            crate::transport::solve::ChannelLu::factor(&f, &rho_ch[1], n).irradiance_response(&f);
        let scale = (0..n)
            .flat_map(|j| direct.col_as_slice(j).iter().copied())
            .fold(0f32, f32::max);
        for j in 0..n {
            for i in 0..n {
                let (a, b) = (fac.responses[1][(i, j)], direct[(i, j)]);
                assert!((a - b).abs() <= 1e-5 * scale, "K[{j}][{i}]: {a} vs {b}");
            }
        }
    }

    #[test]
    fn many_emissions_solved_together_equal_the_single_solves() {
        let n = 300;
        let (t, f) = factored(n);
        // Single patches (white and coloured), and a dense emission.
        let mut emissions: Vec<Vec<f32>> = (0..40)
            .map(|k| {
                let mut e = vec![0f32; 3 * n];
                let p = (k * 37) % n;
                Rgb::column_mut(&mut e)[p] = Rgb::new(1.0, 0.5 + (k % 3) as f32, 0.25 * k as f32);
                e
            })
            .collect();
        emissions.push((0..3 * n).map(|k| (k % 11) as f32).collect());
        let refs: Vec<&[f32]> = emissions.iter().map(|e| e.as_slice()).collect();
        let together = t.solve_many(&refs).unwrap();
        assert_eq!(together.len(), emissions.len());
        for (e, s) in emissions.iter().zip(&together) {
            let one = t.solve(e).unwrap();
            assert_eq!(&s.e, e);
            let scale = one.b.iter().fold(0f32, |m, x| m.max(x.abs()));
            for k in 0..3 * n {
                assert!((s.b[k] - one.b[k]).abs() <= 1e-5 * scale, "B[{k}]");
                assert!((s.h[k] - one.h[k]).abs() <= 1e-5 * scale, "H[{k}]");
            }
            // And both solve the system: B = E + ρ F B, H = F B.
            let (b, h) = (Rgb::column(&s.b), Rgb::column(&s.h));
            let off = |x: Rgb, want: Rgb64| (x.to_f64() - want).map(f64::abs).max_component();
            for i in 0..n {
                let fb: Rgb64 = (0..n).map(|j| f[i * n + j] as f64 * b[j].to_f64()).sum();
                assert!(off(h[i], fb) <= 1e-5 * scale as f64);
                let want = Rgb::column(e)[i].to_f64() + t.rho[i].to_f64() * fb;
                assert!(off(b[i], want) <= 1e-5 * scale as f64);
            }
        }
        assert!(t.solve_many(&[]).unwrap().is_empty());
        assert!(t.solve_many(&[&[1.0; 3]]).is_none());
    }
}
