//! Bakes and the CLI as processes: child bakes, failures, out-of-memory kills, closed pipes.

use relight::server::{AppState, ServerConfig};

use crate::common;

#[test]
fn failed_scene_errors_carried_absolute_server_paths() {
    let _gate = common::shared();
    let root = tempfile::tempdir().unwrap();
    let scene = root.path().join("broken");
    std::fs::create_dir(&scene).unwrap();
    std::fs::write(scene.join("broken.obj"), "mtllib missing.mtl\nv 0 0 0\n").unwrap();
    // Strict: a lenient load would only warn about the missing MTL file.
    std::fs::write(scene.join("scene.toml"), "strict = true\n").unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (status, _, err) = st.slot("broken").unwrap().status();
    assert_eq!(status, "failed");
    let err = err.unwrap();
    assert!(err.contains("missing.mtl"), "{err}");
    let abs = root.path().display().to_string();
    assert!(!err.contains(&abs), "'{err}' names the server path {abs}");
    let cache_abs = cache.path().display().to_string();
    assert!(!err.contains(&cache_abs), "{err}");
}

#[test]
fn a_scene_bakes_in_a_child_process_and_its_failure_is_reported() {
    let _gate = common::shared();
    let root = tempfile::tempdir().unwrap();
    let good = root.path().join("box");
    std::fs::create_dir(&good).unwrap();
    let obj = common::box_faces("room", "grey", [0.0; 3], [1.0; 3], true)
        + &common::quad(
            "lamp",
            "light",
            [
                [0.4, 0.99, 0.4],
                [0.6, 0.99, 0.4],
                [0.6, 0.99, 0.6],
                [0.4, 0.99, 0.6],
            ],
            [0.0, -1.0, 0.0],
        );
    std::fs::write(good.join("box.obj"), format!("mtllib box.mtl\n{obj}")).unwrap();
    std::fs::write(
        good.join("box.mtl"),
        format!("{}newmtl light\nKd 0 0 0\nKe 10 10 10\n", common::GREY_MTL),
    )
    .unwrap();
    std::fs::write(good.join("scene.toml"), "[mesh]\ntarget_patches = 200\n").unwrap();
    let bad = root.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    std::fs::write(bad.join("bad.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        bake_command: Some(env!("CARGO_BIN_EXE_relight").into()),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (s, ready, _) = st.slot("box").unwrap().status();
    assert_eq!(s, "ready");
    // Baked by the child, loaded by the server from the entry the child wrote.
    assert!(ready.unwrap().model.baked.stats.from_cache);
    let (s, _, err) = st.slot("bad").unwrap().status();
    assert_eq!(s, "failed");
    let err = err.unwrap();
    assert!(err.contains("bad.obj"), "{err}");
    // The child wrote the cache entry the server loaded.
    assert!(std::fs::read_dir(cache.path()).unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with("box-")));
}

#[test]
fn cli_on_a_closed_pipe_panicked_with_a_backtrace() {
    let _gate = common::shared();
    use std::io::Read;
    use std::process::{Command, Stdio};
    let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-pipe-cache");
    let mut child = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["radiosity", "--json", "--cache"])
        .arg(&cache)
        .arg(common::scenes_dir().join("cornell-box"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then close the pipe, like `| head -c 1`.
    let mut out = child.stdout.take().unwrap();
    let mut one = [0u8; 1];
    out.read_exact(&mut one).unwrap();
    drop(out);
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    assert!(status.success(), "{status}: {err}");
}

#[cfg(unix)]
#[test]
fn a_bake_that_runs_out_of_memory_took_the_server_down() {
    let _gate = common::shared();
    use std::os::unix::fs::PermissionsExt;
    // The kernel's OOM killer ends a process with SIGKILL: a stand-in bake command that
    // dies that way must leave the server up and the scene failed with the reason.
    let root = tempfile::tempdir().unwrap();
    let scene = root.path().join("huge");
    std::fs::create_dir(&scene).unwrap();
    std::fs::write(scene.join("huge.obj"), "v 0 0 0\n").unwrap();
    let bin = tempfile::tempdir().unwrap();
    let exe = bin.path().join("fake-bake");
    std::fs::write(&exe, "#!/bin/sh\necho '{\"progress\": 0.1}'\nkill -9 $$\n").unwrap();
    std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let st = AppState::new(ServerConfig {
        scenes: root.path().to_path_buf(),
        cache: cache.path().to_path_buf(),
        bake_command: Some(exe),
        ..ServerConfig::default()
    })
    .unwrap();
    st.bake_all();
    let (status, _, err) = st.slot("huge").unwrap().status();
    assert_eq!(status, "failed");
    let err = err.unwrap();
    assert!(
        err.contains("signal 9") && err.contains("out of memory"),
        "{err}"
    );
}
