//! Building a [`Transfer`]: the sources of the light groups, then the dense solves
//! (factored: the irradiance responses, and solves through them with one step of
//! refinement; columns: Jacobi) or
//! the sweeps over the links (hierarchical).

use faer::Mat;

use super::*;
use crate::transport::solve::{self, ChannelLu};

/// Per-group RGB emission columns for `mesh`, at intensity 1 and colour (1, 1, 1).
pub fn group_emission(scene: &Scene, mesh: &Mesh) -> Vec<Vec<f32>> {
    let n = mesh.len();
    let mut cols = vec![vec![0f32; 3 * n]; scene.lights.len()];
    for (i, p) in mesh.patches.iter().enumerate() {
        if let Some(g) = p.group {
            let ke = scene.materials[p.material as usize].ke;
            let s = scene.lights[g as usize].ke_scale;
            Rgb::column_mut(&mut cols[g as usize])[i] = (ke.to_f64() * s).to_f32();
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

/// Per group, the source `E + ρ D` (lm/m², n × 3 interleaved, intensity 1, colour white):
/// the group's emission plus the first reflection of its luminaires' direct illuminance
/// D (lux). Every mode solves for these.
pub fn group_sources(
    emission: &[Vec<f32>],
    direct: &[Option<Vec<f32>>],
    rho: &[Rgb],
) -> Vec<Vec<f32>> {
    emission
        .iter()
        .enumerate()
        .map(|(gi, col)| {
            let mut s = col.clone();
            if let Some(d) = direct.get(gi).and_then(|d| d.as_deref()) {
                let sources = Rgb::column_mut(&mut s).iter_mut();
                for ((s, &r), &d) in sources.zip(rho).zip(Rgb::column(d)) {
                    *s += r * d;
                }
            }
            s
        })
        .collect()
}

/// Per patch, the source term `E + ρ D` of all groups at intensity 1 and colour white,
/// mean of R, G and B, lm/m².
pub fn all_sources(scene: &Scene, mesh: &Mesh, direct: &[Option<Vec<f32>>]) -> Vec<f64> {
    let rho = patch_rho(scene, mesh);
    let mut out = vec![0f64; mesh.len()];
    for s in group_sources(&group_emission(scene, mesh), direct, &rho) {
        for (o, c) in out.iter_mut().zip(s.chunks_exact(3)) {
            *o += (c[0] as f64 + c[1] as f64 + c[2] as f64) / 3.0;
        }
    }
    out
}

/// Per sky patch k, the source `ρ D_k` (n × 3 interleaved) of the sky's direct
/// illuminance at unit luminance `d` (n × K row-major).
fn sky_sources(d: &SkyDirect, rho: &[Rgb]) -> Vec<Vec<f32>> {
    (0..d.k)
        .map(|k| {
            rho.iter()
                .enumerate()
                .flat_map(|(i, &r)| (r * d.direct[i * d.k + k]).0)
                .collect()
        })
        .collect()
}

/// The sources of the groups and then the sky patches as an n × 3(G + K) matrix, column
/// 3g + c (see [`group_sources`], [`sky_sources`]).
fn source_matrix(
    emission: &[Vec<f32>],
    direct: &[Option<Vec<f32>>],
    sky: Option<&SkyDirect>,
    rho: &[Rgb],
) -> Mat<f32> {
    let mut s = group_sources(emission, direct, rho);
    if let Some(d) = sky {
        s.extend(sky_sources(d, rho));
    }
    Mat::from_fn(rho.len(), 3 * s.len(), |i, k| s[k / 3][3 * i + k % 3])
}

/// The factored mode's irradiance responses `K = F (I − ρF)⁻¹`, one per distinct
/// reflectance channel ([`Factored`]). The first channel's is made from its LU
/// ([`ChannelLu::irradiance_response`]). Each other channel's is a rank-k update of it
/// ([`solve::updated_response`]) when the channels differ on few enough patches (a
/// colour on a few surfaces, as the Cornell box's red and green walls); otherwise it is
/// made from its own LU. Each LU is dropped once its response is made.
pub(super) fn factor_responses(
    f: &[f32],
    rho_ch: &[Vec<f32>; 3],
    n: usize,
    progress: &(dyn Fn(f64) + Sync),
) -> Factored {
    let mut channel = [0u8; 3];
    let mut distinct: Vec<usize> = Vec::new();
    for c in 0..3 {
        match distinct.iter().position(|&d| rho_ch[d] == rho_ch[c]) {
            Some(k) => channel[c] = k as u8,
            None => {
                channel[c] = distinct.len() as u8;
                distinct.push(c);
            }
        }
    }
    let first = distinct[0];
    let k0 = ChannelLu::factor(f, &rho_ch[first], n).irradiance_response(f);
    progress(0.9 / distinct.len() as f64);
    let mut responses = vec![k0];
    for (u, &c) in distinct.iter().enumerate().skip(1) {
        let d: Vec<usize> = (0..n)
            .filter(|&i| rho_ch[c][i] != rho_ch[first][i])
            .collect();
        // Work of the update (a k × n solve and an n × k × n product) against a
        // factorization and a solve with n right-hand sides.
        let (k, nf) = (d.len() as f64, n as f64);
        let update = 2.0 * k * k * nf + 2.0 * nf * nf * k + k * k * k;
        let k_c = if update < (2.0 / 3.0 + 2.0) * nf * nf * nf {
            solve::updated_response(&responses[0], &rho_ch[first], &rho_ch[c], &d)
        } else {
            ChannelLu::factor(f, &rho_ch[c], n).irradiance_response(f)
        };
        responses.push(k_c);
        progress(0.9 * (u + 1) as f64 / distinct.len() as f64);
    }
    Factored { responses, channel }
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
    /// `sky`, for a scene with a site, is the direct illuminance of every sky patch at unit
    /// luminance; each gets a response ([`SkyColumns`]) solved with the groups.
    pub fn build(
        scene: &Scene,
        mesh: &Mesh,
        coupling: Coupling,
        direct: &[Option<Vec<f32>>],
        sky: Option<SkyDirect>,
        mode: TransferMode,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Transfer {
        let b = Build {
            scene,
            n: mesh.len(),
            emission: group_emission(scene, mesh),
            direct,
            rho: patch_rho(scene, mesh),
            area: mesh.patches.iter().map(|p| p.area as f32).collect(),
            progress,
        };
        match coupling {
            Coupling::Dense(f) => b.dense(f, sky, mode),
            Coupling::Links(h, escape) => b.links(*h, escape, sky),
        }
    }
}

/// What a build reads in every mode: the scene, the groups' emission and luminaires'
/// direct light, and per patch (n) the reflectance and area.
struct Build<'a> {
    scene: &'a Scene,
    n: usize,
    /// Per group, the emission column ([`group_emission`]).
    emission: Vec<Vec<f32>>,
    direct: &'a [Option<Vec<f32>>],
    rho: Vec<Rgb>,
    area: Vec<f32>,
    progress: &'a (dyn Fn(f64) + Sync),
}

impl Build<'_> {
    /// The hierarchical mode: the group columns from sweeps over the links.
    fn links(self, hier: Hierarchy, escape: Vec<f32>, sky: Option<SkyDirect>) -> Transfer {
        let n = self.n;
        let g = self.emission.len();
        let mut cols = group_sources(&self.emission, self.direct, &self.rho);
        if let Some(d) = &sky {
            cols.extend(sky_sources(d, &self.rho));
        }
        let c = 3 * cols.len();
        // Sources E + ρD (groups, then sky patches), row-major n × 3(G + K).
        let mut src = vec![0f32; n * c];
        let src_rgb = Rgb::column_mut(&mut src);
        for (gi, col) in cols.iter().enumerate() {
            for (i, &v) in Rgb::column(col).iter().enumerate() {
                src_rgb[i * cols.len() + gi] = v;
            }
        }
        let sol = if c == 0 {
            None
        } else {
            Some(hier.solve(
                &self.rho,
                &src,
                c,
                HIERARCHY_TOL,
                HIERARCHY_MAX_SWEEPS,
                self.progress,
            ))
        };
        let pick = |x: &[f32], gi: usize| -> Vec<f32> {
            (0..n)
                .flat_map(|i| (0..3).map(move |ch| x[i * c + 3 * gi + ch]))
                .collect()
        };
        let groups = (0..g)
            .map(|gi| {
                let sol = sol.as_ref().expect("groups imply columns");
                self.group_columns(gi, pick(&sol.b, gi), pick(&sol.h, gi))
            })
            .collect();
        let sky = sky.map(|d| {
            let sol = sol.as_ref().expect("sky patches imply columns");
            let indirect = (0..d.k).map(|k| pick(&sol.h, g + k)).collect();
            SkyColumns::new(d, indirect)
        });
        let info = SolveInfo {
            residual: sol.as_ref().map_or(0.0, |s| s.residual),
            sweeps: sol.as_ref().map_or(0, |s| s.sweeps),
        };
        (self.progress)(1.0);
        Transfer {
            sky,
            mode: TransferMode::Hierarchical,
            n,
            rho: self.rho,
            area: self.area,
            escape,
            groups,
            factored: None,
            hierarchy: Some(hier),
            coarse: None,
            grids: vec![],
            grid_gathers: vec![],
            info,
        }
    }

    /// The factored and columns modes, from the dense `F`.
    fn dense(self, f: Vec<f32>, sky: Option<SkyDirect>, mode: TransferMode) -> Transfer {
        let n = self.n;
        let escape: Vec<f32> = crate::transport::formfactor::row_sums(&f, n)
            .into_iter()
            .map(|s| (1.0 - s).max(0.0) as f32)
            .collect();
        let rho_ch: [Vec<f32>; 3] =
            std::array::from_fn(|c| self.rho.iter().map(|r| r[c]).collect());
        let g = self.emission.len();
        let e = source_matrix(&self.emission, self.direct, sky.as_ref(), &self.rho);
        let rho_of_col: Vec<&[f32]> = (0..e.ncols()).map(|k| rho_ch[k % 3].as_slice()).collect();

        let (b, factored, sweeps) = match mode {
            TransferMode::Factored => {
                let fac = factor_responses(&f, &rho_ch, n, self.progress);
                let b = solve_refined(&fac, &f, e.as_ref(), &rho_of_col);
                (b, Some(fac), 0)
            }
            TransferMode::Columns | TransferMode::Hierarchical => {
                let (b, sweeps) = solve::jacobi(
                    &f,
                    n,
                    e.as_ref(),
                    &rho_of_col,
                    COLUMN_TOL,
                    2000,
                    self.progress,
                );
                (b, None, sweeps)
            }
        };
        let h = solve::apply_f(&f, n, b.as_ref());
        let residual = max_residual(&e, &b, &h, &rho_of_col);
        let rgb = |m: &Mat<f32>, col: usize| solve::interleave(m.as_ref(), [col, col + 1, col + 2]);
        let groups = (0..g)
            .map(|gi| self.group_columns(gi, rgb(&b, 3 * gi), rgb(&h, 3 * gi)))
            .collect();
        let sky = sky.map(|d| {
            let indirect = (0..d.k).map(|k| rgb(&h, 3 * (g + k))).collect();
            SkyColumns::new(d, indirect)
        });
        drop(f);
        (self.progress)(1.0);
        Transfer {
            sky,
            mode,
            n,
            rho: self.rho,
            area: self.area,
            escape,
            groups,
            factored,
            hierarchy: None,
            coarse: None,
            grids: vec![],
            grid_gathers: vec![],
            info: SolveInfo { residual, sweeps },
        }
    }

    /// Group `gi`'s columns from its solved radiosity `b` and reflected illuminance `h`
    /// (n × 3): `h` gets the group's direct light added, and the luminaires' flux is
    /// summed over the patch areas.
    fn group_columns(&self, gi: usize, b: Vec<f32>, mut h: Vec<f32>) -> GroupColumns {
        let d = self.direct.get(gi).and_then(|d| d.as_deref());
        if let Some(d) = d {
            for (hv, dv) in h.iter_mut().zip(d) {
                *hv += dv;
            }
        }
        let (flux, landed) =
            crate::transport::direct::group_flux(&self.scene.lights[gi], &self.area, d);
        GroupColumns {
            e: self.emission[gi].clone(),
            b,
            h,
            flux,
            landed,
        }
    }
}

/// Solves `(I − ρF) X = E` for the columns of `e` (column k uses channel k % 3) with the
/// irradiance responses: `X = E + ρ K E`, then one step of iterative refinement with `F`.
pub fn solve_refined(
    fac: &Factored,
    f: &[f32],
    e: faer::MatRef<'_, f32>,
    rho_of_col: &[&[f32]],
) -> Mat<f32> {
    let n = e.nrows();
    // T x = x + ρ K x
    let through = |x: faer::MatRef<'_, f32>| fac.radiosity(x, rho_of_col).0;
    let mut x = through(e);
    // r = E − (X − ρ F X); X += T r
    let fx = solve::apply_f(f, n, x.as_ref());
    let mut r = Mat::<f32>::zeros(n, e.ncols());
    for k in 0..e.ncols() {
        let rho = rho_of_col[k];
        for i in 0..n {
            r[(i, k)] = e[(i, k)] - (x[(i, k)] - rho[i] * fx[(i, k)]);
        }
    }
    let dx = through(r.as_ref());
    for k in 0..e.ncols() {
        for i in 0..n {
            x[(i, k)] += dx[(i, k)];
        }
    }
    x
}
