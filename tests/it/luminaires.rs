//! Point luminaires, IES photometry, calculation grids and energy balance, checked against
//! closed forms in the style of CIE 171:2006 (test cases for lighting programs).

use relight::bake::{load_or_bake, BakeOptions, Baked, CachePolicy};
use relight::color::Rgb;
use relight::model::grid::GridResponse;

use crate::common::{self, *};

fn bake(s: &TempScene) -> Baked {
    load_or_bake(
        s.path(),
        CachePolicy::Off,
        &BakeOptions::default(),
        &|_, _| {},
    )
    .unwrap()
}

fn grid_values(b: &Baked, id: &str) -> Vec<f32> {
    let grids = GridResponse::build_all(
        &b.scene,
        &b.bvh,
        b.transfer.grids.clone(),
        b.transfer.grid_gathers.clone(),
    );
    let g = grids.iter().find(|g| g.grid.id == id).unwrap();
    g.values(&vec![Rgb::ONE; b.scene.lights.len()])
}

const BLACK: &str = "newmtl black\nKd 0 0 0\n";

fn floor(size: f64) -> String {
    quad(
        "floor",
        "black",
        [
            [-size, 0., -size],
            [size, 0., -size],
            [size, 0., size],
            [-size, 0., size],
        ],
        [0., 1., 0.],
    )
}

/// CIE 171 §5.2 style: a point source over a black plane, E = I cos θ / d².
#[test]
fn point_source_over_a_plane_follows_the_inverse_square_cosine_law() {
    let _gate = common::shared();
    let toml = r#"
transfer = "columns"
[mesh]
max_edge = 4.0
[[luminaires]]
id = "p"
position = [0, 2, 0]
lumens = 1000
[[grids]]
id = "line"
points = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [4, 0, 0], [0, 0, 3], [-2.5, 0, 1.5]]
"#;
    let s = write_scene(&floor(10.0), BLACK, Some(toml));
    let b = bake(&s);
    let got = grid_values(&b, "line");
    let i = 1000.0 / (4.0 * std::f64::consts::PI);
    let mut worst = 0f64;
    for (p, e) in [
        [0f64, 0.],
        [1., 0.],
        [2., 0.],
        [4., 0.],
        [0., 3.],
        [-2.5, 1.5],
    ]
    .iter()
    .zip(&got)
    {
        let d2 = p[0] * p[0] + p[1] * p[1] + 4.0;
        let want = i * 2.0 / d2.powf(1.5);
        let err = (*e as f64 / want - 1.0).abs();
        worst = worst.max(err);
        assert!(err < 0.01, "at {p:?}: {e} lx, want {want}");
    }
    eprintln!(
        "point source, E = I cos θ / d²: worst error {:.4} %",
        100.0 * worst
    );
}

/// An IES type C file with a known, C-dependent table: the illuminance it produces gives
/// back its candela values (I = E d² / cos θ), in the documented orientation (C = 0° along
/// `c0` = +x, C = 90° along aim × c0 = +z).
#[test]
fn an_ies_file_reproduces_its_candela_values() {
    let _gate = common::shared();
    let ies = "IESNA:LM-63-2002\n[TEST] bilateral table\nTILT=NONE\n\
        1 -1 2 4 3 1 2 0 0 0\n1 1 10\n0 30 60 90\n0 90 180\n\
        500 450 300 100\n\
        500 400 250 50\n\
        500 350 200 25\n";
    let toml = r#"
transfer = "columns"
[mesh]
max_edge = 8.0
[[luminaires]]
id = "l"
position = [0, 3, 0]
ies = "lamp.ies"
[[grids]]
id = "probe"
points = [POINTS]
"#;
    // Directions (γ, C) on the table's nodes; C = 270° mirrors C = 90° (bilateral file).
    let dirs: [(f64, f64, f64); 8] = [
        (0.0, 0.0, 500.0),
        (30.0, 0.0, 450.0),
        (60.0, 0.0, 300.0),
        (30.0, 90.0, 400.0),
        (60.0, 90.0, 250.0),
        (30.0, 180.0, 350.0),
        (60.0, 180.0, 200.0),
        (60.0, 270.0, 250.0),
    ];
    let h = 3.0f64;
    let pts: Vec<[f64; 3]> = dirs
        .iter()
        .map(|&(g, c, _)| {
            let r = h * g.to_radians().tan();
            let c = c.to_radians();
            [r * c.cos(), 0.0, r * c.sin()]
        })
        .collect();
    let list = pts
        .iter()
        .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
        .collect::<Vec<_>>()
        .join(", ");
    let s = write_scene(&floor(12.0), BLACK, Some(&toml.replace("POINTS", &list)));
    // The multiplier (2) scales the table: candela = 2 × the values above.
    std::fs::write(s.path().join("lamp.ies"), ies).unwrap();
    let b = bake(&s);
    let got = grid_values(&b, "probe");
    for ((g, c, cd), e) in dirs.iter().zip(&got) {
        let cos = g.to_radians().cos();
        let d2 = (h / cos).powi(2);
        let i = *e as f64 * d2 / cos;
        assert!(
            (i / (2.0 * cd) - 1.0).abs() < 0.005,
            "γ {g}° C {c}°: {i:.1} cd from the illuminance, table {}",
            2.0 * cd
        );
    }
}

/// EULUMDAT files (symmetry types 0, 2 and 4, decimal commas, CRLF) against IES twins made
/// by an independent converter (`eulumdat-ies`, see `tests/data/photometry/make_twins.py`):
/// the same intensities in every direction, between the planes too, and the same lumens,
/// within 0.5 %; and in a scene, the same illuminance on a grid.
#[test]
fn ldt_files_and_their_ies_twins_give_the_same_light() {
    use glam::DVec3;
    use relight::photometry::{parse_ies, parse_ldt, Distribution, Luminaire, LuminaireSpec};
    let _gate = common::shared();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/photometry");
    for name in ["panel-isym0", "panel-isym2", "panel-isym4"] {
        let read = |ext: &str| std::fs::read_to_string(dir.join(format!("{name}.{ext}"))).unwrap();
        let ldt = parse_ldt(name, &read("ldt"), None).unwrap();
        let ies = parse_ies(name, &read("ies")).unwrap();
        assert_eq!(ldt.opening, ies.opening, "{name}");
        let lum = |t| {
            let d = Distribution::Table(Box::new(t));
            Luminaire::new(LuminaireSpec {
                id: "l",
                position: DVec3::ZERO,
                aim: -DVec3::Y,
                c0: None,
                distribution: d,
                lumens: None,
                color: Rgb::ONE,
                watts: None,
            })
            .unwrap()
        };
        let (a, b) = (lum(ldt), lum(ies));
        assert!(
            (a.lumens / b.lumens - 1.0).abs() < 0.005,
            "{name}: {} lm vs {} lm",
            a.lumens,
            b.lumens
        );
        let peak = (0..=36)
            .map(|g| {
                a.intensity(
                    DVec3::new(0.0, -1.0, 0.0)
                        .lerp(DVec3::X, g as f64 / 36.0)
                        .normalize(),
                )
            })
            .fold(0.0, f64::max);
        for g in 0..=72 {
            for c in 0..48 {
                let (gr, cr) = ((g as f64 * 2.5).to_radians(), (c as f64 * 7.5).to_radians());
                // C from c0 (+x) towards aim × c0 = (−y) × x = +z.
                let d = DVec3::new(gr.sin() * cr.cos(), -gr.cos(), gr.sin() * cr.sin());
                let (ia, ib) = (a.intensity(d), b.intensity(d));
                assert!(
                    (ia - ib).abs() <= 0.005 * ib.max(0.05 * peak),
                    "{name} γ {} C {}: LDT {ia:.2} cd, IES {ib:.2} cd",
                    g as f64 * 2.5,
                    c as f64 * 7.5
                );
            }
        }
    }
    // In a scene: a grid under the LDT and under its twin.
    let toml = r#"
transfer = "columns"
[mesh]
max_edge = 8.0
[[luminaires]]
id = "l"
position = [0, 2.5, 0]
photometry = "FILE"
[[grids]]
id = "floor"
min = [-3, -3]
max = [3, 3]
height = 0
spacing = 0.75
"#;
    let values = |file: &str| {
        let s = write_scene(&floor(12.0), BLACK, Some(&toml.replace("FILE", file)));
        std::fs::copy(dir.join(file), s.path().join(file)).unwrap();
        grid_values(&bake(&s), "floor")
    };
    let (a, b) = (values("panel-isym0.ldt"), values("panel-isym0.ies"));
    assert!(a.iter().any(|v| *v > 10.0));
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 0.005 * y.max(1.0), "{x} lx vs {y} lx");
    }
}

/// Watts from the photometric files: an LM-63-2019 file's input watts (458 W) and an
/// EULUMDAT lamp set's wattage (36 W) are the luminaires' power unless `scene.toml` gives
/// `watts`; rescaling `lumens` keeps the file's watts; an isotropic luminaire has none.
/// The file's tilt data (factor 0.5 at 60°) halves the light of the luminaire aimed 60°
/// from straight down, on the floor and in its lumens, and not its watts.
#[test]
fn photometric_files_give_watts_and_tilt_factors() {
    let _gate = common::shared();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/photometry");
    let toml = r#"
transfer = "columns"
[mesh]
max_edge = 8.0
[[luminaires]]
id = "down"
group = "a"
position = [0, 2, 0]
photometry = "tilt-2019.ies"
[[luminaires]]
id = "tilted"
group = "b"
position = [10, 2, 0]
aim = [0.8660254037844386, -0.5, 0]
c0 = [0, 0, 1]
photometry = "tilt-2019.ies"
[[luminaires]]
id = "rescaled"
group = "c"
position = [-10, 2, 0]
photometry = "tilt-2019.ies"
lumens = 20000
[[luminaires]]
id = "override"
group = "c"
position = [-10, 2, 10]
photometry = "tilt-2019.ies"
watts = 400
[[luminaires]]
id = "panel"
group = "d"
position = [0, 2, 10]
photometry = "panel-isym0.ldt"
[[luminaires]]
id = "bulb"
group = "e"
position = [0, 2, -10]
lumens = 1000
[[grids]]
id = "axes"
points = [[0, 0, 0], [13.464101615137754, 0, 0]]
"#;
    let s = write_scene(&floor(30.0), BLACK, Some(toml));
    for f in ["tilt-2019.ies", "panel-isym0.ldt"] {
        std::fs::copy(dir.join(f), s.path().join(f)).unwrap();
    }
    let model = relight::model::Model::new(bake(&s));
    let lums = model.luminaires();
    let by_id = |id: &str| lums.iter().find(|l| l.id == id).unwrap();
    assert_eq!(by_id("down").watts, Some(458.0));
    assert_eq!(by_id("tilted").watts, Some(458.0));
    assert_eq!(by_id("rescaled").watts, Some(458.0));
    assert_eq!(by_id("override").watts, Some(400.0));
    assert_eq!(by_id("panel").watts, Some(36.0));
    assert_eq!(by_id("bulb").watts, None);
    let down = by_id("down").lumens;
    assert!((by_id("tilted").lumens / down - 0.5).abs() < 1e-9);
    assert!((by_id("rescaled").lumens - 20000.0).abs() < 1e-6);
    let group_watts: Vec<Option<f64>> = model.groups.iter().map(|g| g.watts).collect();
    assert_eq!(
        group_watts,
        [Some(458.0), Some(458.0), Some(858.0), Some(36.0), None]
    );
    // On the floor: 10,000 cd straight down from 2 m; along the tilted aim 4 m away at
    // 60° incidence, 10,000 × 0.5 cd × cos 60° / 4².
    let w = |on: [f32; 5]| on.map(Rgb::splat);
    let axes = &model.grids[0];
    let e_down = f64::from(axes.values(&w([1.0, 0.0, 0.0, 0.0, 0.0]))[0]);
    let e_tilted = f64::from(axes.values(&w([0.0, 1.0, 0.0, 0.0, 0.0]))[1]);
    assert!((e_down / 2500.0 - 1.0).abs() < 0.01, "{e_down} lx");
    assert!((e_tilted / 156.25 - 1.0).abs() < 0.01, "{e_tilted} lx");
    // Power: every group at full but the bulb (off: no watts to know); the tilted group
    // at half its level counts half its watts.
    let p = model.luminaire_power(&w([1.0, 0.5, 1.0, 1.0, 0.0]));
    let watts = p
        .luminaire_watts
        .expect("the lit luminaires all give watts");
    assert!(
        (watts - (458.0 + 229.0 + 858.0 + 36.0)).abs() < 1e-6,
        "{watts}"
    );
    // With the bulb on, the power is unknown.
    let p = model.luminaire_power(&w([1.0; 5]));
    assert_eq!(p.luminaire_watts, None);
}

/// A luminaire with a luminous opening is an area source near it: a 1.2 × 0.3 m panel with
/// a Lambertian table (I = I₀ cos γ, so its luminance is L = I₀ / A), 0.5 m above a black
/// floor, gives E = π L F at floor points, F the closed-form configuration factor from a
/// point to a parallel rectangle, within 1 % (the point approximation is 84 % high under
/// the centre and 30–50 % off beside it).
#[test]
fn a_panel_close_to_the_work_plane_lit_it_as_an_area_not_a_point() {
    let _gate = common::shared();
    let (a, b, h, i0) = (1.2f64, 0.3f64, 0.5f64, 1000.0f64);
    // Type C, one plane, γ every 5° to 90°; width 0.3 (along C90) and length 1.2 (along C0).
    let gammas: Vec<String> = (0..=18).map(|k| format!("{}", 5 * k)).collect();
    let cd: Vec<String> = (0..=18)
        .map(|k| format!("{:.6}", i0 * (5.0 * k as f64).to_radians().cos()))
        .collect();
    let ies = format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 19 1 1 2 {b} {a} 0\n1 1 40\n{}\n0\n{}\n",
        gammas.join(" "),
        cd.join(" ")
    );
    // Under the centre, under a corner, beside a long edge, and farther out.
    let pts = [[0.0, 0.0], [0.6, 0.15], [0.0, 0.45], [0.9, 0.0], [1.2, 0.6]];
    let list = pts
        .iter()
        .map(|p| format!("[{}, 0, {}]", p[0], p[1]))
        .collect::<Vec<_>>()
        .join(", ");
    let toml = format!(
        "transfer = \"columns\"\n[mesh]\nmax_edge = 8.0\n[[luminaires]]\nid = \"panel\"\n\
         position = [0, {h}, 0]\nc0 = [1, 0, 0]\nphotometry = \"panel.ies\"\n\
         [[grids]]\nid = \"probe\"\npoints = [{list}]\n"
    );
    let s = write_scene(&floor(12.0), BLACK, Some(&toml));
    std::fs::write(s.path().join("panel.ies"), ies).unwrap();
    let got = grid_values(&bake(&s), "probe");
    // Point to the corner of a parallel a × b rectangle at distance c (Howell's A-type).
    let corner = |a: f64, b: f64, c: f64| {
        let (x, y) = (a / c, b / c);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    // Signed sum over the four rectangles between the point's foot and the corners.
    let f = |x: f64, z: f64| {
        let part = |u: f64, v: f64| u.signum() * v.signum() * corner(u.abs(), v.abs(), h);
        part(a / 2.0 - x, b / 2.0 - z)
            - part(-a / 2.0 - x, b / 2.0 - z)
            - part(a / 2.0 - x, -b / 2.0 - z)
            + part(-a / 2.0 - x, -b / 2.0 - z)
    };
    let l = i0 / (a * b);
    for (p, e) in pts.iter().zip(&got) {
        let want = std::f64::consts::PI * l * f(p[0], p[1]);
        assert!(
            (*e as f64 / want - 1.0).abs() < 0.01,
            "at {p:?}: {e} lx, the configuration factor gives {want:.2} lx"
        );
    }
}

/// CIE 171 §5.5 style: a diffuse square area source over a black plane; E = M · F with the
/// closed-form point-to-rectangle configuration factor.
#[test]
fn diffuse_area_source_gives_the_closed_form_illuminance() {
    let _gate = common::shared();
    let c = 2.0;
    let obj = floor(6.0)
        + &quad(
            "panel",
            "glow",
            [
                [-0.5, c, -0.5],
                [0.5, c, -0.5],
                [0.5, c, 0.5],
                [-0.5, c, 0.5],
            ],
            [0., -1., 0.],
        );
    let toml = r#"
transfer = "columns"
[mesh]
max_edge = 0.5
[[grids]]
id = "p"
points = [[0, 0, 0], [0.5, 0, 0.5], [1.5, 0, 0]]
"#;
    let m = 1000.0;
    let s = write_scene(
        &obj,
        &format!("{BLACK}newmtl glow\nKd 0 0 0\nKe {m} {m} {m}\n"),
        Some(toml),
    );
    let b = bake(&s);
    let got = grid_values(&b, "p");
    // Factor from a point below one corner of an a × b rectangle at distance c.
    let corner = |a: f64, b: f64| {
        let (x, y) = (a / c, b / c);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    // Under the centre: four 0.5 × 0.5 quarters. Under a corner: one 1 × 1. Off to the
    // side at x = 1.5: the 2 × 1 rectangle from x = -0.5..1.5 minus the 1 × 1 from 0.5..1.5,
    // each split at z = 0 into two halves.
    let want = [
        4.0 * corner(0.5, 0.5),
        corner(1.0, 1.0),
        2.0 * (corner(2.0, 0.5) - corner(1.0, 0.5)),
    ];
    let mut worst = 0f64;
    for (k, (e, f)) in got.iter().zip(want).enumerate() {
        let err = (*e as f64 / (m * f) - 1.0).abs();
        worst = worst.max(err);
        assert!(err < 0.01, "point {k}: {e} lx, want {}", m * f);
    }
    eprintln!(
        "diffuse area source, E = M·F: worst error {:.4} %",
        100.0 * worst
    );
}

/// CIE 171 §5.13 style: inter-reflection in an empty cube with uniform reflectance ρ and
/// a point source. Flux balance makes the area-weighted mean illuminance exactly
/// Φ / (A (1 − ρ)); the direct part alone averages Φ / A.
#[test]
fn interreflection_in_an_empty_cube_meets_the_flux_balance() {
    let _gate = common::shared();
    let rho = 0.5;
    let toml = r#"
transfer = "factored"
[mesh]
target_patches = 1500
[[luminaires]]
id = "bulb"
position = [2, 2, 2]
lumens = 10000
[[grids]]
id = "floor_centre"
points = [[2, 0, 2]]
"#;
    let s = write_scene(
        &box_faces("cube", "wall", [0., 0., 0.], [4., 4., 4.], true),
        &format!("newmtl wall\nKd {rho} {rho} {rho}\n"),
        Some(toml),
    );
    let b = bake(&s);
    let t = &b.transfer;
    let sol = t.relight(&[Rgb::ONE]);
    let area: f64 = t.area.iter().map(|&a| a as f64).sum();
    let mean_h: f64 = (0..t.n)
        .map(|i| t.area[i] as f64 * Rgb::column(&sol.h)[i].to_f64().luminance())
        .sum::<f64>()
        / area;
    let want = 10000.0 / (area * (1.0 - rho));
    let err = (mean_h / want - 1.0).abs();
    eprintln!(
        "empty cube, ρ = {rho}: mean E {mean_h:.2} lx, Φ/(A(1−ρ)) = {want:.2} lx, error {:.4} %",
        100.0 * err
    );
    assert!(err < 0.01, "mean {mean_h}, want {want}");
    // The direct flux lands entirely on the walls.
    let g = &t.groups[0];
    let landed = g.landed.luminance() / g.flux.luminance();
    assert!((landed - 1.0).abs() < 0.01, "direct flux landing: {landed}");
    // Floor centre: direct I/h² plus an indirect part close to the room's mean indirect
    // ρΦ/(A(1−ρ)) (reported; the closed form holds for the mean, not per point).
    let e = grid_values(&b, "floor_centre")[0] as f64;
    let direct = 10000.0 / (4.0 * std::f64::consts::PI) / 4.0;
    let indirect_mean = rho * 10000.0 / (area * (1.0 - rho));
    eprintln!(
        "empty cube floor centre: {e:.2} lx = direct {direct:.2} + indirect {:.2} (room mean indirect {indirect_mean:.2})",
        e - direct
    );
    assert!(e > direct && (e - direct - indirect_mean).abs() < 0.25 * indirect_mean);
}

/// Lumens in = lumens absorbed + lumens escaping, for luminaires (direct light that misses
/// every surface included) in the bundled office with its open window.
#[test]
fn office_lumens_in_equal_absorbed_plus_escaped() {
    let _gate = common::shared();
    let dir = scenes_dir().join("office");
    let b = load_or_bake(&dir, CachePolicy::Off, &BakeOptions::default(), &|_, _| {}).unwrap();
    for w in [
        [Rgb::ONE, Rgb::ONE],
        [Rgb::splat(0.3), Rgb::new(1.0, 0.8, 0.6)],
    ] {
        let sol = b.transfer.relight(&w);
        let p = b.transfer.power(&sol);
        let (e, a, x) = (
            p.emitted.luminance(),
            p.absorbed.luminance(),
            p.escaped.luminance(),
        );
        assert!(e > 1000.0);
        assert!(x > 0.01 * e, "the window lets light out: {x} of {e}");
        assert!(
            ((a + x) / e - 1.0).abs() < 1e-3,
            "in {e}, absorbed {a}, escaped {x}"
        );
    }
    // At full power the six 2500 lm downlights emit their rated flux (the table's own
    // integral, within the 5° sampling of the file).
    let p = b.transfer.power(&b.transfer.relight(&[Rgb::ONE, Rgb::ONE]));
    assert!(
        (p.emitted.luminance() / 15000.0 - 1.0).abs() < 0.005,
        "{p:?}"
    );
}
