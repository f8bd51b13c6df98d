//! Emission answers in hierarchical mode: the sweeps (Jacobi) and GMRES after fixed pass
//! counts (`PASSES=5,10,15,20` by default) and GMRES as the server ran it before the
//! coarse preconditioner (to `EMISSION_TOL`, unpreconditioned); with `COARSE=m1,m2,…`, the
//! coarse transfer of a cut of about m clusters, and GMRES preconditioned by it to each
//! tolerance of `PTOL` (default 0.01; the server: `COARSE=1000`, [`EMISSION_TOL`]).
//! Each against a solve converged far past them (sweeps to 1e-9), per surface of ≥ 1 m²
//! (mean incident illuminance) and per patch (incident illuminance), with each answer's
//! power balance and time. The accuracy check of #47's fast transfer.
//!
//! `cargo run --release --example emission_solvers -- SCENE_DIR CACHE_DIR`
//! (the scene baked in hierarchical mode, e.g. scenes/office-floor).

use std::time::Instant;

use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb64;
use relight::model::report::surface_averages;
use relight::transport::transfer::{Solution, Transfer, EMISSION_MAX_PASSES, EMISSION_TOL};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn solution(e: &[f32], b: Vec<f32>, h: Vec<f32>) -> Solution {
    Solution {
        e: e.to_vec(),
        b,
        h,
        luminaire_flux: Rgb64::ZERO,
        direct_escaped: Rgb64::ZERO,
    }
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let b = load_or_bake(
        std::path::Path::new(&a[1]),
        CachePolicy::ReadWrite(std::path::Path::new(&a[2])),
        &BakeOptions::default(),
        &|_, _| {},
    )
    .expect("bake");
    let t: &Transfer = &b.transfer;
    let hier = t.hierarchy.as_ref().expect("a hierarchical transfer");
    let n = t.n;
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let mut emissions: Vec<(&str, Vec<f32>)> = Vec::new();
    let mut one = vec![0f32; 3 * n];
    let p = n / 3;
    one[3 * p..3 * p + 3].copy_from_slice(&[1000.0; 3]);
    emissions.push(("one patch", one.clone()));
    // Light moved: one patch off, another on (a source of both signs).
    let mut moved = one;
    let q = 2 * n / 3;
    moved[3 * q..3 * q + 3].copy_from_slice(&[-1000.0; 3]);
    emissions.push(("moved", moved));
    let mut sparse = vec![0f32; 3 * n];
    for i in 0..n {
        if rng.next() < 0.01 {
            let v = (1000.0 * rng.next()) as f32;
            sparse[3 * i..3 * i + 3].copy_from_slice(&[v; 3]);
        }
    }
    emissions.push(("1 % of patches", sparse));
    let dense: Vec<f32> = (0..3 * n).map(|_| (100.0 * rng.next()) as f32).collect();
    emissions.push(("every patch", dense));
    let coarse: Vec<(usize, relight::transport::hierarchy::Coarse)> = std::env::var("COARSE")
        .unwrap_or_default()
        .split(',')
        .filter(|x| !x.is_empty())
        .map(|x| {
            let m: usize = x.parse().expect("COARSE: a list of cluster counts");
            let t0 = Instant::now();
            let c = hier.coarse(&b.mesh, &b.bvh, &t.rho, m);
            eprintln!(
                "coarse {m}: {} clusters, built in {:.2} s",
                c.area.len(),
                t0.elapsed().as_secs_f64()
            );
            (m, c)
        })
        .collect();
    for (name, e) in &emissions {
        let t0 = Instant::now();
        let truth = hier.solve(&t.rho, e, 3, 1e-9, 5000, &|_| {});
        eprintln!(
            "{name}: truth {} sweeps, {:.2} s, residual {:.1e}",
            truth.sweeps,
            t0.elapsed().as_secs_f64(),
            truth.residual
        );
        let ts = solution(e, truth.b, truth.h);
        let sa = surface_averages(&b.scene, &b.mesh, &ts);
        let hmax = ts.h.iter().cloned().fold(0f32, f32::max) as f64;
        let mut runs: Vec<(
            String,
            relight::transport::hierarchy::HierarchySolution,
            f64,
        )> = Vec::new();
        let passes: Vec<usize> = std::env::var("PASSES")
            .unwrap_or("5,10,15,20".into())
            .split(',')
            .map(|p| p.parse().expect("PASSES: a list of counts"))
            .collect();
        for &k in &passes {
            let t0 = Instant::now();
            let s = hier.solve(&t.rho, e, 3, 0.0, k, &|_| {});
            runs.push((format!("sweeps ×{k}"), s, t0.elapsed().as_secs_f64()));
        }
        for &k in &passes {
            let t0 = Instant::now();
            let s = hier.solve_krylov(&t.rho, e, 3, 0.0, k);
            runs.push((format!("gmres ×{k}"), s, t0.elapsed().as_secs_f64()));
        }
        for (m, c) in &coarse {
            let pre = |v: &[f32]| c.precondition(&hier.area, v, 3);
            let tols: Vec<f64> = std::env::var("PTOL")
                .unwrap_or("0.01".into())
                .split(',')
                .map(|x| x.parse().expect("PTOL: tolerances"))
                .collect();
            for tol in tols {
                let t0 = Instant::now();
                let s = hier.solve_krylov_with(&t.rho, e, 3, tol, EMISSION_MAX_PASSES, Some(&pre));
                runs.push((format!("pgmres {m} {tol}"), s, t0.elapsed().as_secs_f64()));
            }
        }
        // As the server answers: to EMISSION_TOL.
        let t0 = Instant::now();
        let s = hier.solve_krylov(&t.rho, e, 3, EMISSION_TOL, EMISSION_MAX_PASSES);
        runs.push((
            format!("gmres {EMISSION_TOL:.0e}"),
            s,
            t0.elapsed().as_secs_f64(),
        ));
        for (label, s, secs) in runs {
            let cand = solution(e, s.b, s.h);
            let sb = surface_averages(&b.scene, &b.mesh, &cand);
            let mut worst = 0f64;
            let mut worst_level = 0f64;
            let top = sa
                .values()
                .map(|x| x.illuminance.iter().sum::<f64>())
                .fold(0f64, f64::max);
            for (k, x) in &sa {
                let Some(y) = sb.get(k) else { continue };
                let (p, q) = (
                    x.illuminance.iter().sum::<f64>(),
                    y.illuminance.iter().sum::<f64>(),
                );
                if x.area >= 1.0 && p > 0.0 && (q / p - 1.0).abs() > worst {
                    worst = (q / p - 1.0).abs();
                    worst_level = p / top;
                }
            }
            // Per patch (channel mean), patches lit above 1e-9 of the brightest.
            let mut errs: Vec<f64> =
                ts.h.chunks_exact(3)
                    .zip(cand.h.chunks_exact(3))
                    .filter_map(|(x, y)| {
                        let p = x.iter().map(|&v| v as f64).sum::<f64>();
                        let q = y.iter().map(|&v| v as f64).sum::<f64>();
                        (p > 3e-9 * hmax).then(|| (q / p - 1.0).abs())
                    })
                    .collect();
            errs.sort_by(f64::total_cmp);
            let p99 = errs[(errs.len() as f64 * 0.99) as usize];
            let pw = t.power(&cand);
            let em: f64 = pw.emitted.iter().sum();
            let bal = (em - pw.absorbed.iter().sum::<f64>() - pw.escaped.iter().sum::<f64>()) / em;
            println!(
                "{name:<17} {label:<13} {:>4} passes {:>7.1} ms  surfaces worst {:>7.4} % (at {:.0e} of the brightest)  patches p99 {:>7.4} %  balance {:>9.2e}",
                s.sweeps,
                secs * 1e3,
                100.0 * worst,
                worst_level,
                100.0 * p99,
                bal
            );
        }
    }
}
