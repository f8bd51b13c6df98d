//! Health, readiness, the scene list and details, patches, scenes baking or broken.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use relight::server::{router, AppState};
use serde_json::Value;

use super::{app, config, get, post, ready, send};
use crate::common;

#[tokio::test]
async fn health_ready_and_scene_list() {
    let _gate = common::shared();
    let (s, _, b) = send(app(), Request::get("/healthz").body(Body::empty()).unwrap()).await;
    assert_eq!((s, b.as_slice()), (StatusCode::OK, &b"ok"[..]));
    let (s, v) = get(app(), "/readyz").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["ready"], true);
    let (s, v) = get(app(), "/api/scenes").await;
    assert_eq!(s, StatusCode::OK);
    let scenes = v["scenes"].as_array().unwrap();
    let ids: Vec<&str> = scenes.iter().map(|s| s["id"].as_str().unwrap()).collect();
    assert_eq!(
        ids,
        ["cornell-box", "desk-room", "gallery", "office", "rooflight"]
    );
    assert!(scenes
        .iter()
        .all(|s| s["status"] == "ready" && s["patches"].as_u64().unwrap() > 1000));
    assert_eq!(scenes[1]["lights"].as_array().unwrap().len(), 2);
    // The glTF gallery: its spots and lamp (KHR_lights_punctual) and its emissive panel.
    let gallery: Vec<&str> = scenes[2]["lights"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["id"].as_str().unwrap())
        .collect();
    assert_eq!(gallery, ["spots", "lamp", "panel"]);
    assert_eq!(scenes[2]["lights"][0]["luminaires"], 3);
}

#[tokio::test]
async fn scene_details_with_flux_surfaces_and_cameras() {
    let _gate = common::shared();
    let (s, v) = get(app(), "/api/scenes/cornell-box").await;
    assert_eq!(s, StatusCode::OK);
    let light = &v["lights"][0];
    assert_eq!(light["id"], "ceiling");
    // 50 lm/m² over the 0.13 m × 0.105 m light.
    assert!(
        (light["lumens"].as_f64().unwrap() - 0.6825).abs() < 1e-4,
        "{light}"
    );
    assert!((light["emitting_area"].as_f64().unwrap() - 0.01365).abs() < 1e-6);
    assert_eq!(v["surfaces"].as_array().unwrap().len(), 10);
    assert_eq!(v["cameras"][0]["id"], "front");
    assert_eq!(v["transfer"], "factored");
    let total: u64 = v["surfaces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["patches"]["count"].as_u64().unwrap())
        .sum();
    assert_eq!(total, v["patches"].as_u64().unwrap());
    let (_, v) = get(app(), "/api/scenes/desk-room").await;
    let lamp = v["lights"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["id"] == "lamp")
        .unwrap();
    assert!((lamp["lumens"].as_f64().unwrap() - 400.0).abs() < 0.01);
}

#[tokio::test]
async fn unknown_scene_is_a_404_problem() {
    let _gate = common::shared();
    let (s, h, b) = send(
        app(),
        Request::get("/api/scenes/atlantis")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    let v: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!(v["status"], 404);
    assert!(v["detail"].as_str().unwrap().contains("atlantis"));
    let (s, _, _) = post(app(), "/api/scenes/atlantis/radiosity", "{}").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    let (s, _) = get(app(), "/api/nothing-here").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn patches_as_json_and_binary() {
    let _gate = common::shared();
    let r = ready("cornell-box");
    let n = r.model.baked.mesh.len();
    let (s, v) = get(app(), "/api/scenes/cornell-box/patches").await;
    assert_eq!(s, StatusCode::OK);
    let list = v["patches"].as_array().unwrap();
    assert_eq!(list.len(), n);
    assert_eq!(list[0]["surface"], "floor");
    let req = Request::get("/api/scenes/cornell-box/patches")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::empty())
        .unwrap();
    let (s, h, b) = send(app(), req).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/octet-stream");
    assert_eq!(b.len(), 32 * n);
    let words: &[u32] = bytemuck::cast_slice(&b);
    let last = n - 1;
    assert_eq!(words[8 * last], r.model.baked.mesh.patches[last].surface);
    let area: f64 = (0..n)
        .map(|i| f32::from_bits(words[8 * i + 1]) as f64)
        .sum();
    // The areas of shared/reference/cornell-box/scene.json sum to 1.92070 m².
    assert!((area - 1.92070).abs() < 1e-4, "total area {area}");
}

#[tokio::test]
async fn baking_scenes_answer_503_with_progress() {
    let _gate = common::shared();
    let s = AppState::new(config(
        common::scenes_dir(),
        std::env::temp_dir().join("never"),
    ))
    .unwrap();
    let (st, v) = get(router(s.clone()), "/readyz").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(v["ready"], false);
    let (st, h, v) = post(router(s.clone()), "/api/scenes/cornell-box/radiosity", "{}").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    assert!(v["progress"].is_number() && v["detail"].as_str().unwrap().contains("retry"));
    let (st, v) = get(router(s), "/api/scenes").await;
    assert_eq!(st, StatusCode::OK);
    assert_eq!(v["scenes"][0]["status"], "queued");
}

#[tokio::test]
async fn a_broken_scene_is_listed_as_failed_and_the_others_serve() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken");
    std::fs::create_dir(&bad).unwrap();
    std::fs::write(
        bad.join("b.obj"),
        "mtllib b.mtl\no t\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
    )
    .unwrap();
    std::fs::write(bad.join("b.mtl"), "newmtl m\nKd -1.5 0.5 0.5\n").unwrap();
    relight::bench::write_group_room(&dir.path().join("good"), 1, 300).unwrap();
    // A scene a lenient load fixes: served, with its warnings listed.
    let fixed = dir.path().join("lenient");
    std::fs::create_dir(&fixed).unwrap();
    std::fs::write(
        fixed.join("l.obj"),
        "mtllib l.mtl\no t\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
    )
    .unwrap();
    std::fs::write(fixed.join("l.mtl"), "newmtl m\nKd 1 1 1\n").unwrap();
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    s.bake_all();
    let (st, v) = get(router(s.clone()), "/readyz").await;
    assert_eq!(st, StatusCode::OK, "failed scenes count as settled");
    let (_, v2) = get(router(s.clone()), "/api/scenes").await;
    let broken = &v2["scenes"][0];
    assert_eq!(broken["status"], "failed", "{v}");
    assert!(broken["error"].as_str().unwrap().contains("b.mtl:2"));
    let (st, _, v) = post(router(s.clone()), "/api/scenes/broken/radiosity", "{}").await;
    assert_eq!(st, StatusCode::SERVICE_UNAVAILABLE);
    assert!(v["detail"].as_str().unwrap().contains("failed to load"));
    let (st, _, _) = post(router(s.clone()), "/api/scenes/good/radiosity", "{}").await;
    assert_eq!(st, StatusCode::OK);
    let lenient = &v2["scenes"][2];
    assert_eq!(lenient["status"], "ready", "{v2}");
    let warned = |v: &serde_json::Value| {
        v["warnings"].as_array().unwrap().iter().any(|w| {
            w.as_str().unwrap().contains("l.mtl:2")
                && w.as_str().unwrap().contains("scaled to 0.95")
        })
    };
    assert!(warned(lenient), "{lenient}");
    assert_eq!(v2["scenes"][1]["warnings"], serde_json::json!([]));
    let (st, details) = get(router(s), "/api/scenes/lenient").await;
    assert_eq!(st, StatusCode::OK);
    assert!(warned(&details), "{details}");
}

/// A fresh start baked the scenes in name order, so the 2,488-patch rooflight waited behind
/// the 177,222-patch office floor: now the smallest estimated scene bakes first.
#[tokio::test]
async fn small_scenes_waited_behind_large_ones_baked_in_name_order() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    // Named so that name order would bake the large one first.
    relight::bench::write_group_room(&dir.path().join("a-large"), 1, 6000).unwrap();
    relight::bench::write_group_room(&dir.path().join("b-small"), 1, 300).unwrap();
    let broken = dir.path().join("c-broken");
    std::fs::create_dir(&broken).unwrap();
    std::fs::write(broken.join("b.obj"), "v 0 0 0\nf 1 1 1 1\n").unwrap();
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    let order: Vec<String> = s.bake_order().iter().map(|s| s.id.clone()).collect();
    assert_eq!(order, ["c-broken", "b-small", "a-large"]);
    // Baking in that order: when the small scene is ready, the large one has not finished.
    let baker = s.clone();
    let t = std::thread::spawn(move || baker.bake_all());
    let slot = |id: &str| s.slot(id).unwrap();
    loop {
        let small = slot("b-small").status().0;
        let large = slot("a-large").status().0;
        if small == "ready" {
            assert_ne!(
                large, "ready",
                "the large scene finished before the small one"
            );
            break;
        }
        assert_ne!(
            large, "ready",
            "the large scene finished before the small one"
        );
        assert_ne!(small, "failed");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    t.join().unwrap();
    assert_eq!(slot("a-large").status().0, "ready");
    assert!(
        slot("a-large").ready().unwrap().model.patches()
            > 4 * slot("b-small").ready().unwrap().model.patches()
    );
}

#[tokio::test]
async fn scene_details_give_the_bounds_in_metres_and_the_units_hint() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    // One 6 × 3 × 4 m room written in millimetres twice: with `units = "mm"`, and without.
    let room = common::box_faces("room", "wall", [0., 0., 0.], [6000., 3000., 4000.], true);
    for (id, toml) in [
        ("set", "units = \"mm\"\n[mesh]\ntarget_patches = 60\n"),
        ("bare", "[mesh]\ntarget_patches = 60\n"),
    ] {
        let d = dir.path().join(id);
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("r.obj"), format!("mtllib r.mtl\n{room}")).unwrap();
        std::fs::write(d.join("r.mtl"), "newmtl wall\nKd 0.5 0.5 0.5\n").unwrap();
        std::fs::write(d.join("scene.toml"), toml).unwrap();
    }
    let s = AppState::new(config(dir.path().into(), dir.path().join("cache"))).unwrap();
    s.bake_all();
    let (st, v) = get(router(s.clone()), "/api/scenes/set").await;
    assert_eq!(st, StatusCode::OK, "{v}");
    let close =
        |a: &Value, b: [f64; 3]| (0..3).all(|k| (a[k].as_f64().unwrap() - b[k]).abs() < 1e-9);
    let b = &v["bounds"];
    assert!(close(&b["min"], [0.0; 3]), "{b}");
    assert!(close(&b["max"], [6.0, 3.0, 4.0]), "{b}");
    assert!(close(&b["size"], [6.0, 3.0, 4.0]), "{b}");
    assert_eq!(v["units"]["source_units"], "mm");
    assert_eq!(v["warnings"], serde_json::json!([]));
    // Without units the file is read in metres, and the answer says what to set.
    let (st, v) = get(router(s), "/api/scenes/bare").await;
    assert_eq!(st, StatusCode::OK, "{v}");
    assert!(close(&v["bounds"]["size"], [6000.0, 3000.0, 4000.0]), "{v}");
    let warned = v["warnings"].as_array().unwrap().iter().any(|w| {
        let w = w.as_str().unwrap();
        w.contains("bare/r.obj") && w.contains("6000 m across") && w.contains("units = \"mm\"")
    });
    assert!(warned, "{}", v["warnings"]);
}
