//! The solved transfer against known answers: the furnace, the unit cube's 6 × 6 system,
//! energy balance, agreement of the two modes, and linearity of relighting.

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
use relight::model::lighting::{LightSetting, LightState};
use relight::transport::transfer::TransferMode;

use crate::common::{self, *};

fn bake(dir: &std::path::Path, opts: BakeOptions) -> Baked {
    load_or_bake(dir, CachePolicy::Off, &opts, &|_, _| {}).expect("bakes")
}

fn surface_mean(b: &Baked, sol: &[f32], name: &str) -> [f64; 3] {
    let s = b.scene.surface_index(name).unwrap();
    let mut acc = [0f64; 3];
    let mut area = 0f64;
    for i in b.mesh.surface_patches[s].clone() {
        let a = b.mesh.patches[i as usize].area;
        area += a;
        for c in 0..3 {
            acc[c] += a * sol[3 * i as usize + c] as f64;
        }
    }
    acc.map(|x| x / area)
}

#[test]
fn furnace_closed_room_with_uniform_emission() {
    let _gate = common::shared();
    // Every surface emits E = 10 and reflects ρ = 0.5: B = E / (1 − ρ) = 20 everywhere.
    let obj = box_faces("room", "glow", [0., 0., 0.], [3., 2.5, 2.], true);
    let s = write_scene(
        &obj,
        "newmtl glow\nKd 0.5 0.5 0.5\nKe 10 10 10\n",
        Some("[mesh]\ntarget_patches = 1500\n"),
    );
    let b = bake(s.path(), BakeOptions::default());
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let worst = sol
        .b
        .iter()
        .map(|&x| (x as f64 / 20.0 - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.005,
        "worst patch deviates from E/(1−ρ) by {worst:.4}"
    );
}

/// Exact 6 × 6 radiosities of a unit cube with face 0 emitting E, by symmetry reduced to
/// (emitter, each adjacent face, opposite face).
fn cube_6x6(e: f64, rho: f64) -> (f64, f64, f64) {
    let (fa, fo) = (0.200044, 0.199825);
    // B_e = E + ρ(4 fa B_a + fo B_o)
    // B_a = ρ(fa B_e + (2 fa + fo) B_a + fa B_o)
    // B_o = ρ(fo B_e + 4 fa B_a)
    // Solve by fixed-point iteration (converges: ρ < 1).
    let (mut be, mut ba, mut bo) = (e, 0.0, 0.0);
    for _ in 0..500 {
        be = e + rho * (4.0 * fa * ba + fo * bo);
        ba = rho * (fa * be + (2.0 * fa + fo) * ba + fa * bo);
        bo = rho * (fo * be + 4.0 * fa * ba);
    }
    (be, ba, bo)
}

fn unit_cube(target: Option<&str>) -> TempScene {
    // Faces named by axis; the -y face (floor) emits upward into the cube.
    let mut obj = String::new();
    let faces = box_faces("f", "white", [0., 0., 0.], [1., 1., 1.], true);
    obj += &faces.replace("o f-y\nusemtl white", "o f-y\nusemtl lamp");
    let mtl = "newmtl white\nKd 0.6 0.6 0.6\nnewmtl lamp\nKd 0.6 0.6 0.6\nKe 1 1 1\n";
    write_scene(&obj, mtl, target)
}

#[test]
fn unit_cube_face_factors_match_the_6x6_system() {
    let _gate = common::shared();
    // Coarsest meshing (two triangles per face): the face-to-face factors, summed over the
    // triangle patches, are the classic unit-cube values to 0.1 %, and so the face-level
    // 6 × 6 solution is reproduced.
    let s = unit_cube(Some("[mesh]\nmax_edge = 2.0\n"));
    let sol = form_factors(s.path());
    assert_eq!(sol.n(), 12);
    let adj = sol.surface_factor("f-y", "f-x");
    let opp = sol.surface_factor("f-y", "f+y");
    assert!((adj / 0.200044 - 1.0).abs() < 1e-3, "adjacent {adj}");
    assert!((opp / 0.199825 - 1.0).abs() < 1e-3, "opposite {opp}");
    // The face-level system built from these factors matches the analytic 6 × 6 answer.
    let names = ["f-y", "f-x", "f+x", "f-z", "f+z", "f+y"];
    let mut f = [[0f64; 6]; 6];
    for (a, na) in names.iter().enumerate() {
        for (b, nb) in names.iter().enumerate() {
            if a != b {
                f[a][b] = sol.surface_factor(na, nb);
            }
        }
    }
    let rho = 0.6;
    let mut bv = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for _ in 0..500 {
        let mut next = [0.0; 6];
        for a in 0..6 {
            next[a] =
                if a == 0 { 1.0 } else { 0.0 } + rho * (0..6).map(|k| f[a][k] * bv[k]).sum::<f64>();
        }
        bv = next;
    }
    let (be, ba, bo) = cube_6x6(1.0, rho);
    for (got, want) in [(bv[0], be), (bv[1], ba), (bv[4], ba), (bv[5], bo)] {
        assert!(
            (got / want - 1.0).abs() < 1e-3,
            "face radiosity {got} vs 6×6 {want}"
        );
    }
}

#[test]
fn finely_meshed_cube_conserves_energy_and_departs_from_6x6() {
    let _gate = common::shared();
    let s = unit_cube(None);
    let b = bake(s.path(), BakeOptions::default());
    let sol = b.transfer.relight(&[Rgb::ONE]);
    // Closed cube: area-weighted mean radiosity = Φ / (A (1 − ρ)) with Φ = 1 lm, A = 6 m².
    let total: f64 = (0..b.mesh.len())
        .map(|i| b.mesh.patches[i].area * sol.b[3 * i] as f64)
        .sum();
    let want = 1.0 / (6.0 * (1.0 - 0.6));
    assert!(
        (total / 6.0 / want - 1.0).abs() < 1e-3,
        "mean {} vs {want}",
        total / 6.0
    );
    // Per face, the continuous solution differs from the constant-per-face 6 × 6 one.
    let (be, ba, bo) = cube_6x6(1.0, 0.6);
    let mut max_dev = 0f64;
    for (name, want) in [("f-y", be), ("f-x", ba), ("f+z", ba), ("f+y", bo)] {
        let got = surface_mean(&b, &sol.b, name)[0];
        let dev = (got / want - 1.0).abs();
        assert!(dev < 0.06, "{name}: {got} vs 6×6 {want}");
        max_dev = max_dev.max(dev);
    }
    assert!(
        max_dev > 0.002,
        "fine mesh should resolve non-uniform radiosity ({max_dev})"
    );
}

#[test]
fn energy_balance_closed_and_open() {
    let _gate = common::shared();
    // Closed room with a lamp: emitted = absorbed.
    let obj = box_faces("room", "wall", [0., 0., 0.], [3., 2.5, 2.], true)
        + &quad(
            "lamp",
            "lamp",
            [
                [1., 2.49, 0.8],
                [2., 2.49, 0.8],
                [2., 2.49, 1.2],
                [1., 2.49, 1.2],
            ],
            [0., -1., 0.],
        );
    let mtl = "newmtl wall\nKd 0.7 0.5 0.3\nnewmtl lamp\nKd 0 0 0\nKe 100 100 100\n";
    let s = write_scene(&obj, mtl, Some("[mesh]\ntarget_patches = 1200\n"));
    let b = bake(s.path(), BakeOptions::default());
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let p = b.transfer.power(&sol);
    for c in 0..3 {
        assert!(
            (p.emitted[c] - 40.0).abs() < 1e-3,
            "emitted {}",
            p.emitted[c]
        );
        let rel = (p.emitted[c] - p.absorbed[c]) / p.emitted[c];
        assert!(
            rel.abs() < 0.005,
            "closed room: emitted {} absorbed {}",
            p.emitted[c],
            p.absorbed[c]
        );
    }
    // Open box (no ceiling): emitted = absorbed + escaped, and a real share escapes.
    let obj: String = box_faces("room", "wall", [0., 0., 0.], [3., 2.5, 2.], true)
        .split("o ")
        .filter(|f| !f.is_empty() && !f.starts_with("room+y"))
        .map(|f| format!("o {f}"))
        .collect::<String>()
        + &quad(
            "lamp",
            "lamp",
            [
                [1., 1.0, 0.8],
                [2., 1.0, 0.8],
                [2., 1.0, 1.2],
                [1., 1.0, 1.2],
            ],
            [0., -1., 0.],
        );
    let s = write_scene(&obj, mtl, Some("[mesh]\ntarget_patches = 1200\n"));
    let b = bake(s.path(), BakeOptions::default());
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let p = b.transfer.power(&sol);
    for c in 0..3 {
        let rel = (p.emitted[c] - p.absorbed[c] - p.escaped[c]) / p.emitted[c];
        assert!(rel.abs() < 1e-4, "open box: imbalance {rel}");
        assert!(p.escaped[c] > 0.05 * p.emitted[c]);
    }
}

/// A colour on one wall: green's and blue's irradiance responses then differ from red's on
/// that wall's patches only, and are made as rank-k updates of red's
/// (`solve::updated_response`). Per-patch emissions (one patch, sparse; every patch,
/// dense) must still solve the radiosity system exactly in every channel, checked against
/// dense form factors computed apart: `B − ρ F B = E` and `H = F B`.
#[test]
fn a_red_wall_answers_emission_exactly_in_every_channel() {
    let _gate = common::shared();
    let obj: String = box_quads([0., 0., 0.], [3., 2.5, 2.], true)
        .iter()
        .map(|(k, p, n)| {
            quad(
                &format!("room{k}"),
                if *k == "+x" { "red" } else { "wall" },
                *p,
                *n,
            )
        })
        .collect();
    let mtl = "newmtl wall\nKd 0.6 0.6 0.6\nnewmtl red\nKd 0.7 0.12 0.05\n";
    let s = write_scene(&obj, mtl, Some("[mesh]\ntarget_patches = 900\n"));
    let opts = BakeOptions {
        mode: Some(TransferMode::Factored),
        ..Default::default()
    };
    let b = bake(s.path(), opts);
    let fac = b.transfer.factored.as_ref().expect("factored");
    assert_eq!(fac.channel, [0, 1, 2], "three distinct channels");
    let solved = form_factors(s.path());
    let n = solved.n();
    assert_eq!(n, b.mesh.len());
    let red = b.scene.surface_index("room+x").unwrap();
    let on_red = b.mesh.surface_patches[red].start as usize;
    let mut one = vec![0f32; 3 * n];
    one[3 * on_red..3 * on_red + 3].copy_from_slice(&[50.0, 40.0, 30.0]);
    let dense: Vec<f32> = (0..3 * n).map(|k| 1.0 + (k % 7) as f32).collect();
    for (name, e) in [("one patch", one), ("dense", dense)] {
        let sol = b.transfer.solve(&e).unwrap();
        // Against the reflected light: the emitting patch's own E would hide its errors.
        let scale = sol
            .b
            .iter()
            .zip(&e)
            .fold(0f32, |m, (&x, &ek)| m.max((x - ek).abs())) as f64;
        let mut worst = 0f64;
        for i in 0..n {
            for c in 0..3 {
                let fb: f64 = (0..n)
                    .map(|j| solved.f[i * n + j] as f64 * sol.b[3 * j + c] as f64)
                    .sum();
                let rho = b.transfer.rho[i][c] as f64;
                let residual = sol.b[3 * i + c] as f64 - rho * fb - e[3 * i + c] as f64;
                worst = worst
                    .max(residual.abs())
                    .max((sol.h[3 * i + c] as f64 - fb).abs());
            }
        }
        assert!(
            worst <= 1e-4 * scale,
            "{name}: B − ρFB − E or H − FB off by {worst:.2e} of {scale:.2e}"
        );
    }
}

fn desk_room(mode: TransferMode) -> Baked {
    bake(
        &scenes_dir().join("desk-room"),
        BakeOptions {
            max_edge: Some(0.5),
            mode: Some(mode),
            ..Default::default()
        },
    )
}

#[test]
fn factored_and_columns_modes_agree() {
    let _gate = common::shared();
    let f = desk_room(TransferMode::Factored);
    let c = desk_room(TransferMode::Columns);
    assert_eq!(f.transfer.mode, TransferMode::Factored);
    assert_eq!(c.transfer.mode, TransferMode::Columns);
    assert!(c.transfer.info.sweeps > 3);
    for g in 0..2 {
        let (a, b) = (&f.transfer.groups[g].b, &c.transfer.groups[g].b);
        let scale = a.iter().fold(0f32, |m, x| m.max(x.abs()));
        let worst = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0f32, f32::max);
        assert!(
            worst / scale < 1e-4,
            "group {g}: max diff {worst} of {scale}"
        );
        // Relative to each patch's own value, for patches that are lit at all.
        for (x, y) in a.iter().zip(b) {
            if x.abs() > 1e-3 * scale {
                assert!(((x - y) / x).abs() < 1e-4, "{x} vs {y}");
            }
        }
    }
}

#[test]
fn relighting_is_linear_and_mixes_colours_per_channel() {
    let _gate = common::shared();
    let b = desk_room(TransferMode::Factored);
    let scene = &b.scene;
    let weights = |ceiling: LightSetting, lamp: LightSetting| {
        let mut st = LightState::default();
        st.lights.insert("ceiling".into(), ceiling);
        st.lights.insert("lamp".into(), lamp);
        st.weights(scene).unwrap()
    };
    let on = |i: f32| LightSetting {
        intensity: i,
        color: Rgb::ONE,
    };
    let base = b.transfer.relight(&weights(on(1.0), on(0.0)));
    let one = b.transfer.relight(&weights(on(1.0), on(1.0)));
    let two = b.transfer.relight(&weights(on(1.0), on(2.0)));
    for k in 0..base.b.len() {
        let d1 = one.b[k] - base.b[k];
        let d2 = two.b[k] - base.b[k];
        assert!(
            (d2 - 2.0 * d1).abs() <= 1e-4 * d2.abs().max(1e-3),
            "doubling at {k}: {d1} {d2}"
        );
    }
    // A red filter on the lamp keeps only the lamp's red response.
    let red = b.transfer.relight(&weights(
        on(0.0),
        LightSetting {
            intensity: 1.0,
            color: Rgb::new(1.0, 0.0, 0.0),
        },
    ));
    let lamp = b.transfer.relight(&weights(on(0.0), on(1.0)));
    for i in 0..b.mesh.len() {
        assert_eq!(red.b[3 * i + 1], 0.0);
        assert_eq!(red.b[3 * i + 2], 0.0);
        assert!((red.b[3 * i] - lamp.b[3 * i]).abs() <= 1e-6 * lamp.b[3 * i].abs().max(1.0));
    }
    // The mix equals the exact solve of the mixed emission vector (factored mode).
    let mix = weights(
        on(0.3),
        LightSetting {
            intensity: 2.0,
            color: Rgb::new(1.0, 0.5, 0.25),
        },
    );
    let relit = b.transfer.relight(&mix);
    let solved = b.transfer.solve(&relit.e).expect("factored");
    let scale = relit.b.iter().fold(0f32, |m, x| m.max(x.abs()));
    for k in 0..relit.b.len() {
        assert!((relit.b[k] - solved.b[k]).abs() < 1e-4 * scale, "B at {k}");
        assert!((relit.h[k] - solved.h[k]).abs() < 1e-4 * scale, "H at {k}");
    }
    // Lumens in scene.toml set each group's flux at intensity 1.
    let lamp_only = b
        .transfer
        .power(&b.transfer.relight(&weights(on(0.0), on(1.0))));
    let y = lamp_only.emitted.luminance();
    assert!((y - 400.0).abs() < 0.01, "lamp emits {y} lm");
}
