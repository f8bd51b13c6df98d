//! The command line, run as a user would.

use std::process::Command;

use crate::common::{self, *};

fn relight() -> Command {
    Command::new(env!("CARGO_BIN_EXE_relight"))
}

/// A closed 2 m room (ρ = 0.5) with a 0.4 m square lamp (100 lm/m²) under its ceiling.
const ROOM_MTL: &str = "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0 0 0\nKe 100 100 100\n";

fn room_obj() -> String {
    box_faces("room", "wall", [0., 0., 0.], [2., 2., 2.], true)
        + &quad(
            "lamp",
            "glow",
            [
                [0.8, 1.99, 0.8],
                [1.2, 1.99, 0.8],
                [1.2, 1.99, 1.2],
                [0.8, 1.99, 1.2],
            ],
            [0., -1., 0.],
        )
}

#[test]
fn radiosity_json_on_a_bare_obj_and_mtl_folder() {
    let _gate = common::shared();
    let s = write_scene(&room_obj(), ROOM_MTL, None);
    let cache = tempfile::tempdir().unwrap();
    let out = relight()
        .args([
            "radiosity",
            s.path().to_str().unwrap(),
            "--json",
            "--light",
            "glow=0.5",
            "--cache",
        ])
        .arg(cache.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let floor = &v["surfaces"]["room-y"];
    assert!((floor["area"].as_f64().unwrap() - 4.0).abs() < 1e-6);
    assert!(floor["radiosity"][0].as_f64().unwrap() > 0.0);
    assert!(floor["illuminance"][2].as_f64().unwrap() > 0.0);
    // Half intensity: 0.5 × 100 lm/m² × 0.16 m² = 8 lm emitted, closed room absorbs it.
    let p = &v["power"];
    assert!(
        (p["emitted_lm"].as_f64().unwrap() - 8.0).abs() < 1e-3,
        "{p}"
    );
    assert!(
        (p["absorbed_lm"].as_f64().unwrap() / 8.0 - 1.0).abs() < 0.005,
        "{p}"
    );
}

#[test]
fn bad_input_is_a_clear_error_not_a_panic() {
    let _gate = common::shared();
    let out = relight()
        .args(["radiosity", "/nonexistent/scene"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    // Library errors name scenes by their id (the folder name), never by an absolute path.
    assert!(
        err.contains("error:") && err.contains("scene: scene folder not found"),
        "{err}"
    );
    assert!(!err.contains("panicked"));

    let s = write_scene(
        "o t\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    // Its own cache: a test never writes to the user's.
    let cache = tempfile::tempdir().unwrap();
    let out = relight()
        .args([
            "radiosity",
            s.path().to_str().unwrap(),
            "--light",
            "nosuch=1",
        ])
        .arg("--cache")
        .arg(cache.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("unknown light group 'nosuch'"),
        "{err}"
    );
}

#[test]
fn info_lists_the_bundled_scenes() {
    let _gate = common::shared();
    let out = relight()
        .args(["info", "--scenes"])
        .arg(scenes_dir())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        text.contains("cornell-box") && text.contains("desk-room"),
        "{text}"
    );
    assert!(text.contains("ceiling") && text.contains("lamp"));
}

/// A running `relight serve`, killed on drop.
struct Server(std::process::Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Polls the scene list until `scene` leaves queued/baking; returns it.
async fn settled(base: &str, scene: &str) -> serde_json::Value {
    let c = reqwest::Client::new();
    for _ in 0..600 {
        if let Ok(r) = c.get(format!("{base}/api/scenes")).send().await {
            let v: serde_json::Value = r.json().await.unwrap();
            let s = v["scenes"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["id"] == scene)
                .cloned()
                .unwrap();
            if s["status"] == "ready" || s["status"] == "failed" {
                return s;
            }
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    panic!("{scene} never settled");
}

/// Names and modification times of the files in a folder, to show nothing was written.
fn listing(dir: &std::path::Path) -> Vec<(std::ffi::OsString, std::time::SystemTime)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (e.file_name(), e.metadata().unwrap().modified().unwrap())
        })
        .collect();
    v.sort();
    v
}

#[tokio::test]
async fn read_only_replicas_serve_a_baked_cache_and_never_bake() {
    let _gate = common::shared();
    // A scenes folder with one small room.
    let scenes = tempfile::tempdir().unwrap();
    let room = scenes.path().join("room");
    std::fs::create_dir(&room).unwrap();
    std::fs::write(
        room.join("scene.obj"),
        format!("mtllib scene.mtl\n{}", room_obj()),
    )
    .unwrap();
    std::fs::write(room.join("scene.mtl"), ROOM_MTL).unwrap();
    std::fs::write(room.join("scene.toml"), "[mesh]\nmax_edge = 0.5\n").unwrap();
    let cache = tempfile::tempdir().unwrap();

    // 1. An empty cache: the replica reports the scene as failed, and writes nothing.
    let port = free_port();
    let _a = Server(
        relight()
            .args([
                "serve",
                "--read-only",
                "--addr",
                &format!("127.0.0.1:{port}"),
            ])
            .arg("--scenes")
            .arg(scenes.path())
            .arg("--cache")
            .arg(cache.path())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let s = settled(&format!("http://127.0.0.1:{port}"), "room").await;
    assert_eq!(s["status"], "failed", "{s}");
    let err = s["error"].as_str().unwrap();
    assert!(
        err.contains("read-only") && err.contains("relight bake"),
        "{err}"
    );
    assert!(
        listing(cache.path()).is_empty(),
        "a read-only replica wrote"
    );

    // 2. Bake on "one machine" …
    let out = relight()
        .args(["bake", "--all"])
        .arg("--scenes")
        .arg(scenes.path())
        .arg("--cache")
        .arg(cache.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let baked = listing(cache.path());
    assert_eq!(baked.len(), 1, "{baked:?}");

    // 3. … and a replica configured only through the environment serves it, read-only.
    let port = free_port();
    let t0 = std::time::Instant::now();
    let _b = Server(
        relight()
            .arg("serve")
            .env("RELIGHT_ADDR", format!("127.0.0.1:{port}"))
            .env("RELIGHT_SCENES", scenes.path())
            .env("RELIGHT_CACHE", cache.path())
            .env("RELIGHT_READ_ONLY", "true")
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let base = format!("http://127.0.0.1:{port}");
    let s = settled(&base, "room").await;
    eprintln!(
        "read-only replica ready in {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(s["status"], "ready", "{s}");
    let r = reqwest::Client::new()
        .post(format!("{base}/api/scenes/room/illuminance"))
        .header("content-type", "application/json")
        .body(r#"{"lights": {"glow": 0.5}, "surfaces": ["room-y"]}"#)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let v: serde_json::Value = r.json().await.unwrap();
    assert!(v["surfaces"]["room-y"]["avg"]["lux"].as_f64().unwrap() > 0.0);
    assert_eq!(listing(cache.path()), baked, "a read-only replica wrote");
}

/// `relight radiosity --grid` answers through the same model as the server: its JSON is
/// the HTTP `/illuminance` answer for the same lighting state and grids, value for value.
#[tokio::test]
async fn radiosity_grid_equals_the_http_grid_answer() {
    use http_body_util::BodyExt;
    use tower::ServiceExt;
    let _gate = common::shared();
    let cache = tempfile::tempdir().unwrap();
    let out = relight()
        .args(["radiosity", scenes_dir().join("office").to_str().unwrap()])
        .args([
            "--grid",
            "desk",
            "--grid",
            "workplane",
            "--light",
            "window_row=0.5",
        ])
        .args(["--json", "--cache"])
        .arg(cache.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cli: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(cli["grids"]["desk"]["avg"].as_f64().unwrap() > 0.0, "{cli}");
    // A read-only server over the entry the command just wrote.
    let config = relight::server::ServerConfig {
        scenes: scenes_dir(),
        cache: cache.path().to_path_buf(),
        read_only: true,
        ..Default::default()
    };
    let state = relight::server::AppState::new(config).unwrap();
    state.bake_all();
    let req = axum::http::Request::post("/api/scenes/office/illuminance")
        .header("content-type", "application/json")
        .body(axum::body::Body::from(
            r#"{"lights": {"window_row": 0.5}, "grids": ["desk", "workplane"]}"#,
        ))
        .unwrap();
    let resp = relight::server::router(state).oneshot(req).await.unwrap();
    assert_eq!(resp.status(), 200);
    let body = resp.into_body().collect().await.unwrap().to_bytes();
    let http: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(cli, http);
}

#[test]
fn export_writes_a_relit_glb_and_refuses_other_names() {
    let _gate = common::shared();
    let s = write_scene(
        &room_obj(),
        ROOM_MTL,
        Some("[mesh]\ntarget_patches = 300\n"),
    );
    let cache = tempfile::tempdir().unwrap();
    let out_dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        relight()
            .arg("export")
            .arg(s.path())
            .arg("-o")
            .arg(out_dir.path().join(name))
            .arg("--cache")
            .arg(cache.path())
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run("room.glb", &["--light", "glow=0.5", "--exposure", "-2"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("exposure -2.00 stops"));
    let full = std::fs::read(out_dir.path().join("room.glb")).unwrap();
    assert_eq!(&full[..4], b"glTF");
    let out = run("lean.glb", &["--no-groups", "--tonemap", "clamp"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lean = std::fs::read(out_dir.path().join("lean.glb")).unwrap();
    assert!(lean.len() < full.len());
    let out = run("room.png", &[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("name it .glb"));
    let out = run("x.glb", &["--tonemap", "sepia"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("clamp or filmic"));
}

/// `relight render --sky` composes daylight through the same pipeline as the server: its
/// image is the HTTP `/render` answer for the same scene, camera and sky, byte for byte,
/// at `fast` and at `final` quality.
#[tokio::test]
async fn render_with_a_sky_equals_the_http_render() {
    use http_body_util::BodyExt;
    use tower::ServiceExt;
    let _gate = common::shared();
    // A grey block on a grey yard in the open, under a clear sky with the sun.
    let scenes = tempfile::tempdir().unwrap();
    let dir = scenes.path().join("yard");
    std::fs::create_dir(&dir).unwrap();
    let obj = quad(
        "ground",
        "wall",
        [[-3., 0., -3.], [3., 0., -3.], [3., 0., 3.], [-3., 0., 3.]],
        [0., 1., 0.],
    ) + &box_faces("block", "wall", [-0.5, 0., -0.5], [0.5, 1., 0.5], false);
    std::fs::write(dir.join("scene.obj"), format!("mtllib scene.mtl\n{obj}")).unwrap();
    std::fs::write(dir.join("scene.mtl"), "newmtl wall\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "[site]\nlatitude = 49.5\nlongitude = 8.5\ntimezone = 1\n[mesh]\nmax_edge = 0.5\n\
         [[cameras]]\nid = \"above\"\nposition = [2.5, 2.5, 2.5]\ntarget = [0, 0.3, 0]\nfov_deg = 60\n",
    )
    .unwrap();
    let sky = r#"{"type": "cie_clear", "horizontal_illuminance": 15000, "direct_normal_illuminance": 70000, "sun": {"altitude": 40, "azimuth": 160}}"#;
    let cache = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    let mut cli = Vec::new();
    for quality in ["fast", "final"] {
        let png = out.path().join(format!("{quality}.png"));
        let run = relight()
            .args(["render", dir.to_str().unwrap(), "--sky", sky])
            .args([
                "--width",
                "48",
                "--height",
                "32",
                "--quality",
                quality,
                "-o",
            ])
            .arg(&png)
            .arg("--cache")
            .arg(cache.path())
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        cli.push(std::fs::read(&png).unwrap());
    }
    // A read-only server over the entry the command wrote.
    let config = relight::server::ServerConfig {
        scenes: scenes.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        read_only: true,
        ..Default::default()
    };
    let state = relight::server::AppState::new(config).unwrap();
    state.bake_all();
    let app = relight::server::router(state);
    for (quality, cli) in ["fast", "final"].into_iter().zip(cli) {
        let body =
            format!(r#"{{"width": 48, "height": 32, "quality": "{quality}", "sky": {sky}}}"#);
        let req = axum::http::Request::post("/api/scenes/yard/render")
            .header("content-type", "application/json")
            .body(axum::body::Body::from(body))
            .unwrap();
        let resp = app.clone().oneshot(req).await.unwrap();
        assert_eq!(resp.status(), 200, "{quality}");
        let http = resp.into_body().collect().await.unwrap().to_bytes();
        assert!(
            cli == http,
            "{quality}: the command line's image differs from /render's"
        );
    }
}
