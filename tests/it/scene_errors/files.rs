//! Scene files on disk: escapes, FIFOs, directories, empty, non-UTF-8 and oversized files.

use relight::input_limits as limits;
use relight::scene::Scene;

use super::{assert_relative, id_of, load_err, with_obj_line, TRI};
use crate::common::{self, *};

#[test]
fn mtllib_outside_the_scene_folder_is_refused() {
    let _gate = common::shared();
    let outside = tempfile::tempdir().unwrap();
    let evil = outside.path().join("evil.mtl");
    std::fs::write(&evil, GREY_MTL).unwrap();
    let rel = format!(
        "../{}/evil.mtl",
        outside.path().file_name().unwrap().to_string_lossy()
    );
    for target in [
        "/etc/passwd".to_string(),
        "/dev/zero".to_string(),
        evil.to_string_lossy().into_owned(),
        rel,
    ] {
        let s = write_scene(TRI, GREY_MTL, None);
        with_obj_line(&s, "mtllib scene.mtl", &format!("mtllib {target}"));
        let e = Scene::load(s.path()).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}/scene.obj:1: mtllib '", id_of(&s)))
                && e.contains("outside the scene folder"),
            "{target}: {e}"
        );
    }
    // A symlink inside the folder that points outside is refused too.
    #[cfg(unix)]
    {
        let s = write_scene(TRI, GREY_MTL, None);
        std::os::unix::fs::symlink(&evil, s.path().join("link.mtl")).unwrap();
        with_obj_line(&s, "mtllib scene.mtl", "mtllib link.mtl");
        let e = Scene::load(s.path()).unwrap_err().to_string();
        assert!(e.contains("link.mtl") && e.contains("outside"), "{e}");
        assert_relative(&e, &s);
        // ... and so is a symlinked OBJ.
        let s = write_scene(TRI, GREY_MTL, None);
        let obj = outside.path().join("x.obj");
        std::fs::rename(s.path().join("scene.obj"), &obj).unwrap();
        std::os::unix::fs::symlink(&obj, s.path().join("scene.obj")).unwrap();
        let e = Scene::load(s.path()).unwrap_err().to_string();
        assert!(e.contains("scene.obj") && e.contains("outside"), "{e}");
    }
}

#[test]
fn ies_outside_the_scene_folder_is_refused() {
    let _gate = common::shared();
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(
        outside.path().join("x.ies"),
        "IESNA:LM-63-2002\nTILT=NONE\n",
    )
    .unwrap();
    let name = outside.path().file_name().unwrap().to_string_lossy();
    for ies in [
        "../../x.ies".to_string(),
        format!("../{name}/x.ies"),
        outside.path().join("x.ies").to_string_lossy().into_owned(),
    ] {
        // The ies line is line 5 of scene.toml.
        let toml = format!(
            "[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\nlumens = 10\nies = \"{ies}\"\n"
        );
        let s = write_scene(TRI, GREY_MTL, Some(&toml));
        let e = Scene::load(s.path()).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}/scene.toml:5: luminaire 'l': ies '", id_of(&s)))
                && e.contains("outside the scene folder"),
            "{ies}: {e}"
        );
    }
}

#[cfg(unix)]
fn mkfifo(p: &std::path::Path) {
    let st = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .unwrap();
    assert!(st.success());
}

#[cfg(unix)]
#[test]
fn fifo_as_obj_mtl_or_ies_is_refused_without_blocking() {
    let _gate = common::shared();
    let t0 = std::time::Instant::now();
    // MTL
    let s = write_scene(TRI, GREY_MTL, None);
    std::fs::remove_file(s.path().join("scene.mtl")).unwrap();
    mkfifo(&s.path().join("scene.mtl"));
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(
        e.contains("scene.mtl") && e.contains("not a regular file (a FIFO)"),
        "{e}"
    );
    // OBJ
    let s = write_scene(TRI, GREY_MTL, None);
    std::fs::remove_file(s.path().join("scene.obj")).unwrap();
    mkfifo(&s.path().join("scene.obj"));
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.obj") && e.contains("FIFO"), "{e}");
    // IES
    let toml = "[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\nies = \"d.ies\"\n";
    let s = write_scene(TRI, GREY_MTL, Some(toml));
    mkfifo(&s.path().join("d.ies"));
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("d.ies") && e.contains("FIFO"), "{e}");
    // scene.toml
    let s = write_scene(TRI, GREY_MTL, None);
    mkfifo(&s.path().join("scene.toml"));
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.toml") && e.contains("FIFO"), "{e}");
    assert!(t0.elapsed().as_secs() < 5, "a FIFO blocked the loader");
}

#[test]
fn directory_named_like_an_obj_is_refused() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("x.obj")).unwrap();
    let e = Scene::load(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("x.obj") && e.contains("not a regular file (a directory)"),
        "{e}"
    );
    // A directory as the MTL.
    let s = write_scene(TRI, GREY_MTL, None);
    std::fs::create_dir(s.path().join("d.mtl")).unwrap();
    with_obj_line(&s, "mtllib scene.mtl", "mtllib d.mtl");
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("d.mtl") && e.contains("directory"), "{e}");
}

#[test]
fn empty_files_give_clean_errors() {
    let _gate = common::shared();
    let s = write_scene("", "", None);
    std::fs::write(s.path().join("scene.obj"), "").unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("no usable triangles"), "{e}");
    // An empty MTL defines no material: the usemtl is unknown (an error when strict,
    // grey with a warning otherwise: tests/it/lenient.rs).
    let e = load_err(TRI, "", Some("strict = true\n"));
    assert!(
        e.contains("scene.obj:3") && e.contains("unknown material 'grey'"),
        "{e}"
    );
    // An empty scene.toml is the default configuration.
    let s = write_scene(TRI, GREY_MTL, Some(""));
    assert!(Scene::load(s.path()).is_ok());
    // An empty IES file.
    let toml = "[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\nies = \"d.ies\"\n";
    let s = write_scene(TRI, GREY_MTL, Some(toml));
    std::fs::write(s.path().join("d.ies"), "").unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("d.ies") && e.contains("TILT"), "{e}");
}

#[test]
fn non_utf8_bytes_name_the_line() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, None);
    let p = s.path().join("scene.obj");
    let mut bytes = std::fs::read(&p).unwrap();
    bytes.extend_from_slice(b"o caf\xe9\n");
    std::fs::write(&p, bytes).unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.obj:8") && e.contains("not UTF-8"), "{e}");
    let s = write_scene(TRI, GREY_MTL, None);
    std::fs::write(
        s.path().join("scene.mtl"),
        b"newmtl grey\nKd 0.5 0.5 0.5\n# \xff\n",
    )
    .unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.mtl:3") && e.contains("not UTF-8"), "{e}");
    let s = write_scene(TRI, GREY_MTL, None);
    std::fs::write(s.path().join("scene.toml"), b"\n\nname = \"\xc3(\"\n").unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.toml:3") && e.contains("not UTF-8"), "{e}");
}

#[test]
fn files_over_their_size_limit_are_refused() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, None);
    // A sparse file one byte over the limit: refused from its size, never read.
    let f = std::fs::OpenOptions::new()
        .append(true)
        .open(s.path().join("scene.mtl"))
        .unwrap();
    f.set_len(limits::MAX_TEXT_BYTES + 1).unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(
        e.contains("scene.mtl") && e.contains("larger than the limit of 16 MiB"),
        "{e}"
    );
    let s = write_scene(TRI, GREY_MTL, None);
    let f = std::fs::OpenOptions::new()
        .append(true)
        .open(s.path().join("scene.obj"))
        .unwrap();
    f.set_len(limits::MAX_OBJ_BYTES + 1).unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("scene.obj") && e.contains("256 MiB"), "{e}");
}

#[test]
fn errors_name_scene_relative_paths() {
    let _gate = common::shared();
    let cases: Vec<(String, String, Option<String>)> = vec![
        (format!("{TRI}v nan 0 0\n"), GREY_MTL.into(), None),
        (
            TRI.into(),
            "newmtl grey\nKd 2 0 0\n".into(),
            Some("strict = true\n".into()),
        ),
        (
            TRI.into(),
            GREY_MTL.into(),
            Some("[mesh]\nmax_edg = 1\n".into()),
        ),
        (
            TRI.into(),
            GREY_MTL.into(),
            Some("[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\nies = \"no.ies\"\n".into()),
        ),
        (
            TRI.into(),
            GREY_MTL.into(),
            Some("[[lights]]\nid = \"x\"\n".into()),
        ),
        ("# nothing\n".into(), GREY_MTL.into(), None),
    ];
    for (obj, mtl, toml) in cases {
        let s = write_scene(&obj, &mtl, toml.as_deref());
        let e = Scene::load(s.path()).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}/scene.", id_of(&s))), "{e}");
        assert_relative(&e, &s);
    }
    // Bake errors too (the cache key, the patch limit).
    let s = write_scene(TRI, GREY_MTL, Some("[mesh]\nmax_edge = 0.0001\n"));
    let e = relight::bake::load_or_bake(
        s.path(),
        relight::bake::CachePolicy::Off,
        &Default::default(),
        &|_, _| {},
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.starts_with(&id_of(&s)), "{e}");
    assert_relative(&e, &s);
}
