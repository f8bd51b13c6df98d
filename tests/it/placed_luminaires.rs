//! Luminaires placed per request (added, moved, removed) against the same luminaires
//! written into scene.toml and baked; superposition with the groups' light.

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
use relight::model::lighting::Lighting;
use relight::model::placed::{place, LuminairePlacement, Photometry};
use relight::model::query::IlluminanceQuery;
use relight::model::report::surface_averages;
use relight::model::{Cancel, Model};
use relight::transport::transfer::{Solution, TransferMode};

use crate::common::{self, box_faces, write_scene, TempScene};

const IES: &str = include_str!("../../scenes/office-floor/downlight.ies");

/// A closed 4 × 2.8 × 3 m room (Y up) with a desk, a downlight `l1` in group `ceiling`,
/// `extra` scene.toml lines (more luminaires) and a work-plane grid.
fn room(extra: &str, mode: &str) -> TempScene {
    room_at([1.5, 2.75, 1.5], extra, mode)
}

/// [`room`] with `l1` at `l1`.
fn room_at(l1: [f64; 3], extra: &str, mode: &str) -> TempScene {
    let mut obj = box_faces("room", "white", [0., 0., 0.], [4., 2.8, 3.], true);
    obj += &box_faces("desk", "wood", [1.0, 0.0, 1.0], [2.2, 0.75, 1.8], false);
    let mtl = "newmtl white\nKd 0.7 0.7 0.7\nnewmtl wood\nKd 0.5 0.35 0.2\n";
    let toml = format!(
        r#"transfer = "{mode}"
[mesh]
target_patches = 1500
[[luminaires]]
id = "l1"
group = "ceiling"
photometry = "down.ies"
position = [{}, {}, {}]
{extra}
[[grids]]
id = "work"
min = [0.25, 0.25]
max = [3.75, 2.75]
height = 0.8
spacing = 0.5
"#,
        l1[0], l1[1], l1[2]
    );
    let s = write_scene(&obj, mtl, Some(&toml));
    std::fs::write(s.path().join("down.ies"), IES).unwrap();
    s
}

/// The scene's model; the folder stays (a request reads its photometric files).
fn bake(s: TempScene) -> (TempScene, Model) {
    let b: Baked = load_or_bake(
        s.path(),
        CachePolicy::Off,
        &BakeOptions::default(),
        &|_, _| {},
    )
    .unwrap();
    (s, Model::new(b))
}

fn new_downlight(id: &str, position: [f64; 3]) -> LuminairePlacement {
    LuminairePlacement {
        id: id.into(),
        position: Some(position),
        photometry: Some(Photometry::File("down.ies".into())),
        ..Default::default()
    }
}

/// Largest |a − b| over the values, relative to the largest |b|.
fn worst(a: &[f32], b: &[f32]) -> f64 {
    let scale = b.iter().fold(0f32, |m, x| m.max(x.abs())) as f64;
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() as f64 / scale)
        .fold(0.0, f64::max)
}

/// Per surface of ≥ 1 m², the largest relative difference of the mean illuminance.
fn worst_surface(a: &Model, sa: &Solution, b: &Model, sb: &Solution) -> f64 {
    let (x, y) = (
        surface_averages(&a.baked.scene, &a.baked.mesh, sa),
        surface_averages(&b.baked.scene, &b.baked.mesh, sb),
    );
    let mut w = 0f64;
    for (k, v) in &y {
        if v.area >= 1.0 {
            let r = (x[k].illuminance_y() - v.illuminance_y()) / v.illuminance_y();
            w = w.max(r.abs());
        }
    }
    w
}

fn grid(m: &Model, l: &Lighting) -> Vec<f64> {
    let q = IlluminanceQuery {
        grids: vec![m.grid_index("work").unwrap()],
        ..Default::default()
    };
    let a = m.illuminance(l, &q, &Cancel::default()).unwrap();
    a.grids["work"]
        .values
        .iter()
        .map(|v| v.unwrap_or(0.0) as f64)
        .collect()
}

/// A luminaire added per request gives what the same luminaire baked from scene.toml gives:
/// the same direct light on every patch, every surface within 0.5 %, grid points within
/// 1 %; the same with the scene's own luminaire moved.
#[test]
fn a_luminaire_placed_per_request_equals_the_same_luminaire_baked() {
    let _gate = common::shared();
    let (_base_dir, base) = bake(room("", "factored"));
    let (_baked_dir, baked) = bake(room(
        "[[luminaires]]\nid = \"l2\"\ngroup = \"spare\"\nphotometry = \"down.ies\"\nposition = [3.0, 2.75, 2.0]\n",
        "factored",
    ));
    assert_eq!(base.baked.transfer.mode, TransferMode::Factored);
    let placed = place(
        &base.baked.scene,
        base.patches(),
        vec![Rgb::ONE],
        &[new_downlight("l2", [3.0, 2.75, 2.0])],
    )
    .unwrap();
    let lit = Lighting::Placed(placed);
    let got = base.solve(&lit).unwrap();
    let want = baked.solve(&Lighting::Groups(vec![Rgb::ONE; 2])).unwrap();
    let (b, h) = (worst(&got.b, &want.b), worst(&got.h, &want.h));
    assert!(b < 1e-4 && h < 1e-4, "per patch: B {b:.2e}, H {h:.2e}");
    let s = worst_surface(&base, &got, &baked, &want);
    assert!(s < 0.005, "worst surface {s:.4}");
    let (ga, gb) = (
        grid(&base, &lit),
        grid(&baked, &Lighting::Groups(vec![Rgb::ONE; 2])),
    );
    for (x, y) in ga.iter().zip(&gb) {
        assert!((x - y).abs() <= 0.01 * y, "grid point: {x} against {y}");
    }
    // The flux balance counts the new luminaire: emitted = absorbed + escaped.
    let p = base.baked.transfer.power(&got);
    let emitted = p.emitted.luminance();
    let twice = baked.baked.transfer.power(&want).emitted.luminance();
    assert!(
        (emitted - twice).abs() < 1e-6 * twice,
        "emitted {emitted} against {twice}"
    );
    // The same balance as the bake's (the direct light's sampling and the closure of the
    // form factors leave a few 1e-3 in this closed room, the same either way).
    let lost = |p: relight::transport::transfer::Power| {
        (p.emitted.luminance() - p.absorbed.luminance() - p.escaped.luminance())
            / p.emitted.luminance()
    };
    let (lp, lb) = (lost(p), lost(baked.baked.transfer.power(&want)));
    assert!(
        lp.abs() < 5e-3 && (lp - lb).abs() < 1e-5,
        "balance {lp:.2e}, baked {lb:.2e}"
    );

    // Moving the scene's own luminaire equals baking it at the new place.
    let (_moved_dir, moved) = bake(room_at([2.5, 2.75, 0.8], "", "factored"));
    let edit = LuminairePlacement {
        id: "l1".into(),
        position: Some([2.5, 2.75, 0.8]),
        ..Default::default()
    };
    let placed = place(&base.baked.scene, base.patches(), vec![Rgb::ONE], &[edit]).unwrap();
    let got = base.solve(&Lighting::Placed(placed)).unwrap();
    let want = moved.solve(&Lighting::Groups(vec![Rgb::ONE])).unwrap();
    let (b, h) = (worst(&got.b, &want.b), worst(&got.h, &want.h));
    assert!(
        b < 1e-4 && h < 1e-4,
        "moved, per patch: B {b:.2e}, H {h:.2e}"
    );
}

/// Light adds up: a group state plus a placed luminaire is the sum of the two answers, and
/// removing the scene's only luminaire leaves the room dark.
#[test]
fn placed_luminaires_superpose_with_the_groups_and_removing_one_takes_its_light_out() {
    let _gate = common::shared();
    let (_m_dir, m) = bake(room("", "factored"));
    let scene = &m.baked.scene;
    let w = vec![Rgb::new(0.4, 0.5, 0.6)];
    let lum = [new_downlight("new", [3.0, 2.75, 2.0])];
    let both = m
        .solve(&Lighting::Placed(
            place(scene, m.patches(), w.clone(), &lum).unwrap(),
        ))
        .unwrap();
    let groups = m.solve(&Lighting::Groups(w.clone())).unwrap();
    let alone = m
        .solve(&Lighting::Placed(
            place(scene, m.patches(), vec![Rgb::ZERO], &lum).unwrap(),
        ))
        .unwrap();
    let sum: Vec<f32> = groups.b.iter().zip(&alone.b).map(|(a, b)| a + b).collect();
    assert!(worst(&both.b, &sum) < 1e-5, "{:.2e}", worst(&both.b, &sum));
    let removed = LuminairePlacement {
        id: "l1".into(),
        remove: true,
        ..Default::default()
    };
    let dark = m
        .solve(&Lighting::Placed(
            place(scene, m.patches(), w, &[removed]).unwrap(),
        ))
        .unwrap();
    let left = dark.b.iter().fold(0f32, |a, x| a.max(x.abs()));
    let was = groups.b.iter().fold(0f32, |a, x| a.max(x.abs()));
    assert!(left < 1e-5 * was, "left {left} of {was}");
}

/// The hierarchical transfer answers a placed luminaire too, within its accuracy of the
/// factored answer.
#[test]
fn hierarchical_scenes_answer_placed_luminaires() {
    let _gate = common::shared();
    let (_f_dir, f) = bake(room("", "factored"));
    let (_h_dir, h) = bake(room("", "hierarchical"));
    let lum = [new_downlight("new", [3.0, 2.75, 2.0])];
    let solve = |m: &Model| {
        m.solve(&Lighting::Placed(
            place(&m.baked.scene, m.patches(), vec![Rgb::ONE], &lum).unwrap(),
        ))
        .unwrap()
    };
    let (sf, sh) = (solve(&f), solve(&h));
    let s = worst_surface(&h, &sh, &f, &sf);
    assert!(s < 0.02, "worst surface {s:.4}");
}

/// Maintained answers take each placed luminaire's own maintenance factor: its group's, or
/// the scene's for a luminaire without a group.
#[test]
fn placed_luminaires_are_maintained_by_their_groups_factor() {
    let _gate = common::shared();
    let (_dir, m) = bake(room(
        "[[lights]]\nid = \"ceiling\"\nmaintenance_factor = 0.8\n",
        "factored",
    ));
    let q = IlluminanceQuery {
        grids: vec![m.grid_index("work").unwrap()],
        ..Default::default()
    };
    let ratio = |group: Option<&str>| {
        let mut lum = new_downlight("new", [3.0, 2.75, 2.0]);
        lum.group = group.map(String::from);
        // The scene's own luminaire taken out: only the placed one lights the room.
        let out = LuminairePlacement {
            id: "l1".into(),
            remove: true,
            ..Default::default()
        };
        let p = place(&m.baked.scene, m.patches(), vec![Rgb::ONE], &[lum, out]).unwrap();
        let a = m
            .illuminance(&Lighting::Placed(p), &q, &Cancel::default())
            .unwrap();
        a.maintained.grids["work"].avg / a.grids["work"].avg
    };
    let (grouped, alone) = (ratio(Some("ceiling")), ratio(None));
    assert!((grouped - 0.8).abs() < 1e-6, "in the group: {grouped}");
    assert!((alone - 1.0).abs() < 1e-6, "without a group: {alone}");
}

/// A `final` image of a state with luminaires placed per request (one added, the scene's
/// own moved) equals the `final` image of the same luminaires written into scene.toml and
/// baked, within 0.5 % RMSE: the new luminaires' direct light is traced per pixel as the
/// baked groups' is, and the gather reads the state's radiosity.
#[test]
fn final_image_of_luminaires_placed_per_request_equals_the_same_luminaires_baked() {
    use relight::render::final_gather::{patch_locator, FinalSettings};
    use relight::render::pipeline::{final_images, final_state_image};
    use relight::render::{Camera, Shading};
    let _gate = common::shared();
    let (_base_dir, base) = bake(room("", "factored"));
    let (_baked_dir, baked) = bake(room_at(
        [2.5, 2.75, 0.8],
        "[[luminaires]]\nid = \"l2\"\ngroup = \"spare\"\nphotometry = \"down.ies\"\nposition = [3.0, 2.75, 2.0]\n",
        "factored",
    ));
    let cam = Camera {
        position: glam::Vec3::new(3.8, 2.2, 2.9),
        target: glam::Vec3::new(1.5, 0.6, 1.2),
        up: glam::Vec3::Y,
        fov_deg: 70.0,
        width: 96,
        height: 72,
    };
    let settings = FinalSettings::default();
    let cancel = Cancel::default();
    let image = |m: &Model, lighting: Option<&Lighting>| {
        let shading = Shading::new(&m.baked.mesh);
        let patches = patch_locator(&m.baked.mesh, &m.baked.scene.triangles);
        match lighting {
            Some(l) => final_state_image(m, &shading, &patches, &cam, l, &settings, &cancel)
                .unwrap()
                .linear(&[Rgb::ONE]),
            None => final_images(m, &shading, &patches, &cam, &settings, &cancel)
                .unwrap()
                .linear(&vec![Rgb::ONE; m.baked.transfer.group_count()]),
        }
    };
    let edits = [
        new_downlight("l2", [3.0, 2.75, 2.0]),
        LuminairePlacement {
            id: "l1".into(),
            position: Some([2.5, 2.75, 0.8]),
            ..Default::default()
        },
    ];
    let placed = place(&base.baked.scene, base.patches(), vec![Rgb::ONE], &edits).unwrap();
    let got = image(&base, Some(&Lighting::Placed(placed)));
    let want = image(&baked, None);
    let e = common::relative_rmse(&got, &want);
    eprintln!(
        "final, placed against baked: relative RMSE {:.3} %",
        100.0 * e
    );
    assert!(e < 0.005, "relative RMSE {e:.4}");
    // Not a test that cannot fail: the unmoved room's image is far from it.
    let before = image(&base, None);
    let far = common::relative_rmse(&before[..], &want);
    assert!(
        far > 0.1,
        "the room before the change differs by only {far:.4}"
    );
}

/// Glare under a luminaire placed per request equals glare under the same luminaire baked:
/// the same terms (luminance from its photometry and opening, solid angle, position
/// index) and the background within 1 %, so the UGR within 0.1; and the scene's own
/// luminaire, removed, no longer counts.
#[test]
fn glare_under_a_luminaire_placed_per_request_equals_the_same_luminaire_baked() {
    use glam::DVec3;
    let _gate = common::shared();
    let (_base_dir, base) = bake(room("", "factored"));
    let (_baked_dir, baked) = bake(room(
        "[[luminaires]]\nid = \"l2\"\ngroup = \"spare\"\nphotometry = \"down.ies\"\nposition = [3.0, 2.75, 2.0]\n",
        "factored",
    ));
    let observers = [(DVec3::new(0.4, 1.2, 1.5), DVec3::X)];
    let cancel = Cancel::default();
    let placed = place(
        &base.baked.scene,
        base.patches(),
        vec![Rgb::ONE],
        &[new_downlight("l2", [3.0, 2.75, 2.0])],
    )
    .unwrap();
    let got = &base
        .glare(&observers, &Lighting::Placed(placed), &cancel)
        .unwrap()[0];
    let want = &baked
        .glare(&observers, &Lighting::Groups(vec![Rgb::ONE; 2]), &cancel)
        .unwrap()[0];
    assert_eq!(got.luminaires.len(), 2, "{got:?}");
    for t in &want.luminaires {
        let g = got
            .luminaires
            .iter()
            .find(|g| g.luminaire == t.luminaire)
            .unwrap();
        assert!(
            (g.term - t.term).abs() < 1e-9 * t.term,
            "{g:?} against {t:?}"
        );
        assert!((g.luminance - t.luminance).abs() < 1e-9 * t.luminance);
    }
    let bg = (got.background_luminance / want.background_luminance - 1.0).abs();
    assert!(bg < 0.01, "background off by {bg}");
    let (u, v) = (got.ugr.unwrap(), want.ugr.unwrap());
    eprintln!(
        "UGR placed {u:.3}, baked {v:.3}; background off by {:.4} %",
        100.0 * bg
    );
    assert!((u - v).abs() < 0.1, "UGR {u} against {v}");
    // The scene's luminaire taken out: only the new one glares.
    let out = LuminairePlacement {
        id: "l1".into(),
        remove: true,
        ..Default::default()
    };
    let placed = place(
        &base.baked.scene,
        base.patches(),
        vec![Rgb::ONE],
        &[new_downlight("l2", [3.0, 2.75, 2.0]), out],
    )
    .unwrap();
    let alone = &base
        .glare(&observers, &Lighting::Placed(placed), &cancel)
        .unwrap()[0];
    let ids: Vec<&str> = alone
        .luminaires
        .iter()
        .map(|t| t.luminaire.as_str())
        .collect();
    assert_eq!(ids, ["l2"]);
}

/// `/optimize` with luminaires placed for the request: a luminaire added to the free group
/// dims with it and an ungrouped one is held, and the level found equals the level found
/// on the same luminaires baked (the second in a held group), to 1 %; at that level the
/// grid's average is the target.
#[test]
fn optimize_with_luminaires_placed_per_request_equals_the_same_luminaires_baked() {
    use relight::model::optimize::GridTarget;
    let _gate = common::shared();
    let (_base_dir, base) = bake(room("", "factored"));
    let (_baked_dir, baked) = bake(room(
        "[[luminaires]]\nid = \"l2\"\ngroup = \"ceiling\"\nphotometry = \"down.ies\"\nposition = [3.0, 2.75, 2.0]\n\
         [[luminaires]]\nid = \"held\"\ngroup = \"spare\"\nphotometry = \"down.ies\"\nposition = [0.8, 2.75, 0.8]\nlumens = 600\n",
        "factored",
    ));
    let target = |m: &Model| GridTarget {
        grid: m.grid_index("work").unwrap(),
        eavg_min: Some(150.0),
        emin_min: None,
        u0_min: None,
        ugr_max: None,
    };
    let mut l2 = new_downlight("l2", [3.0, 2.75, 2.0]);
    l2.group = Some("ceiling".into());
    let mut held = new_downlight("held", [0.8, 2.75, 0.8]);
    held.lumens = Some(600.0);
    let placed = place(
        &base.baked.scene,
        base.patches(),
        vec![Rgb::ONE],
        &[l2, held],
    )
    .unwrap();
    let got = base
        .optimize(&placed.weights, &placed.changes, &[0], &[target(&base)])
        .unwrap();
    let want = baked
        .optimize(&[Rgb::ONE; 2], &[], &[0], &[target(&baked)])
        .unwrap();
    let (x, y) = (
        got.lights["ceiling"].intensity,
        want.lights["ceiling"].intensity,
    );
    eprintln!("optimized level: placed {x:.4}, baked {y:.4}");
    assert!(
        y > 0.05 && y < 0.95,
        "the target binds inside the range: {y}"
    );
    assert!((x - y).abs() < 0.01 * y, "level {x} against {y}");
    let avg = got.grids["work"].avg;
    assert!((avg - 150.0).abs() < 1e-3 * 150.0, "average {avg} lx");
    assert!(got.targets[0].met);
    // The flux counts the placed luminaires: the ceiling group's two at the level, the
    // held one at full.
    let flux = got.lumens;
    let want_flux = want.lumens;
    assert!(
        (flux - want_flux).abs() < 0.01 * want_flux,
        "{flux} lm against {want_flux}"
    );
}

/// `/optimize` with candidates (positions × photometric files): the mixed-integer answer
/// lights at most one file per position and uses exactly the least flux of every way to
/// choose a file (or none) per position, each solved alone as a plain LP (brute force).
#[test]
fn optimize_with_candidates_installs_the_least_flux_choice() {
    use relight::model::optimize::{Candidate, GridTarget};
    let _gate = common::shared();
    let dir = room("", "factored");
    // A second file: the same distribution at 60 % of the intensity.
    let dim = IES.replace("1 2500 1 19", "1 2500 0.6 19");
    assert_ne!(dim, IES);
    std::fs::write(dir.path().join("dim.ies"), dim).unwrap();
    let (_dir, m) = bake(dir);
    let scene = &m.baked.scene;
    let positions = [[0.8, 2.75, 0.8], [3.2, 2.75, 0.8], [2.0, 2.75, 2.2]];
    let files = ["down.ies", "dim.ies"];
    let candidate = |p: usize, f: usize| {
        let entry = LuminairePlacement {
            id: format!("c{p}_{f}"),
            position: Some(positions[p]),
            photometry: Some(Photometry::File(files[f].into())),
            ..Default::default()
        };
        let placed = place(scene, m.patches(), vec![Rgb::ZERO], &[entry]).unwrap();
        Candidate {
            position: p,
            change: placed.changes[0].clone(),
        }
    };
    // The scene's own downlight off: the candidates light the grid.
    let target = GridTarget {
        grid: m.grid_index("work").unwrap(),
        eavg_min: Some(300.0),
        emin_min: Some(100.0),
        u0_min: None,
        ugr_max: None,
    };
    let all: Vec<Candidate> = (0..3)
        .flat_map(|p| (0..2).map(move |f| (p, f)))
        .map(|(p, f)| candidate(p, f))
        .collect();
    let got = m
        .optimize_layout(&[Rgb::ZERO], &[], &[], &[target], &all)
        .unwrap();
    let mut per_position = [0; 3];
    for i in &got.installed {
        per_position[i.id[1..2].parse::<usize>().unwrap()] += 1;
    }
    assert!(per_position.iter().all(|&n| n <= 1), "{:?}", got.installed);
    assert!(got.targets[0].met, "{:?}", got.targets);
    // Brute force: a file or none at each position, 27 ways, each a plain LP.
    let mut best = f64::INFINITY;
    for code in 0..27usize {
        let pick: Vec<Candidate> = (0..3)
            .filter_map(|p| match (code / 3usize.pow(p as u32)) % 3 {
                0 => None,
                f => Some(candidate(p, f - 1)),
            })
            .collect();
        if let Ok(a) = m.optimize_layout(&[Rgb::ZERO], &[], &[], &[target], &pick) {
            best = best.min(a.lumens);
        }
    }
    eprintln!(
        "candidates: installed {:?}, {:.1} lm; brute force {best:.1} lm",
        got.installed
            .iter()
            .map(|i| (&i.id, i.level))
            .collect::<Vec<_>>(),
        got.lumens
    );
    assert!(
        (got.lumens - best).abs() < 1e-6 * best,
        "{} lm against the best choice's {best} lm",
        got.lumens
    );
}

/// A batch state's grids (`Model::state_grid_answers`, what `/batch` answers per state)
/// with a luminaire placed per request equal the same luminaire baked, to 1 % per point.
#[test]
fn batch_grids_of_a_placed_state_equal_the_same_luminaire_baked() {
    let _gate = common::shared();
    let (_base_dir, base) = bake(room("", "factored"));
    let (_baked_dir, baked) = bake(room(
        "[[luminaires]]\nid = \"l2\"\ngroup = \"spare\"\nphotometry = \"down.ies\"\nposition = [3.0, 2.75, 2.0]\n",
        "factored",
    ));
    let placed = place(
        &base.baked.scene,
        base.patches(),
        vec![Rgb::new(0.5, 0.5, 0.5)],
        &[new_downlight("l2", [3.0, 2.75, 2.0])],
    )
    .unwrap();
    let lit = Lighting::Placed(placed);
    let sol = base.solve(&lit).unwrap();
    let gi = base.grid_index("work").unwrap();
    let got = base
        .state_grid_answers(&lit, &sol, &[gi], &Cancel::default())
        .unwrap();
    let w = [Rgb::new(0.5, 0.5, 0.5), Rgb::ONE];
    let want = baked.grid_answers(&[baked.grid_index("work").unwrap()], &w);
    let (g, b) = (&got["work"], &want["work"]);
    for (x, y) in g.values.iter().zip(&b.values) {
        let (x, y) = (x.unwrap(), y.unwrap());
        assert!((x - y).abs() <= 0.01 * y, "grid point: {x} against {y}");
    }
    assert!(
        (g.avg - b.avg).abs() < 0.005 * b.avg,
        "{} against {}",
        g.avg,
        b.avg
    );
}
