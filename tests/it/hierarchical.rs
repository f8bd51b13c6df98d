//! The hierarchical transfer: closure in a closed scene, agreement with the factored mode
//! and the Cornell reference, per-patch emission solved by sweeps, and the cache.

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
use relight::model::report::surface_averages;
use relight::transport::transfer::TransferMode;

use crate::common::{self, box_faces, quad, scenes_dir, write_scene, TempScene};

fn bake(dir: &std::path::Path, mode: TransferMode) -> Baked {
    let opts = BakeOptions {
        mode: Some(mode),
        ..Default::default()
    };
    load_or_bake(dir, CachePolicy::Off, &opts, &|_, _| {}).unwrap()
}

/// A closed 2 × 1.5 × 1 m room with a block on the floor and a lamp panel under the
/// ceiling facing down.
pub(crate) fn closed_room() -> TempScene {
    closed_room_of(1500)
}

/// The closed room meshed to about `patches` patches.
pub(crate) fn closed_room_of(patches: usize) -> TempScene {
    let mut obj = box_faces("room", "white", [0., 0., 0.], [2., 1.5, 1.], true);
    obj += &box_faces("block", "grey", [0.3, 0., 0.3], [0.7, 0.5, 0.6], false);
    obj += &quad(
        "lamp",
        "lamp",
        [
            [0.8, 1.49, 0.4],
            [1.2, 1.49, 0.4],
            [1.2, 1.49, 0.6],
            [0.8, 1.49, 0.6],
        ],
        [0., -1., 0.],
    );
    let mtl = "newmtl white\nKd 0.7 0.7 0.7\nnewmtl grey\nKd 0.4 0.5 0.3\n\
               newmtl lamp\nKd 0 0 0\nKe 20 20 20\n";
    write_scene(
        &obj,
        mtl,
        Some(&format!(
            "[mesh]\ntarget_patches = {patches}\n[[lights]]\nid = \"lamp\"\nmaterials = [\"lamp\"]\n"
        )),
    )
}

#[test]
fn hierarchical_closed_room_conserves_energy_and_agrees_with_factored() {
    let _gate = common::shared();
    let s = closed_room();
    let h = bake(s.path(), TransferMode::Hierarchical);
    let f = bake(s.path(), TransferMode::Factored);
    let hier = h.transfer.hierarchy.as_ref().expect("links");
    assert!(h.transfer.factored.is_none());
    // Every patch's form factors sum to 1 in a closed scene (after closure), except where
    // a patch sees the lamp's back face (the ceiling above it) or the inside of the
    // bottomless block (floor patches reaching under it): light lost there.
    let sums = hier.factor_sums();
    let under_block = |i: usize| {
        h.mesh
            .element_corners(i)
            .iter()
            .any(|p| p.y.abs() < 1e-9 && (0.3..=0.7).contains(&p.x) && (0.3..=0.6).contains(&p.z))
    };
    let open: Vec<usize> = (0..sums.len()).filter(|&i| !under_block(i)).collect();
    let closed = open
        .iter()
        .filter(|&&i| (sums[i] * hier.sigma[i] as f64 - 1.0).abs() < 1e-3)
        .count();
    assert!(
        closed as f64 > 0.9 * open.len() as f64,
        "{closed} of {} patches sum to 1",
        open.len()
    );
    assert!(open.len() > sums.len() * 3 / 4);
    // Before closure the links alone are within a few per cent on average.
    assert!(hier.stats.closure_mean < 0.05, "{:?}", hier.stats);
    // Fewer links than the n² pairs.
    let n = h.mesh.len() as u64;
    assert!(
        hier.stats.links < n * n / 4,
        "{} links for {n}",
        hier.stats.links
    );
    // The power balance holds and almost nothing escapes.
    let on = [Rgb::ONE];
    let (sh, sf) = (h.transfer.relight(&on), f.transfer.relight(&on));
    let p = h.transfer.power(&sh);
    for c in 0..3 {
        let rel = (p.emitted[c] - p.absorbed[c] - p.escaped[c]) / p.emitted[c];
        assert!(rel.abs() < 0.01, "imbalance {rel}");
        assert!(
            p.escaped[c] < 0.01 * p.emitted[c],
            "escaped {:?}",
            p.escaped
        );
    }
    assert!(
        h.transfer.info.residual < 1e-5,
        "{}",
        h.transfer.info.residual
    );
    // Per surface close to the factored mode.
    let (ah, af) = (
        surface_averages(&h.scene, &h.mesh, &sh),
        surface_averages(&f.scene, &f.mesh, &sf),
    );
    let (mut worst, mut wsum, mut asum) = (0f64, 0f64, 0f64);
    for (name, x) in &af {
        let y = &ah[name];
        if x.radiosity.iter().sum::<f64>() <= 0.0 {
            continue; // the block's underside, dark in both
        }
        let rel = y.radiosity.iter().sum::<f64>() / x.radiosity.iter().sum::<f64>() - 1.0;
        eprintln!("{name}: {:+.3} %", 100.0 * rel);
        worst = worst.max(rel.abs());
        wsum += x.area * rel.abs();
        asum += x.area;
    }
    // Measured: under 0.1 % on the room, worst 0.43 % (a side of the block).
    assert!(wsum / asum < 0.005, "mean |rel. diff| {}", wsum / asum);
    assert!(worst < 0.015, "worst |rel. diff| {worst}");
}

#[test]
fn hierarchical_cornell_box_matches_the_reference() {
    let _gate = common::shared();
    let b = bake(
        &scenes_dir().join("cornell-box"),
        TransferMode::Hierarchical,
    );
    let sol = b.transfer.relight(&[Rgb::ONE]);
    let ours = surface_averages(&b.scene, &b.mesh, &sol);
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/cornell_reference.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let (mut worst, mut wsum, mut asum) = (0f64, 0f64, 0f64);
    for (name, r) in reference["states"]["white"]["surfaces"]
        .as_object()
        .unwrap()
    {
        if name == "light" {
            continue;
        }
        let area = r["area_m2"].as_f64().unwrap();
        let mut mean = 0.0;
        for c in 0..3 {
            let want = r["radiosity_B"][c].as_f64().unwrap();
            let rel = (ours[name.as_str()].radiosity[c] - want) / want;
            worst = worst.max(rel.abs());
            mean += rel.abs() / 3.0;
        }
        wsum += area * mean;
        asum += area;
    }
    // Measured: mean 0.21 %, worst 0.58 % (the factored mode: 0.11 %, 0.61 %). The
    // limits are the targets.
    assert!(wsum / asum < 0.003, "mean |rel. err| {}", wsum / asum);
    assert!(worst < 0.01, "worst |rel. err| {worst}");
    // Light in = light absorbed + light out through the front, per channel (measured:
    // 0.07 % apart; the links are not exactly reciprocal).
    let p = b.transfer.power(&sol);
    for c in 0..3 {
        let rel = (p.emitted[c] - p.absorbed[c] - p.escaped[c]) / p.emitted[c];
        assert!(rel.abs() < 0.002, "imbalance {rel}");
    }
}

#[test]
fn hierarchical_solves_per_patch_emission_and_survives_the_cache() {
    let _gate = common::shared();
    let s = closed_room();
    let cache = tempfile::tempdir().unwrap();
    let opts = BakeOptions {
        mode: Some(TransferMode::Hierarchical),
        ..Default::default()
    };
    let a = load_or_bake(
        s.path(),
        CachePolicy::ReadWrite(cache.path()),
        &opts,
        &|_, _| {},
    )
    .unwrap();
    let b = load_or_bake(
        s.path(),
        CachePolicy::ReadWrite(cache.path()),
        &opts,
        &|_, _| {},
    )
    .unwrap();
    assert!(!a.stats.from_cache && b.stats.from_cache);
    let (ha, hb) = (
        a.transfer.hierarchy.as_ref().unwrap(),
        b.transfer.hierarchy.as_ref().unwrap(),
    );
    assert_eq!(ha.links.src, hb.links.src);
    assert_eq!(ha.links.k, hb.links.k);
    assert_eq!(ha.links.vis, hb.links.vis);
    assert_eq!(ha.stats, hb.stats);
    assert_eq!(a.transfer.groups[0].b, b.transfer.groups[0].b);
    // The lamp's emission as a per-patch vector, solved by sweeps, equals its group column.
    let relit = b.transfer.relight(&[Rgb::ONE]);
    let solved = b
        .transfer
        .solve(&relit.e)
        .expect("hierarchical solves emission");
    let scale = relit.b.iter().fold(0f32, |m, x| m.max(x.abs()));
    for k in 0..relit.b.len() {
        assert!((relit.b[k] - solved.b[k]).abs() < 1e-5 * scale, "B at {k}");
        assert!((relit.h[k] - solved.h[k]).abs() < 1e-5 * scale, "H at {k}");
    }
    // Single patches' emissions, swept together (a batch), equal their own solves; each
    // converges within the sweeps of the bake's group solve, which is what the batch
    // limit (`model::batch::hierarchy_sweep_work`) predicts from.
    let t = &b.transfer;
    let (n, hier) = (t.n, t.hierarchy.as_ref().unwrap());
    let singles: Vec<Vec<f32>> = (0..8)
        .map(|k| {
            let mut e = vec![0f32; 3 * n];
            let p = k * n / 8 + 3;
            e[3 * p..3 * p + 3].copy_from_slice(&[1.0, 2.0, 0.5]);
            e
        })
        .collect();
    let refs: Vec<&[f32]> = singles.iter().map(|e| e.as_slice()).collect();
    let together = t.solve_many(&refs).unwrap();
    for (e, s) in singles.iter().zip(&together) {
        let one = hier.solve(
            &t.rho,
            e,
            3,
            relight::transport::transfer::HIERARCHY_TOL,
            relight::transport::transfer::HIERARCHY_MAX_SWEEPS,
            &|_| {},
        );
        eprintln!(
            "single-patch emission: {} sweeps (the bake's: {})",
            one.sweeps, t.info.sweeps
        );
        assert!(one.sweeps <= t.info.sweeps, "{} sweeps", one.sweeps);
        let scale = one.b.iter().fold(0f32, |m, x| m.max(x.abs()));
        for k in 0..3 * n {
            assert!((s.b[k] - one.b[k]).abs() <= 1e-5 * scale, "B at {k}");
        }
    }
}

#[test]
fn office_floor_is_a_real_size_scene() {
    let _gate = common::shared();
    // The bundled office floor (scenes/office-floor, written by its make_scene.py) is what
    // the hierarchical mode is for; the tests do not bake it (`relight bench --scene`
    // measures it), but it must load and mesh to the size docs/scene-format.md states.
    let dir = common::bundled_scenes().join("office-floor");
    let scene = relight::scene::Scene::load(&dir).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    assert!(mesh.len() >= 150_000, "{} patches", mesh.len());
    let luminaires: usize = scene.lights.iter().map(|g| g.luminaires.len()).sum();
    assert!(luminaires >= 40, "{luminaires} luminaires");
    assert!(scene.lights.len() >= 8, "{} groups", scene.lights.len());
    assert!(scene.grids.len() >= 3, "{} grids", scene.grids.len());
    assert!(scene.cameras.len() >= 2);
    assert_eq!(scene.transfer, relight::scene::TransferChoice::Hierarchical);
    // Every luminaire hangs inside the floor's bounds, below the ceiling.
    let (lo, hi) = mesh.vertices.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), v| {
            (
                [lo[0].min(v.x), lo[1].min(v.y), lo[2].min(v.z)],
                [hi[0].max(v.x), hi[1].max(v.y), hi[2].max(v.z)],
            )
        },
    );
    assert!(
        hi[0] - lo[0] >= 25.0 && hi[2] - lo[2] >= 12.0,
        "{lo:?} {hi:?}"
    );
    for g in &scene.lights {
        for l in &g.luminaires {
            let p = l.position;
            assert!(
                p.y < hi[1] && p.y > lo[1] && p.x > lo[0] && p.x < hi[0],
                "{p:?}"
            );
        }
    }
}

/// A hierarchical bake split into parts (as sharded bakes split it over machines) gives
/// the same links, closure and radiosity, bit for bit, for 1, 3 and 7 parts.
#[test]
fn parts_of_a_hierarchical_bake_assemble_to_the_same_bits() {
    use relight::transport::hierarchy::{HierarchyOptions, Plan};
    let _gate = common::shared();
    let s = closed_room_of(600);
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    let bvh = relight::bake::scene_bvh(&scene);
    let front = relight::bake::triangle_sides(&scene);
    let direct = relight::transport::direct::group_direct(&scene, &mesh, &bvh);
    let rho = relight::transport::transfer::patch_rho(&scene, &mesh);
    let sources = relight::transport::transfer::all_sources(&scene, &mesh, &direct);
    let opts = HierarchyOptions::default();
    let ff = relight::transport::formfactor::FormFactorOptions::default();
    let src: Vec<f32> = sources.iter().flat_map(|&v| [v as f32; 3]).collect();
    let mut first = None;
    for n in [1usize, 3, 7] {
        let plan = Plan::new(&mesh, &rho, &sources).per_group_accuracy(true);
        let shards = plan.shards(n);
        assert_eq!(shards.len(), n);
        assert_eq!(
            shards.iter().map(Vec::len).sum::<usize>(),
            plan.plane_roots().len()
        );
        let parts: Vec<_> = shards
            .iter()
            .map(|roots| plan.part(roots, &bvh, &front, opts, ff, &|_| {}))
            .collect();
        let (h, escape) = plan.assemble(parts, opts).unwrap();
        let b = h.solve(&rho, &src, 3, 1e-6, 1000, &|_| {}).b;
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let got = (
            h.links.offsets.clone(),
            h.links.src.clone(),
            bits(&h.links.k),
            h.links.vis.clone(),
            bits(&h.sigma),
            bits(&escape),
            bits(&b),
        );
        match &first {
            None => first = Some(got),
            Some(want) => assert!(*want == got, "{n} parts differ from one"),
        }
    }
    // A part missing, or a plane covered twice, is refused with its root named.
    let plan = Plan::new(&mesh, &rho, &sources);
    let shards = plan.shards(3);
    let parts: Vec<_> = shards[..2]
        .iter()
        .map(|roots| plan.part(roots, &bvh, &front, opts, ff, &|_| {}))
        .collect();
    let err = plan.assemble(parts, opts).err().unwrap();
    assert!(err.contains("no part covers plane root"), "{err}");
    let plan = Plan::new(&mesh, &rho, &sources);
    let twice = plan.part(&shards[0], &bvh, &front, opts, ff, &|_| {});
    let err = plan
        .assemble(vec![twice.clone(), twice], opts)
        .err()
        .unwrap();
    assert!(err.contains("repeated"), "{err}");
}

/// Two 3 cm plates standing 10 cm apart in a closed room under a lamp panel (as the end
/// panels of two desks placed end to end on the panel floor, benches/floor): the floor
/// and plate faces in and beside the slot see the room far less than their neighbours.
fn slot_room() -> TempScene {
    let mut obj = box_faces("room", "white", [0., 0., 0.], [3., 2., 2.5], true);
    obj += &box_faces("a", "grey", [1.37, 0., 0.25], [1.4, 1.2, 2.25], false);
    obj += &box_faces("b", "grey", [1.5, 0., 0.25], [1.53, 1.05, 2.25], false);
    obj += &quad(
        "lamp",
        "lamp",
        [
            [1.2, 1.99, 1.0],
            [1.8, 1.99, 1.0],
            [1.8, 1.99, 1.5],
            [1.2, 1.99, 1.5],
        ],
        [0., -1., 0.],
    );
    let mtl = "newmtl white\nKd 0.6 0.6 0.6\nnewmtl grey\nKd 0.5 0.5 0.5\n\
               newmtl lamp\nKd 0 0 0\nKe 1000 1000 1000\n";
    write_scene(
        &obj,
        mtl,
        Some("[mesh]\nmax_edge = 0.4\n[[lights]]\nid = \"lamp\"\nmaterials = [\"lamp\"]\n"),
    )
}

/// Partly visible links at cluster receivers were kept once their factor was below ε,
/// with the cluster's mean visibility. Pushed down, a leaf beside the slot (or under a
/// desk) got the mean of leaves that see nothing of the source, on every such link of its
/// cluster at once: on the panel floor, leaves' factor sums came out 25 % low (σ up to
/// 1.39 at max_edge 0.5, 1.55 at 0.25) and others high. They are now refined further at
/// clusters (`refine::PARTIAL_CLUSTER`), and the closure scale stays near 1.
#[test]
fn partly_visible_links_at_clusters_were_pushed_down_with_the_mean_visibility() {
    let _gate = common::shared();
    let s = slot_room();
    let b = bake(s.path(), TransferMode::Hierarchical);
    let hier = b.transfer.hierarchy.as_ref().expect("links");
    let n = hier.sigma.len();
    let far = hier
        .sigma
        .iter()
        .filter(|&&x| (x as f64 - 1.0).abs() > 0.1)
        .count();
    let (lo, hi) = (hier.stats.sigma_min, hier.stats.sigma_max);
    eprintln!(
        "{n} patches, {} links; sigma {lo:.4}..{hi:.4}; {far} off by more than 10 %; closure mean {:.2e}",
        hier.stats.links, hier.stats.closure_mean
    );
    // Measured (2,572 patches, 1.03M links): sigma 0.950..1.095, closure mean 1.37e-2;
    // before (the same room from the release CLI): 0.891..1.185, 1.81e-2. At max_edge
    // 0.3 (3,968 patches): 0.92..1.07 against 0.83..1.41, with 146 patches (3.7 %) off by
    // more than 10 %, the floor beside the plates and the plates' faces in the slot.
    assert!(
        far == 0,
        "{far} of {n} patches have sigma off by more than 10 %"
    );
    assert!(lo > 0.92 && hi < 1.12, "sigma {lo}..{hi}");
    assert!(hier.stats.closure_mean < 0.016, "{:?}", hier.stats);
}

/// Per surface of at least 1 m²: the worst relative difference of the mean incident
/// illuminance between two bakes, under light-group weights `w`; and each bake's power
/// imbalance (emitted − absorbed − escaped) over what was emitted.
fn worst_surface_and_imbalance(a: &Baked, b: &Baked, w: &[Rgb]) -> (String, f64, [f64; 2]) {
    let (sa, sb) = (a.transfer.relight(w), b.transfer.relight(w));
    let (ra, rb) = (
        surface_averages(&a.scene, &a.mesh, &sa),
        surface_averages(&b.scene, &b.mesh, &sb),
    );
    let mut worst = (String::new(), 0f64);
    for (name, x) in &ra {
        let want: f64 = x.illuminance.iter().sum();
        if x.area < 1.0 || want <= 0.0 {
            continue;
        }
        let got: f64 = rb[name].illuminance.iter().sum();
        let rel = got / want - 1.0;
        if rel.abs() > worst.1.abs() {
            worst = (name.clone(), rel);
        }
    }
    let balance = |t: &relight::transport::transfer::Transfer, s| {
        let p = t.power(s);
        let e: f64 = p.emitted.iter().sum();
        (e - p.absorbed.iter().sum::<f64>() - p.escaped.iter().sum::<f64>()) / e
    };
    (
        worst.0,
        worst.1,
        [balance(&a.transfer, &sa), balance(&b.transfer, &sb)],
    )
}

/// Three rooms in a row (benches/doors/make_scene.py at max_edge 0.5, with
/// `per_group_accuracy`): A and B joined by a door, B and C by a glazed internal window,
/// one light group per room. With one group on, the other rooms get 0.1–5 % of the lit
/// room's illuminance, all of it through the openings. The hierarchical mode read those
/// rooms up to 11 % low: links judged hidden by a few rays were dropped, and fixed
/// pairings of the link samples missed the lines of sight through both openings. With
/// per-group accuracy (links dropped as hidden only where a wall proves it) every group
/// alone, and a mixed state, agree with the factored mode within 2 % on every surface of
/// at least 1 m², and each state's power balances.
#[test]
fn rooms_lit_only_through_a_door_or_a_window_read_low_in_hierarchical_mode() {
    let _gate = common::shared();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/three-rooms");
    let f = bake(&dir, TransferMode::Factored);
    let h = bake(&dir, TransferMode::Hierarchical);
    assert_eq!(h.transfer.group_count(), 3);
    let one = |k: usize| {
        let mut w = vec![Rgb::ZERO; 3];
        w[k] = Rgb::ONE;
        w
    };
    let states = [
        ("a alone", one(0)),
        ("b alone", one(1)),
        ("c alone", one(2)),
        (
            "a off, b at 50 %",
            vec![Rgb::ZERO, Rgb::splat(0.5), Rgb::ONE],
        ),
        ("all on", vec![Rgb::ONE; 3]),
    ];
    for (name, w) in &states {
        let (surface, rel, [ef, eh]) = worst_surface_and_imbalance(&f, &h, w);
        eprintln!(
            "{name}: worst {surface} {:+.2} %; imbalance factored {ef:.1e}, hierarchical {eh:.1e}",
            100.0 * rel
        );
        assert!(
            rel.abs() < 0.02,
            "{name}: {surface} off by {:.2} %",
            100.0 * rel
        );
        // Each group's flux balance on its own, not only the sum's. Measured: at most
        // 1.7e-3 (a alone), the factored mode 1.5e-4: the closure scales what each
        // patch gathers, which the links' sums do not return exactly.
        assert!(eh.abs() < 2e-3, "{name}: hierarchical imbalance {eh:.2e}");
        assert!(ef.abs() < 1e-3, "{name}: factored imbalance {ef:.2e}");
    }
    emission_answers_equal_the_converged_sweeps(&h);
    // Not trivial: the rooms away from the lit one are dim, and the check reaches them.
    let s = f.transfer.relight(&one(0));
    let avg = surface_averages(&f.scene, &f.mesh, &s);
    let lux = |n: &str| avg[n].illuminance.iter().sum::<f64>() / 3.0;
    let ratio = lux("c_floor") / lux("a_floor");
    assert!(ratio < 3e-3, "room C gets {ratio:.1e} of room A");
}

/// An emission answer (GMRES through the links, [`relight::transport::transfer::EMISSION_TOL`])
/// against the same links swept to 10⁻¹⁰: one patch on room A's floor, whose light reaches
/// rooms B and C only through the door and the window; that light moved to room B's floor
/// (a source of both signs); and a random emission on every patch. Every surface of at
/// least 1 m² within 0.5 % and 99 % of the patches within 2 % (of the answer to the
/// source's magnitude, where light taken out and put in cancel), and the power balance as
/// the converged solve's within 10⁻³.
fn emission_answers_equal_the_converged_sweeps(h: &Baked) {
    let t = &h.transfer;
    let (n, hier) = (t.n, t.hierarchy.as_ref().unwrap());
    let first_patch = |name: &str| {
        let k = h
            .scene
            .surfaces
            .iter()
            .position(|s| s.name == name)
            .expect("a floor");
        h.mesh.surface_patches[k].start as usize
    };
    let (p, q) = (first_patch("a_floor"), first_patch("b_floor"));
    let mut one = vec![0f32; 3 * n];
    one[3 * p..3 * p + 3].copy_from_slice(&[1000.0, 500.0, 250.0]);
    let mut moved = one.clone();
    moved[3 * q..3 * q + 3].copy_from_slice(&[-1000.0, -500.0, -250.0]);
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let dense: Vec<f32> = (0..3 * n)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect();
    let converged = |e: &[f32]| {
        let x = hier.solve(&t.rho, e, 3, 1e-10, 5000, &|_| {});
        relight::transport::transfer::Solution {
            e: e.to_vec(),
            b: x.b,
            h: x.h,
            luminaire_flux: relight::color::Rgb64::ZERO,
            direct_escaped: relight::color::Rgb64::ZERO,
        }
    };
    for (name, e) in [("one patch", one), ("moved", moved), ("every patch", dense)] {
        let got = t.solve(&e).expect("an emission answer");
        let want = converged(&e);
        let magnitude: Vec<f32> = e.iter().map(|v| v.abs()).collect();
        let scale = converged(&magnitude);
        let [sg, sw, ss] = [&got, &want, &scale].map(|s| surface_averages(&h.scene, &h.mesh, s));
        let mut worst = (String::new(), 0f64);
        for (k, w) in &sw {
            let lux = |s: &std::collections::BTreeMap<
                _,
                relight::model::report::SurfaceAverage,
            >| { s[k].illuminance.iter().sum::<f64>() };
            let rel = (lux(&sg) - lux(&sw)).abs() / lux(&ss);
            if w.area >= 1.0 && lux(&ss) > 0.0 && rel > worst.1 {
                worst = (k.clone(), rel);
            }
        }
        eprintln!("{name}: worst surface {} {:.4} %", worst.0, 100.0 * worst.1);
        assert!(
            worst.1 < 5e-3,
            "{name}: {} off by {:.3} %",
            worst.0,
            100.0 * worst.1
        );
        let sum3 = |v: &[f32]| -> f32 { v.iter().sum() };
        let past = (0..n)
            .filter(|&i| {
                let r = 3 * i..3 * i + 3;
                let (g, w, m) = (
                    sum3(&got.h[r.clone()]),
                    sum3(&want.h[r.clone()]),
                    sum3(&scale.h[r]),
                );
                (g - w).abs() > 0.02 * m
            })
            .count();
        assert!(past * 100 <= n, "{name}: {past} of {n} patches past 2 %");
        if name != "moved" {
            let balance = |s| {
                let p = t.power(s);
                let e: f64 = p.emitted.iter().sum();
                (e - p.absorbed.iter().sum::<f64>() - p.escaped.iter().sum::<f64>()) / e
            };
            let (bg, bw) = (balance(&got), balance(&want));
            assert!(
                (bg - bw).abs() < 1e-3,
                "{name}: balance {bg:.2e}, converged {bw:.2e}"
            );
        }
    }
}

/// The furnace: a closed box of reflectance 0.5 emitting 1 lm/m² from every patch has
/// `B = 1 / (1 − ρ) = 2` everywhere. The emission answer (GMRES through the links) holds
/// it at every patch within 0.5 %.
#[test]
fn an_emission_answer_in_hierarchical_mode_fills_the_furnace() {
    let _gate = common::shared();
    let obj = box_faces("room", "white", [0., 0., 0.], [3., 2., 2.5], true);
    let s = write_scene(
        &obj,
        "newmtl white\nKd 0.5 0.5 0.5\n",
        Some("[mesh]\ntarget_patches = 2500\n"),
    );
    let b = bake(s.path(), TransferMode::Hierarchical);
    let n = b.transfer.n;
    let sol = b.transfer.solve(&vec![1f32; 3 * n]).expect("an answer");
    let worst = sol
        .b
        .iter()
        .map(|&v| (v as f64 / 2.0 - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 5e-3,
        "worst patch off the furnace by {:.3} %",
        100.0 * worst
    );
    // The coarse transfer alone fills it too: every later bounce of a uniform emission,
    // carried between clusters, is `ρ/(1 − ρ) = 1` at every patch.
    let hier = b.transfer.hierarchy.as_ref().unwrap();
    let coarse = b.transfer.coarse.as_ref().expect("a coarse transfer");
    let filled = coarse.precondition(&hier.area, &vec![1f32; 3 * n], 3);
    let worst = filled
        .iter()
        .map(|&v| (v as f64 / 2.0 - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-2,
        "the coarse transfer off the furnace by {:.3} %",
        100.0 * worst
    );
}

/// `auto` picked the columns mode from 6,000 to 15,000 patches, and that mode refuses
/// per-patch emission (so request-time light too): every mode `auto` picks answers it.
#[test]
fn auto_transfer_above_the_factored_limit_answers_per_patch_emission() {
    use relight::scene::TransferChoice;
    use relight::transport::transfer::AUTO_FACTORED_MAX;
    for n in [
        1,
        AUTO_FACTORED_MAX,
        AUTO_FACTORED_MAX + 1,
        10_000,
        15_001,
        2_000_000,
    ] {
        assert_ne!(
            TransferMode::resolve(TransferChoice::Auto, n),
            TransferMode::Columns,
            "at {n} patches"
        );
    }
    let _gate = common::shared();
    let s = closed_room_of(8000);
    let b = load_or_bake(
        s.path(),
        CachePolicy::Off,
        &BakeOptions::default(),
        &|_, _| {},
    )
    .unwrap();
    assert!(b.mesh.len() > AUTO_FACTORED_MAX, "{} patches", b.mesh.len());
    assert_eq!(b.transfer.mode, TransferMode::Hierarchical);
    // The lamp as an emission vector gives the lamp group's column.
    let relit = b.transfer.relight(&[Rgb::ONE]);
    let solved = b.transfer.solve(&relit.e).expect("emission is answered");
    let scale = relit.b.iter().fold(0f32, |m, x| m.max(x.abs()));
    for k in 0..relit.b.len() {
        assert!((relit.b[k] - solved.b[k]).abs() < 1e-5 * scale, "B at {k}");
    }
}

/// Two rooms, 1.5 and 4.5 m deep, under one floor and one ceiling (single quads), parted
/// by a wall with a door; a lamp in room A.
fn rooms_sharing_a_floor() -> TempScene {
    let mut obj = box_faces("room", "white", [0., 0., 0.], [6., 2.5, 3.], true);
    obj += &box_faces("wall_s", "white", [1.45, 0., 0.], [1.55, 2.5, 1.0], false);
    obj += &box_faces("wall_n", "white", [1.45, 0., 1.9], [1.55, 2.5, 3.0], false);
    obj += &box_faces("lintel", "white", [1.45, 2.1, 1.0], [1.55, 2.5, 1.9], false);
    obj += &quad(
        "lamp",
        "lamp",
        [
            [0.4, 2.49, 1.0],
            [1.1, 2.49, 1.0],
            [1.1, 2.49, 2.0],
            [0.4, 2.49, 2.0],
        ],
        [0., -1., 0.],
    );
    write_scene(
        &obj,
        "newmtl white\nKd 0.7 0.6 0.5\nnewmtl lamp\nKd 0 0 0\nKe 20 20 20\n",
        Some("[mesh]\ntarget_patches = 3000\n[[lights]]\nid = \"lamp\"\nmaterials = [\"lamp\"]\n"),
    )
}

/// The coarse transfer that preconditions the emission answers carries light between
/// clusters at one value each. A cluster of the floor reaching under the wall into both
/// rooms leaked the lit room's light into the dark one (on office-floor its surfaces read
/// up to 170 times too bright at one pass): no cluster may hold patches on both sides of
/// the wall. And the preconditioner must pay: an emission in room A, whose light reaches
/// room B through the door, converges in fewer passes than without it, to the same
/// answer.
#[test]
fn coarse_clusters_stay_in_one_room_and_save_passes() {
    let _gate = common::shared();
    let s = rooms_sharing_a_floor();
    let h = bake(s.path(), TransferMode::Hierarchical);
    let t = &h.transfer;
    let hier = t.hierarchy.as_ref().unwrap();
    // Few clusters, so that they are large enough to reach under the wall.
    let few = hier.coarse(&h.mesh, &h.bvh, &t.rho, 30);
    // Room B's patches; the wall's own faces (the jambs, the faces inside it) are in
    // neither room.
    let side = |i: usize| {
        let x = h.mesh.patches[i].centroid.x;
        (!(1.4..=1.6).contains(&x)).then_some(x > 1.5)
    };
    let mut seen = vec![[false; 2]; few.len()];
    for i in 0..t.n {
        if let Some(b) = side(i) {
            seen[few.cluster[i] as usize][b as usize] = true;
        }
    }
    let both = seen.iter().filter(|s| s[0] && s[1]).count();
    assert_eq!(both, 0, "{both} of {} clusters span the wall", few.len());
    assert!(few.len() >= 30, "{} clusters", few.len());
    let coarse = t.coarse.as_ref().expect("the transfer's own clusters");
    // One floor patch in room A emits.
    let p = (0..t.n)
        .find(|&i| {
            let q = &h.mesh.patches[i];
            q.normal.y > 0.9 && q.centroid.y < 0.01 && q.centroid.x < 0.5
        })
        .expect("a floor patch in room A");
    let mut e = vec![0f32; 3 * t.n];
    e[3 * p..3 * p + 3].copy_from_slice(&[1000.0, 800.0, 600.0]);
    let tol = relight::transport::transfer::EMISSION_TOL;
    let plain = hier.solve_krylov(&t.rho, &e, 3, tol, 100);
    let pre = |v: &[f32]| coarse.precondition(&hier.area, v, 3);
    let with = hier.solve_krylov_with(&t.rho, &e, 3, tol, 100, Some(&pre));
    let truth = hier.solve(&t.rho, &e, 3, 1e-10, 5000, &|_| {});
    eprintln!(
        "passes: {} plain, {} preconditioned",
        plain.sweeps, with.sweeps
    );
    assert!(
        with.sweeps < plain.sweeps,
        "{} passes preconditioned, {} without",
        with.sweeps,
        plain.sweeps
    );
    // Room B's mean irradiance (all of it through the door).
    let room_b = |x: &[f32]| -> f64 {
        (0..t.n)
            .filter(|&i| side(i) == Some(true))
            .map(|i| h.mesh.patches[i].area * x[3 * i..3 * i + 3].iter().sum::<f32>() as f64)
            .sum()
    };
    let rel = room_b(&with.h) / room_b(&truth.h) - 1.0;
    assert!(rel.abs() < 1e-3, "room B off by {:.3} %", 100.0 * rel);
}
