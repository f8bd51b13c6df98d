//! Maintained values (the maintenance factor) and EN 12464-1 compliance in `illuminance`
//! answers, over HTTP, on the bundled office (scene MF 0.8; the desk requires Ēm 500 lx,
//! U₀ 0.6, UGR_L 19 and Ra 80).

use axum::http::StatusCode;
use serde_json::{json, Value};

use super::{app, post};
use crate::common::{self, write_scene};

const URI: &str = "/api/scenes/office/illuminance";
const POINTS: &str = r#"[{"position": [1.0, 0.75, 1.0], "normal": [0, 1, 0]},
                         {"position": [4.0, 1.5, 3.9], "normal": [0, 0, -1]}]"#;

async fn ask(body: Value) -> Value {
    let (s, _, v) = post(app(), URI, body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    v
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN))
        .collect()
}

#[tokio::test]
async fn maintained_answers_are_each_groups_light_times_its_factor() {
    let _gate = common::shared();
    let points: Value = serde_json::from_str(POINTS).unwrap();
    let query = |lights: Value, mf: Option<Value>| {
        let mut b = json!({"lights": lights, "grids": ["workplane"], "surfaces": ["desk_top"],
                           "points": points});
        if let Some(mf) = mf {
            b["maintenance_factor"] = mf;
        }
        b
    };
    // Each row alone, initial values.
    let window = ask(query(json!({"corridor_row": 0}), None)).await;
    let corridor = ask(query(json!({"window_row": 0}), None)).await;
    let both = ask(query(
        json!({}),
        Some(json!({"window_row": 0.5, "corridor_row": 0.9})),
    ))
    .await;
    assert_eq!(
        both["maintenance_factors"],
        json!({"window_row": 0.5, "corridor_row": 0.9})
    );
    // Maintained = 0.5 × window row + 0.9 × corridor row, point by point.
    let (w, c) = (
        nums(&window["grids"]["workplane"]["values"]),
        nums(&corridor["grids"]["workplane"]["values"]),
    );
    let m = nums(&both["maintained"]["grids"]["workplane"]["values"]);
    assert_eq!(m.len(), w.len());
    for i in 0..m.len() {
        let want = 0.5 * w[i] + 0.9 * c[i];
        assert!(
            (m[i] - want).abs() <= 1e-4 * want.max(1.0),
            "point {i}: {} vs {want}",
            m[i]
        );
    }
    for k in 0..2 {
        let lux = |v: &Value| v["lux"].as_f64().unwrap();
        let want = 0.5 * lux(&window["points"][k]) + 0.9 * lux(&corridor["points"][k]);
        let got = lux(&both["maintained"]["points"][k]);
        assert!(
            (got - want).abs() <= 1e-4 * want,
            "point {k}: {got} vs {want}"
        );
        // The initial values are the plain state's.
        let initial = lux(&window["points"][k]) + lux(&corridor["points"][k]);
        assert!((lux(&both["points"][k]) - initial).abs() <= 1e-4 * initial);
    }
    let desk = |v: &Value| v["surfaces"]["desk_top"]["avg"]["lux"].as_f64().unwrap();
    let want = 0.5 * desk(&window) + 0.9 * desk(&corridor);
    assert!((desk(&both["maintained"]) - want).abs() <= 1e-4 * want);

    // The scene's own factor, 0.8 for both rows: maintained is 0.8 × initial, and the
    // uniformity stays.
    let plain = ask(query(json!({}), None)).await;
    assert_eq!(
        plain["maintenance_factors"],
        json!({"window_row": 0.8, "corridor_row": 0.8})
    );
    let (g, mg) = (
        &plain["grids"]["workplane"],
        &plain["maintained"]["grids"]["workplane"],
    );
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
    assert!((f(mg, "avg") - 0.8 * f(g, "avg")).abs() <= 1e-5 * f(g, "avg"));
    assert!((f(mg, "u0") - f(g, "u0")).abs() <= 1e-5);
    // One factor for every group.
    let all = ask(query(json!({}), Some(json!(0.5)))).await;
    let a = &all["maintained"]["grids"]["workplane"];
    assert!((f(a, "avg") - 0.5 * f(g, "avg")).abs() <= 1e-5 * f(g, "avg"));
}

#[tokio::test]
async fn the_desk_is_checked_against_its_requirements_from_the_maintained_grid() {
    let _gate = common::shared();
    let v = ask(json!({"grids": ["desk"], "surfaces": []})).await;
    let c = &v["compliance"]["desk"];
    let m = &v["maintained"]["grids"]["desk"];
    let check = |k: &str| {
        c["checks"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["requirement"] == k)
            .unwrap_or_else(|| panic!("no {k} check in {c}"))
            .clone()
    };
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
    // Ēm and U₀ are the maintained grid's; the margins are achieved − required.
    let em = check("em");
    assert_eq!(f(&em, "achieved"), f(m, "avg"));
    assert_eq!(f(&em, "required"), 500.0);
    assert_eq!(em["pass"], f(m, "avg") >= 500.0);
    assert!((f(&em, "margin") - (f(m, "avg") - 500.0)).abs() < 1e-9);
    let u0 = check("u0");
    assert_eq!(f(&u0, "achieved"), f(m, "u0"));
    // UGR: the highest of the four seated observers, each the glare endpoint's answer for
    // the same eye and direction; UGR_L is a ceiling, so the margin is limit − UGR.
    let obs = c["observers"].as_array().unwrap();
    assert_eq!(obs.len(), 4);
    let body = json!({"observers": obs.iter().map(|o| json!({"eye": o["eye"], "direction": o["direction"]})).collect::<Vec<_>>()});
    let (s, _, glare) = post(app(), "/api/scenes/office/glare", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{glare}");
    let mut worst = f64::NEG_INFINITY;
    for (o, g) in obs.iter().zip(glare["observers"].as_array().unwrap()) {
        let (a, b) = (f(o, "ugr"), f(g, "ugr"));
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        assert!(
            (o["eye"][1].as_f64().unwrap() - 1.2).abs() < 1e-9,
            "seated eyes: {o}"
        );
        worst = worst.max(a);
    }
    let ugr = check("ugr_l");
    assert_eq!(f(&ugr, "achieved"), worst);
    assert!((f(&ugr, "margin") - (19.0 - worst)).abs() < 1e-9);
    assert_eq!(ugr["pass"], worst <= 19.0);
    // Ra: both rows give 80.
    assert_eq!(f(&check("ra"), "achieved"), 80.0);
    let all_pass = c["checks"]
        .as_array()
        .unwrap()
        .iter()
        .all(|x| x["pass"] == true);
    assert_eq!(c["pass"], all_pass);

    // Requirements in the request replace the scene's: just above and just below what is
    // achieved.
    let avg = f(m, "avg");
    for (em, pass) in [(avg + 1.0, false), (avg - 1.0, true)] {
        let v = ask(json!({"surfaces": [], "requirements": {"desk": {"em": em}}})).await;
        let c = &v["compliance"]["desk"];
        assert_eq!(c["checks"].as_array().unwrap().len(), 1, "{c}");
        assert_eq!(c["pass"], pass, "{c}");
        assert!((f(&c["checks"][0], "margin") - (avg - em)).abs() < 1e-6);
    }
    // Dimming the rows to 40 % lowers Ēm by exactly that, and UGR by 8 log₁₀(1 / 0.4).
    let dim = ask(json!({"surfaces": [], "grids": ["desk"],
                         "lights": {"window_row": 0.4, "corridor_row": 0.4}}))
    .await;
    let dc = &dim["compliance"]["desk"];
    let by = |c: &Value, k: &str| {
        c["checks"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["requirement"] == k)
            .unwrap()["achieved"]
            .as_f64()
            .unwrap()
    };
    assert!((by(dc, "em") - 0.4 * avg).abs() < 1e-4 * avg);
    assert!((by(dc, "ugr_l") - (worst - 8.0 * (1.0f64 / 0.4).log10())).abs() < 1e-6);
}

#[tokio::test]
async fn bad_maintenance_factors_and_requirements_are_refused_by_name() {
    let _gate = common::shared();
    for (body, says) in [
        (
            json!({"maintenance_factor": 0}),
            "maintenance_factor = 0: must be in (0, 1]",
        ),
        (json!({"maintenance_factor": 1.2}), "must be in (0, 1]"),
        (
            json!({"maintenance_factor": {"nope": 0.5}}),
            "unknown light group 'nope'",
        ),
        (
            json!({"maintenance_factor": {"window_row": -1}}),
            "maintenance_factor['window_row'] = -1",
        ),
        (
            json!({"maintenance_factor": "high"}),
            "a number in (0, 1] or an object",
        ),
        (json!({"maintenance_factor": null}), "got null"),
        (
            json!({"requirements": {"desk": {"u0": 2}}}),
            "requirements['desk'].u0 = 2",
        ),
        (
            json!({"requirements": {"desk": {"ugr_l": 50}}}),
            "ugr_l = 50",
        ),
        (
            json!({"requirements": {"hall": {"em": 100}}}),
            "unknown grid 'hall'",
        ),
        (
            json!({"requirements": {"desk": {"lux": 100}}}),
            "unknown field 'lux'",
        ),
        (json!({"requirements": {"desk": {"em": null}}}), "got null"),
    ] {
        let (s, _, v) = post(app(), URI, body.to_string()).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}: {v}");
        let detail = v["detail"].as_str().unwrap();
        assert!(detail.contains(says), "{body}: {detail}");
    }
}

#[test]
fn scene_maintenance_factors_and_requirements_out_of_range_name_the_key() {
    let _gate = common::shared();
    let obj = common::box_faces("room", "white", [0., 0., 0.], [2., 2., 2.], true);
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
    for (toml, says) in [
        (
            "maintenance_factor = 0\n",
            "maintenance_factor = 0: must be in (0, 1]",
        ),
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"white\"]\nmaintenance_factor = 1.5\n",
            "light 'a': maintenance_factor = 1.5",
        ),
        (
            "[[grids]]\nid = \"g\"\npoints = [[1, 1, 1]]\nrequirements = { u0 = 1.5 }\n",
            "grid 'g': requirements.u0 = 1.5",
        ),
        (
            "[[grids]]\nid = \"g\"\npoints = [[1, 1, 1]]\nrequirements = { lux = 1 }\n",
            "unknown field `lux`",
        ),
    ] {
        let s = write_scene(&obj, mtl, Some(toml));
        let e = relight::scene::Scene::load(s.path())
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{toml}: {e}");
    }
    // In range: each group takes its own factor, else the scene's.
    let s = write_scene(
        &obj,
        mtl,
        Some(
            "maintenance_factor = 0.7\n[[lights]]\nid = \"a\"\nmaterials = [\"white\"]\nra = 90\n",
        ),
    );
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    assert_eq!(scene.lights[0].maintenance_factor, 0.7);
    assert_eq!(scene.lights[0].ra, Some(90.0));
}

/// An unlit grid (every light off) reported U₀ and Emin/Emax as 0: a ratio of zeros has
/// no value. Both are null now, initial and maintained, with a note that says why; a lit
/// grid has no note.
#[tokio::test]
async fn an_unlit_grid_reported_zero_uniformity() {
    let _gate = common::shared();
    let dark = ask(json!({"lights": {"window_row": 0, "corridor_row": 0},
                          "grids": ["workplane"]}))
    .await;
    for g in [
        &dark["grids"]["workplane"],
        &dark["maintained"]["grids"]["workplane"],
    ] {
        assert_eq!(g["avg"], json!(0.0), "{g}");
        assert!(g["u0"].is_null() && g["min_max"].is_null(), "{g}");
        assert!(g["note"].as_str().unwrap().contains("0 lx"), "{g}");
    }
    let lit = ask(json!({"grids": ["workplane"]})).await;
    let g = &lit["grids"]["workplane"];
    assert!(
        g["u0"].as_f64().unwrap() > 0.0 && g.get("note").is_none(),
        "{g}"
    );
}
