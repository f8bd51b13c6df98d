//! Scenes over HTTP: `PUT /api/scenes/{id}` with a zip or a .glb, background bakes, and
//! `DELETE`; tokens; and hostile archives (traversal, absolute paths, links, bombs, entry
//! counts, wrong types), none of which may leave anything behind.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use relight::server::{router, AppState};
use serde_json::Value;
use zip::write::SimpleFileOptions;

use super::{config, send};
use crate::common;

const TOKEN: &str = "test-admin-token-0123456789";

/// A closed box with an emissive ceiling panel: a small scene that bakes in moments.
fn box_obj() -> String {
    let mut s = common::box_faces("wall", "grey", [0.0; 3], [2.0, 2.0, 2.0], true);
    s.push_str(&common::quad(
        "panel",
        "light",
        [
            [0.8, 1.99, 0.8],
            [1.2, 1.99, 0.8],
            [1.2, 1.99, 1.2],
            [0.8, 1.99, 1.2],
        ],
        [0.0, -1.0, 0.0],
    ));
    s
}

const BOX_MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0 0 0\nKe 1000 1000 1000\n";

/// A server over a fresh scenes folder holding one scene of its own ("own").
struct Server {
    _dir: tempfile::TempDir,
    scenes: std::path::PathBuf,
    cache: std::path::PathBuf,
    state: Arc<AppState>,
}

fn server(token: Option<&str>, upload_limit: Option<u64>) -> Server {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes");
    let own = scenes.join("own");
    std::fs::create_dir_all(&own).unwrap();
    std::fs::write(
        own.join("own.obj"),
        format!("mtllib own.mtl\n{}", box_obj()),
    )
    .unwrap();
    std::fs::write(own.join("own.mtl"), BOX_MTL).unwrap();
    std::fs::write(own.join("scene.toml"), "[mesh]\ntarget_patches = 200\n").unwrap();
    let cache = dir.path().join("cache");
    let mut cfg = config(scenes.clone(), cache.clone());
    cfg.admin_token = token.map(String::from);
    if let Some(l) = upload_limit {
        cfg.upload_limit = l;
    }
    let state = AppState::new(cfg).unwrap();
    common::bake_all(&state);
    Server {
        _dir: dir,
        scenes,
        cache,
        state,
    }
}

impl Server {
    fn app(&self) -> Router {
        router(self.state.clone())
    }

    async fn put(
        &self,
        id: &str,
        ct: &str,
        token: Option<&str>,
        body: Vec<u8>,
    ) -> (StatusCode, Value) {
        let mut req = Request::put(format!("/api/scenes/{id}")).header(header::CONTENT_TYPE, ct);
        if let Some(t) = token {
            req = req.header(header::AUTHORIZATION, format!("Bearer {t}"));
        }
        let (s, _, b) = send(self.app(), req.body(Body::from(body)).unwrap()).await;
        (s, serde_json::from_slice(&b).unwrap_or(Value::Null))
    }

    async fn delete(&self, id: &str, token: Option<&str>) -> (StatusCode, Value) {
        let mut req = Request::delete(format!("/api/scenes/{id}"));
        if let Some(t) = token {
            req = req.header(header::AUTHORIZATION, format!("Bearer {t}"));
        }
        let (s, _, b) = send(self.app(), req.body(Body::empty()).unwrap()).await;
        (s, serde_json::from_slice(&b).unwrap_or(Value::Null))
    }

    async fn get(&self, uri: &str) -> (StatusCode, Value) {
        super::get(self.app(), uri).await
    }

    /// Waits (up to three minutes: a loaded machine bakes slowly) until the scene is ready
    /// or failed; its details.
    async fn settled(&self, id: &str) -> Value {
        let t0 = Instant::now();
        loop {
            let (_, v) = self.get("/api/scenes").await;
            let s = v["scenes"]
                .as_array()
                .or(v.as_array())
                .and_then(|a| a.iter().find(|s| s["id"] == id).cloned())
                .unwrap_or(Value::Null);
            if s["status"] == "ready" || s["status"] == "failed" {
                return s;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(180),
                "{id} never settled: {s}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Nothing but scene folders under the scenes folder (no staging or trash left).
    fn clean(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.scenes)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

/// A zip of `files` (name, bytes), deflated.
fn zip_of(files: &[(&str, &[u8])]) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, bytes) in files {
        w.start_file(*name, SimpleFileOptions::default()).unwrap();
        w.write_all(bytes).unwrap();
    }
    w.finish().unwrap().into_inner()
}

fn problem(v: &Value, needle: &str) -> bool {
    v["detail"].as_str().is_some_and(|d| d.contains(needle))
}

#[tokio::test]
async fn zip_and_glb_uploads_bake_in_the_background_and_delete_cleanly() {
    let _gate = common::shared();
    let srv = server(Some(TOKEN), None);
    // A zipped scene folder (one folder around everything), with a texture in a subfolder.
    let mut png = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(2, 2, image::Rgba([128, 128, 128, 255]))
        .write_to(&mut png, image::ImageFormat::Png)
        .unwrap();
    let mtl = BOX_MTL.replace("Kd 0.5 0.5 0.5", "map_Kd tex/grey.png");
    let obj = format!("mtllib box.mtl\n{}", box_obj());
    let body = zip_of(&[
        ("my box/box.obj", obj.as_bytes()),
        ("my box/box.mtl", mtl.as_bytes()),
        ("my box/tex/grey.png", png.get_ref()),
        (
            "my box/scene.toml",
            b"name = \"Uploaded box\"\n[mesh]\ntarget_patches = 300\n",
        ),
        ("__MACOSX/my box/._box.obj", b"junk"),
    ]);
    let (s, v) = srv.put("box", "application/zip", Some(TOKEN), body).await;
    assert_eq!(s, StatusCode::ACCEPTED, "{v}");
    assert_eq!(v["id"], "box");
    assert_eq!(v["status"], "queued");
    assert_eq!(
        v["files"], 4,
        "the four scene files (not the macOS junk): {v}"
    );
    let summary = srv.settled("box").await;
    assert_eq!(summary["status"], "ready", "{summary}");
    assert_eq!(summary["name"], "Uploaded box");
    // It answers like any scene: the panel's light reaches the walls.
    let (s, _, v) = super::post(srv.app(), "/api/scenes/box/radiosity", "{}").await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, d) = srv.get("/api/scenes/box").await;
    assert_eq!(s, StatusCode::OK, "{d}");
    assert!(srv.scenes.join("box/tex/grey.png").is_file());
    assert!(std::fs::read_dir(&srv.cache)
        .unwrap()
        .flatten()
        .any(|e| e.file_name().to_string_lossy().starts_with("box-")));

    // A .glb, under another id.
    let glb = crate::gltf_import::box_glb();
    let (s, v) = srv
        .put("glb-box", "model/gltf-binary", Some(TOKEN), glb)
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{v}");
    assert_eq!(srv.settled("glb-box").await["status"], "ready");
    assert!(srv.scenes.join("glb-box/glb-box.glb").is_file());

    // Replacing an upload: the new content is served, the old views and cache are gone.
    let obj2 = format!("mtllib box.mtl\n{}", box_obj());
    let body = zip_of(&[
        ("box.obj", obj2.as_bytes()),
        ("box.mtl", BOX_MTL.as_bytes()),
        (
            "scene.toml",
            b"name = \"Second box\"\n[mesh]\ntarget_patches = 200\n",
        ),
    ]);
    let (s, v) = srv.put("box", "application/zip", Some(TOKEN), body).await;
    assert_eq!(s, StatusCode::ACCEPTED, "{v}");
    assert_eq!(srv.settled("box").await["name"], "Second box");
    assert!(
        !srv.scenes.join("box/tex").exists(),
        "the old folder was replaced"
    );

    // Delete: 204, then 404; folder and cache entries gone; nothing staged is left.
    let (s, _) = srv.delete("box", Some(TOKEN)).await;
    assert_eq!(s, StatusCode::NO_CONTENT);
    let (s, v) = srv.get("/api/scenes/box").await;
    assert_eq!(s, StatusCode::NOT_FOUND, "{v}");
    assert!(!srv.scenes.join("box").exists());
    assert!(!std::fs::read_dir(&srv.cache)
        .unwrap()
        .flatten()
        .any(|e| e.file_name().to_string_lossy().starts_with("box-")));
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(srv.clean(), ["glb-box", "own"]);

    // A restarted server serves the upload again, as uploaded (deletable).
    let again = AppState::new(srv.state.config.clone()).unwrap();
    assert!(again.slot("glb-box").unwrap().uploaded);
    assert!(!again.slot("own").unwrap().uploaded);
}

#[tokio::test]
async fn writes_need_the_token_and_leave_the_servers_own_scenes_alone() {
    let _gate = common::shared();
    let zip = zip_of(&[("a.obj", box_obj().as_bytes())]);
    // No token configured: uploads are off.
    let off = server(None, None);
    let (s, v) = off
        .put("x", "application/zip", Some(TOKEN), zip.clone())
        .await;
    assert_eq!(s, StatusCode::FORBIDDEN, "{v}");
    assert!(problem(&v, "--admin-token"), "{v}");
    let (s, _) = off.delete("own", Some(TOKEN)).await;
    assert_eq!(s, StatusCode::FORBIDDEN);

    let srv = server(Some(TOKEN), Some(64 << 10));
    for token in [None, Some("wrong-token-0123456789"), Some("")] {
        let (s, v) = srv.put("x", "application/zip", token, zip.clone()).await;
        assert_eq!(s, StatusCode::UNAUTHORIZED, "{token:?}: {v}");
    }
    let req = Request::put("/api/scenes/x")
        .header(header::CONTENT_TYPE, "application/zip")
        .header(header::AUTHORIZATION, format!("Basic {TOKEN}"))
        .body(Body::from(zip.clone()))
        .unwrap();
    let (s, h, _) = send(srv.app(), req).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED);
    assert!(h[header::WWW_AUTHENTICATE]
        .to_str()
        .unwrap()
        .starts_with("Bearer"));
    let (s, _) = srv.delete("own", None).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED);

    // The server's own scene: 409 for both writes; unknown: 404; bad ids: 422.
    let (s, v) = srv
        .put("own", "application/zip", Some(TOKEN), zip.clone())
        .await;
    assert_eq!(s, StatusCode::CONFLICT, "{v}");
    let (s, _) = srv.delete("own", Some(TOKEN)).await;
    assert_eq!(s, StatusCode::CONFLICT);
    let (s, _) = srv.delete("nothing", Some(TOKEN)).await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    for id in ["Big", "a_b", "..", &"x".repeat(65)] {
        let (s, v) = srv
            .put(id, "application/zip", Some(TOKEN), zip.clone())
            .await;
        assert!(
            s == StatusCode::UNPROCESSABLE_ENTITY || s == StatusCode::NOT_FOUND,
            "{id}: {s} {v}"
        );
    }
    // Wrong types; over the upload limit (64 KiB here), declared or streamed.
    for ct in ["application/json", "text/plain", ""] {
        let (s, v) = srv.put("x", ct, Some(TOKEN), zip.clone()).await;
        assert_eq!(s, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{ct}: {v}");
    }
    let (s, v) = srv
        .put("x", "application/zip", Some(TOKEN), vec![0u8; 65 << 10])
        .await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    let stream = futures_util_stream(vec![vec![0u8; 40 << 10], vec![0u8; 40 << 10]]);
    let req = Request::put("/api/scenes/x")
        .header(header::CONTENT_TYPE, "application/zip")
        .header(header::AUTHORIZATION, format!("Bearer {TOKEN}"))
        .body(stream)
        .unwrap();
    let (s, _, _) = send(srv.app(), req).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE);
    assert_eq!(srv.clean(), ["own"]);
}

#[tokio::test]
async fn an_upload_whose_bake_fails_is_listed_as_failed_with_its_error() {
    let _gate = common::shared();
    let mut srv = server(Some(TOKEN), None);
    // A 64 MiB budget: a million patches cannot be baked in it.
    srv.state = AppState::new(relight::server::ServerConfig {
        memory_budget: 64 << 20,
        ..srv.state.config.clone()
    })
    .unwrap();
    common::bake_all(&srv.state);
    let obj = format!("mtllib a.mtl\n{}", box_obj());
    let body = zip_of(&[
        ("a.obj", obj.as_bytes()),
        ("a.mtl", BOX_MTL.as_bytes()),
        ("scene.toml", b"[mesh]\ntarget_patches = 1000000\n"),
    ]);
    let (s, v) = srv.put("huge", "application/zip", Some(TOKEN), body).await;
    assert_eq!(s, StatusCode::ACCEPTED, "{v}");
    let summary = srv.settled("huge").await;
    assert_eq!(summary["status"], "failed", "{summary}");
    let error = summary["error"].as_str().unwrap_or("");
    assert!(error.contains("budget"), "{summary}");
    let (s, v) = srv.get("/api/scenes/huge").await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{v}");
    // A failed upload can be replaced or deleted.
    let (s, _) = srv.delete("huge", Some(TOKEN)).await;
    assert_eq!(s, StatusCode::NO_CONTENT);
    assert_eq!(srv.clean(), ["own"]);
}

/// A body sent in chunks without a length.
fn futures_util_stream(chunks: Vec<Vec<u8>>) -> Body {
    Body::from_stream(futures_util::stream::iter(
        chunks
            .into_iter()
            .map(|c| Ok::<_, std::io::Error>(axum::body::Bytes::from(c))),
    ))
}

#[tokio::test]
async fn hostile_archives_are_refused_and_leave_nothing_behind() {
    let _gate = common::shared();
    let srv = server(Some(TOKEN), None);
    let obj = format!("mtllib a.mtl\n{}", box_obj());
    let ok_files: Vec<(&str, &[u8])> =
        vec![("a.obj", obj.as_bytes()), ("a.mtl", BOX_MTL.as_bytes())];
    let with = |extra: (&str, &[u8])| {
        let mut f = ok_files.clone();
        f.push(extra);
        zip_of(&f)
    };
    let cases: Vec<(&str, Vec<u8>, StatusCode, &str)> = vec![
        (
            "traversal",
            with(("../evil.txt", b"x")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "climbs out",
        ),
        (
            "deep traversal",
            with(("tex/../../evil.txt", b"x")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "climbs out",
        ),
        (
            "absolute",
            with(("/etc/evil.txt", b"x")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "absolute",
        ),
        (
            "windows absolute",
            with(("C:\\evil.txt", b"x")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "drive letter",
        ),
        (
            "not a zip",
            b"PK this is not a zip".to_vec(),
            StatusCode::UNPROCESSABLE_ENTITY,
            "not a zip",
        ),
        (
            "empty zip",
            zip_of(&[]),
            StatusCode::UNPROCESSABLE_ENTITY,
            "no files",
        ),
        (
            "no model",
            zip_of(&[("readme.txt", b"hello")]),
            StatusCode::UNPROCESSABLE_ENTITY,
            "no .obj",
        ),
        (
            "broken obj",
            zip_of(&[
                ("a.obj", b"v 0 0 0\nf 1 2 3\n"),
                ("a.mtl", BOX_MTL.as_bytes()),
            ]),
            StatusCode::UNPROCESSABLE_ENTITY,
            "x/a.obj:2",
        ),
        (
            "mtllib outside",
            zip_of(&[(
                "a.obj",
                b"mtllib ../../etc/passwd\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            )]),
            StatusCode::UNPROCESSABLE_ENTITY,
            "outside",
        ),
    ];
    for (what, body, status, needle) in cases {
        let (s, v) = srv.put("x", "application/zip", Some(TOKEN), body).await;
        assert_eq!(s, status, "{what}: {v}");
        assert!(problem(&v, needle), "{what}: wanted '{needle}' in {v}");
    }
    // A symbolic link entry.
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (n, b) in &ok_files {
        w.start_file(*n, SimpleFileOptions::default()).unwrap();
        w.write_all(b).unwrap();
    }
    w.add_symlink("link.png", "/etc/passwd", SimpleFileOptions::default())
        .unwrap();
    let body = w.finish().unwrap().into_inner();
    let (s, v) = srv.put("x", "application/zip", Some(TOKEN), body).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    assert!(problem(&v, "symbolic link"), "{v}");
    // Too many entries.
    let names: Vec<String> = (0..1001).map(|i| format!("f{i}.txt")).collect();
    let many: Vec<(&str, &[u8])> = names.iter().map(|n| (n.as_str(), &b""[..])).collect();
    let (s, v) = srv
        .put("x", "application/zip", Some(TOKEN), zip_of(&many))
        .await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    assert!(problem(&v, "more than 1000 entries"), "{v}");
    // A zip bomb: 1 MB of deflated zeros that unpacks to more than 1 GiB.
    let (s, v) = srv.put("x", "application/zip", Some(TOKEN), bomb()).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    assert!(problem(&v, "unpacks to more than 1024 MiB"), "{v}");
    // A .glb that is not one.
    let (s, v) = srv
        .put(
            "x",
            "model/gltf-binary",
            Some(TOKEN),
            b"PK\x03\x04 zip".to_vec(),
        )
        .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    assert!(problem(&v, "not a glTF binary"), "{v}");
    // Nothing was stored, nothing is listed.
    assert_eq!(srv.clean(), ["own"]);
    let (s, _) = srv.get("/api/scenes/x").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn glb_uploads_whose_node_trees_repeat_or_share_children_are_refused_with_422() {
    let _gate = common::shared();
    use proptest::strategy::{Strategy, ValueTree};
    let srv = server(Some(TOKEN), None);
    // The finding: a child named ten times at each of eight levels (10⁸ instances).
    let mut children: Vec<Vec<usize>> = (0..8).map(|k| vec![k + 1; 10]).collect();
    children.push(Vec::new());
    let body = crate::gltf_import::tree_glb(&children, Some(&[0]));
    let (s, v) = srv.put("x", "model/gltf-binary", Some(TOKEN), body).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
    assert!(
        problem(&v, "nodes[1] appears twice in the children of nodes[0]"),
        "{v}"
    );
    // Generated trees with one fault each: a repeated or shared child, a root that is a
    // child, a cycle.
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut faulty = 0;
    while faulty < 24 {
        let f = crate::gltf_import::forest()
            .new_tree(&mut runner)
            .unwrap()
            .current();
        let Some(phrase) = f.fault else { continue };
        faulty += 1;
        let (s, v) = srv
            .put("x", "model/gltf-binary", Some(TOKEN), f.glb())
            .await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v} ({f:?})");
        assert!(problem(&v, phrase) && problem(&v, "nodes["), "{v} ({f:?})");
    }
    assert_eq!(srv.clean(), ["own"]);
}

/// A zip bomb, built once per run (deflating a GiB takes a few seconds).
fn bomb() -> Vec<u8> {
    static BOMB: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    BOMB.get_or_init(|| {
        let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bomb-1gib.zip");
        if let Ok(b) = std::fs::read(&path) {
            return b;
        }
        let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let o = SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .compression_level(Some(1))
            .large_file(true);
        w.start_file("zeros.obj", o).unwrap();
        let zeros = vec![0u8; 1 << 20];
        for _ in 0..1025 {
            w.write_all(&zeros).unwrap();
        }
        let b = w.finish().unwrap().into_inner();
        let _ = std::fs::write(&path, &b);
        b
    })
    .clone()
}
