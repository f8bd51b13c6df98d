//! Broken scenes give clear errors that name the file and line or object; none panics.

use relight::scene::Scene;

use crate::common::{self, *};

fn load_err(obj: &str, mtl: &str, toml: Option<&str>) -> String {
    let s = write_scene(obj, mtl, toml);
    match Scene::load(s.path()) {
        Ok(_) => panic!("scene should not load"),
        Err(e) => e.to_string(),
    }
}

const TRI: &str = "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n";

#[test]
fn missing_mtl_names_the_obj_line() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, None);
    let obj = std::fs::read_to_string(s.path().join("scene.obj")).unwrap();
    std::fs::write(
        s.path().join("scene.obj"),
        obj.replace("mtllib scene.mtl", "mtllib nowhere.mtl"),
    )
    .unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(
        e.contains("scene.obj:1") && e.contains("nowhere.mtl"),
        "{e}"
    );
}

#[test]
fn nan_coordinates_name_the_line() {
    let _gate = common::shared();
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0\nv nan 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    // Line 1 is mtllib, so the NaN vertex is on line 5.
    assert!(e.contains("scene.obj:5") && e.contains("nan"), "{e}");
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let _gate = common::shared();
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nf 1 2 7\n",
        GREY_MTL,
        None,
    );
    assert!(
        e.contains("scene.obj:6") && e.contains("out of range"),
        "{e}"
    );
}

#[test]
fn degenerate_triangles_are_skipped_with_a_warning() {
    let _gate = common::shared();
    let obj = format!("{TRI}o sliver\nusemtl grey\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 4 5 6\n");
    let s = write_scene(&obj, GREY_MTL, None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("sliver") && w.contains("degenerate")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn reflectance_of_one_or_more_is_rejected() {
    let _gate = common::shared();
    let e = load_err(TRI, "newmtl grey\nKd 1.0 0.5 0.5\n", None);
    assert!(
        e.contains("scene.mtl:2") && e.contains("grey") && e.contains("[0, 1)"),
        "{e}"
    );
}

#[test]
fn unknown_material_names_the_line() {
    let _gate = common::shared();
    let e = load_err(
        "o floor\nusemtl chrome\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    assert!(e.contains("scene.obj:3") && e.contains("chrome"), "{e}");
}

#[test]
fn unknown_light_reference_names_the_light() {
    let _gate = common::shared();
    let toml = "[[lights]]\nid = \"desk\"\nsurfaces = [\"lampshade\"]\n";
    let e = load_err(TRI, GREY_MTL, Some(toml));
    assert!(
        e.contains("scene.toml") && e.contains("desk") && e.contains("lampshade"),
        "{e}"
    );
}

#[test]
fn empty_scene_is_an_error() {
    let _gate = common::shared();
    let e = load_err("# nothing here\n", GREY_MTL, None);
    assert!(e.contains("no usable triangles"), "{e}");
}

#[test]
fn malformed_scene_toml_names_the_line() {
    let _gate = common::shared();
    let e = load_err(TRI, GREY_MTL, Some("name = \"x\"\n[mesh]\nmax_edg = 0.1\n"));
    assert!(e.contains("scene.toml") && e.contains("max_edg"), "{e}");
}

#[test]
fn folder_without_obj_is_an_error() {
    let _gate = common::shared();
    let dir = tempfile::tempdir().unwrap();
    let e = Scene::load(dir.path()).unwrap_err().to_string();
    assert!(e.contains("no .obj"), "{e}");
}

#[test]
fn obj_without_scene_toml_gets_one_group_per_emissive_material() {
    let _gate = common::shared();
    let obj = format!("{TRI}o lamp\nusemtl glow\nv 0 1 0\nv 0 1 1\nv 1 1 0\nf 4 5 6\n");
    let s = write_scene(
        &obj,
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0 0 0\nKe 5 5 5\n",
        None,
    );
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].id, "glow");
}

#[test]
fn millimetre_models_are_scaled_to_metres() {
    let _gate = common::shared();
    let s = write_scene(TRI, GREY_MTL, Some("units = \"mm\"\n"));
    let scene = Scene::load(s.path()).unwrap();
    let max_x = scene.triangles[0].p.iter().map(|p| p.x).fold(0.0, f64::max);
    assert!((max_x - 0.001).abs() < 1e-12, "{max_x}");
}

#[test]
fn bad_luminaires_and_grids_get_precise_errors() {
    let _gate = common::shared();
    let lum = |extra: &str| format!("[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\n{extra}\n");
    let cases: Vec<(String, &str)> = vec![
        (lum("lumens = 100\nies = \"missing.ies\""), "missing.ies"),
        (lum(""), "lumens is required"),
        (
            lum("lumens = 100\ndistribution = \"spot\"\nbeam_deg = 60\nfield_deg = 30"),
            "beam_deg",
        ),
        (
            lum("lumens = 100\ndistribution = \"laser\""),
            "distribution 'laser'",
        ),
        (lum("lumens = 100\ncct = 200"), "cct = 200"),
        (lum("lumens = 100\naim = [0, 0, 0]"), "aim"),
        (lum("lumens = -5"), "lumens = -5"),
        (
            lum("lumens = 100\ncolor = [1, 1, 1]\ncct = 3000"),
            "color or cct",
        ),
        (
            "[[grids]]\nid = \"g\"\nspacing = 0.1\n".into(),
            "give either points",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [100, 100]\nspacing = 0.01\n".into(),
            "the limit is",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [1, 0]\nmax = [0, 1]\n".into(),
            "max must exceed min",
        ),
        (
            "[[lights]]\nid = \"empty\"\n".into(),
            "names no materials or surfaces, and no luminaire joins it",
        ),
    ];
    for (toml, needle) in cases {
        let e = load_err(TRI, GREY_MTL, Some(&toml));
        assert!(e.contains(needle), "{toml}\n→ {e}");
    }
    // A broken IES file names the file and what is wrong.
    let s = write_scene(TRI, GREY_MTL, Some(&lum("ies = \"bad.ies\"")));
    std::fs::write(
        s.path().join("bad.ies"),
        "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1\n",
    )
    .unwrap();
    let e = Scene::load(s.path()).unwrap_err().to_string();
    assert!(e.contains("bad.ies") && e.contains("ends before"), "{e}");
}

// ---- Hardening: each test is named after the finding it guards. ----

use relight::limits;

/// The scene's id as errors show it (the temporary folder's name).
fn id_of(s: &TempScene) -> String {
    s.path().file_name().unwrap().to_string_lossy().into_owned()
}

/// Asserts that an error names files relative to the scene folder, never absolutely.
fn assert_relative(e: &str, s: &TempScene) {
    let abs = s.path().to_string_lossy().into_owned();
    let canon = std::fs::canonicalize(s.path())
        .unwrap()
        .to_string_lossy()
        .into_owned();
    assert!(
        !e.contains(&abs) && !e.contains(&canon) && !e.contains("/tmp/"),
        "absolute path in: {e}"
    );
}

fn with_obj_line(s: &TempScene, from: &str, to: &str) {
    let p = s.path().join("scene.obj");
    let obj = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, obj.replace(from, to)).unwrap();
}

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
    // An empty MTL defines no material: the usemtl is unknown.
    let e = load_err(TRI, "", None);
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
fn kd_with_one_value_does_not_panic() {
    let _gate = common::shared();
    // One value means grey (MTL specification); it used to make tobj panic.
    let s = write_scene(TRI, "newmtl grey\nKd 0.5\n", None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.materials[0].kd, [0.5; 3]);
    // Two values, or four, are errors that name the file and line.
    for bad in ["Kd 0.5 0.5", "Kd 0.1 0.2 0.3 0.4", "Kd", "Ke 1 2"] {
        let e = load_err(TRI, &format!("newmtl grey\n{bad}\n"), None);
        assert!(
            e.contains("scene.mtl:2") && e.contains("needs 3 numbers"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn unparsable_mtl_line_is_an_error_not_a_silent_drop() {
    let _gate = common::shared();
    let obj = format!("{TRI}o lamp\nusemtl glow\nv 0 1 0\nv 0 1 1\nv 1 1 0\nf 4 5 6\n");
    // `Ns abc` made tobj drop every material, so emitters vanished. relight reads every
    // numeric statement, used or not: a damaged one is an error naming file and line.
    for (bad, needle) in [
        ("Ns abc", "Ns: 'abc' is not a number"),
        ("illum x", "illum: 'x' is not a number"),
        ("d", "d needs a number"),
        ("Ka 1 nan 1", "Ka: 'nan' is not a number"),
    ] {
        let mtl = format!("newmtl grey\nKd 0.5 0.5 0.5\n{bad}\nnewmtl glow\nKe 5 5 5\n");
        let e = load_err(&obj, &mtl, None);
        assert!(
            e.contains("scene.mtl:3") && e.contains(needle),
            "{bad}: {e}"
        );
    }
    // Well-formed statements it does not use are ignored, and every material is kept.
    let mtl = "newmtl grey\nKd 0.5 0.5 0.5\nNs 10\nillum 2\nd -halo 0.5\nKa spectral a.rfl 1\nmap_Kd\nnewmtl glow\nKe 5 5 5\n";
    let s = write_scene(&obj, mtl, None);
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.lights.len(), 1, "the emitter must not vanish");
    assert_eq!(scene.lights[0].id, "glow");
    // What relight does use is strict: a bad number names file, line and material.
    for (bad, needle) in [
        ("Ke 5 x 5", "'x' is not a number"),
        ("Ke 5 5 -1", "must be in [0"),
        ("Ke 5 5 1e39", "not a finite 32-bit number"),
        ("Ke 5 5 nan", "not a finite"),
        ("ke 5 5 5", "did you mean 'Ke'"),
        ("Ke spectral a.spd", "only RGB"),
    ] {
        let e = load_err(&obj, &mtl.replace("Ke 5 5 5", bad), None);
        assert!(
            e.contains("scene.mtl:9") && e.contains(needle),
            "{bad}: {e}"
        );
    }
    // Unknown statements are not errors, but they are reported.
    let s = write_scene(&obj, &format!("{mtl}Xyz 1\n"), None);
    let scene = Scene::load(s.path()).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("scene.mtl") && w.contains("'Xyz' on line 10")),
        "{:?}",
        scene.warnings
    );
    // A material defined twice is an error (which one would count?).
    let e = load_err(
        TRI,
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl grey\nKd 0.1 0.1 0.1\n",
        None,
    );
    assert!(
        e.contains("scene.mtl:3") && e.contains("defined twice"),
        "{e}"
    );
}

#[test]
fn obj_statements_tobj_would_misread_are_refused() {
    let _gate = common::shared();
    for (line, needle) in [
        ("l 1 2 3", "line elements"),
        ("v 1 2", "vertex needs 3 coordinates"),
        ("v 1 2 3 0", "w is 0"),
        ("v 1 2 3 4 5", "vertex needs 3 coordinates"),
        ("f 1/1/1/1 2 3", "bad face vertex"),
        ("f /1 2 3", "bad face vertex"),
        ("f 1/9 2 3", "texture coordinate index 9 out of range"),
        ("f 1//9 2 3", "normal index 9 out of range"),
        ("f 1 2 -9223372036854775808", "out of range"),
        ("f 1 2 99999999999999999999", "bad face index"),
        ("vt x 1", "bad vt value"),
        ("usemtl", "usemtl needs a material name"),
        ("mtllib", "mtllib needs a file name"),
    ] {
        let e = load_err(&format!("{TRI}{line}\n"), GREY_MTL, None);
        assert!(
            e.contains("scene.obj:8") && e.contains(needle),
            "{line}: {e}"
        );
    }
    // Vertex colours: all or none.
    let e = load_err(
        "o floor\nusemtl grey\nv 0 0 0 1 1 1\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        None,
    );
    assert!(e.contains("scene.obj:5") && e.contains("colours"), "{e}");
    // Well-formed extras load: w, colours, vt/vn references, a 2-vertex line, leading
    // blanks before usemtl, usemtl before mtllib.
    let s = write_scene(
        "o floor\n  usemtl grey\nv 0 0 0 2\nv 2 0 0 2\nv 0 0 2 2\nvt 0 0\nvn 0 1 0\n\
         f 1/1/1 3/1/1 2//1\nl 1 2\n",
        GREY_MTL,
        None,
    );
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(
        scene.materials[scene.triangles[0].material as usize].name,
        "grey"
    );
    assert!((scene.triangles[0].p[1].z - 1.0).abs() < 1e-12, "w divides");
    let s = write_scene(TRI, GREY_MTL, None);
    let p = s.path().join("scene.obj");
    let obj = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        obj.replace("mtllib scene.mtl\n", "") + "mtllib scene.mtl\n",
    )
    .unwrap();
    let scene = Scene::load(s.path()).unwrap();
    assert_eq!(
        scene.materials[scene.triangles[0].material as usize].name,
        "grey"
    );
}

#[test]
fn huge_numbers_are_refused_not_turned_into_null() {
    let _gate = common::shared();
    // OBJ coordinates: finite in f32 and within ±1e5 m after scaling.
    for (v, needle) in [
        ("v 3e38 0 0", "within ±1e5 m"),
        ("v 1e39 0 0", "not a finite 32-bit number"),
        ("v 1e5 0 0.5e6", "within ±1e5 m"),
    ] {
        let e = load_err(
            &format!("o floor\nusemtl grey\n{v}\nv 1 0 0\nv 0 0 1\nf 1 3 2\n"),
            GREY_MTL,
            None,
        );
        assert!(e.contains("scene.obj:4") && e.contains(needle), "{v}: {e}");
    }
    // ... which also depends on the unit scale.
    let e = load_err(
        "o floor\nusemtl grey\nv 2e5 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        Some("scale = 1.0\n"),
    );
    assert!(e.contains("scene.obj:4"), "{e}");
    let s = write_scene(
        "o floor\nusemtl grey\nv 2e5 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n",
        GREY_MTL,
        Some("units = \"mm\"\n"),
    );
    assert!(Scene::load(s.path()).is_ok(), "200 m in mm is fine");

    let lum = |extra: &str| format!("[[luminaires]]\nid = \"l\"\nposition = [0, 2, 0]\n{extra}\n");
    let cases: Vec<(String, &str)> = vec![
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\nlumens = 1e300\n".into(),
            "lumens = 1e300",
        ),
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\nintensity = 1e30\n".into(),
            "intensity",
        ),
        (
            "[[lights]]\nid = \"a\"\nmaterials = [\"grey\"]\ncolor = [1, inf, 1]\n".into(),
            "color",
        ),
        (lum("lumens = 1e300"), "lumens = 1e300"),
        (lum("lumens = nan"), "lumens = NaN"),
        (lum("lumens = 10\nwatts = 1e300"), "watts = 1e300"),
        (lum("lumens = 10\nefficacy = 1e9"), "efficacy"),
        (lum("lumens = 10\ncct = inf"), "cct = inf"),
        (
            lum("lumens = 10\ndistribution = \"spot\"\nbeam_deg = nan"),
            "beam_deg",
        ),
        (
            "[[luminaires]]\nid = \"l\"\nposition = [0, 3e38, 0]\nlumens = 1\n".into(),
            "outside ±1e5 m",
        ),
        (
            "[[cameras]]\nid = \"c\"\nposition = [0, 1e300, 0]\ntarget = [0, 0, 0]\nfov_deg = 60\n"
                .into(),
            "camera 'c'",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [1, 1]\nspacing = 1e-9\n".into(),
            "spacing = 1e-9",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [-1e300, 0]\nmax = [1e300, 1]\n".into(),
            "outside ±1e5 m",
        ),
        (
            "[[grids]]\nid = \"g\"\nmin = [0, 0]\nmax = [1, 1]\nheight = nan\n".into(),
            "height",
        ),
        (
            "[[grids]]\nid = \"g\"\npoints = [[0, 1e300, 0]]\n".into(),
            "points",
        ),
        ("scale = 1e300\n".into(), "scale = 1e300"),
        ("scale = 0\n".into(), "scale = 0"),
        ("[mesh]\nmax_edge = 1e-9\n".into(), "max_edge = 1e-9"),
        ("[mesh]\nmax_edge = inf\n".into(), "max_edge = inf"),
        (
            "[mesh]\ntarget_patches = 1000000000\n".into(),
            "target_patches = 1000000000",
        ),
        ("[mesh]\ntarget_patches = 0\n".into(), "target_patches = 0"),
    ];
    for (toml, needle) in cases {
        let e = load_err(TRI, GREY_MTL, Some(&toml));
        assert!(
            e.contains("scene.toml") && e.contains(needle),
            "{toml}\n→ {e}"
        );
    }
}

#[test]
fn ies_values_and_counts_are_bounded() {
    let _gate = common::shared();
    let ies = |header: &str, rest: &str| format!("IESNA:LM-63-2002\nTILT=NONE\n{header}\n{rest}");
    let ok_rest = "1 1 20\n0 45 90\n0\n1000 707.1 0\n";
    let cases = [
        (
            ies("1 1000 1 1000000000 1 1 2 0.1 0.1 0", ok_rest),
            "number of vertical angles = 1000000000",
            3,
        ),
        (
            ies("1 1000 1 2000 2000 1 2 0.1 0.1 0", ok_rest),
            "candela values; the limit is",
            3,
        ),
        (
            ies("1 1000 1e300 3 1 1 2 0.1 0.1 0", ok_rest),
            "candela multiplier",
            3,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 90\n0\n1e300 707.1 0\n",
            ),
            "candela value",
            7,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 45\n0\n1000 707.1 0\n",
            ),
            "must increase",
            5,
        ),
        (
            ies("1 1000 1 3.5 1 1 2 0.1 0.1 0", ok_rest),
            "whole number",
            3,
        ),
        (
            ies(
                "1 1000 1 3 1 1 2 0.1 0.1 0",
                "1 1 20\n0 45 90\n0\n1000 -1 0\n",
            ),
            "candela values = -1",
            7,
        ),
        (
            "TILT=INCLUDE\n1\n1e18\n".to_string(),
            "TILT pair count = 1e18",
            3,
        ),
    ];
    for (text, needle, line) in cases {
        let e = relight::photometry::parse_ies("office/x.ies", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("office/x.ies:{line}: ")) && e.contains(needle),
            "{needle}: {e}"
        );
    }
    let good = ies("1 1000 1 3 1 1 2 0.1 0.1 0", ok_rest);
    assert!(relight::photometry::parse_ies("x.ies", &good).is_ok());
}

#[test]
fn errors_name_scene_relative_paths() {
    let _gate = common::shared();
    let cases: Vec<(String, String, Option<String>)> = vec![
        (format!("{TRI}v nan 0 0\n"), GREY_MTL.into(), None),
        (TRI.into(), "newmtl grey\nKd 2 0 0\n".into(), None),
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

#[test]
fn scene_wide_counts_are_bounded() {
    let _gate = common::shared();
    // Luminaires: each adds shadow rays to every patch and grid point.
    let mut toml = String::new();
    for i in 0..=limits::MAX_LUMINAIRES {
        toml += &format!("[[luminaires]]\nid = \"l{i}\"\nposition = [0, 2, 0]\nlumens = 1\n");
    }
    let e = load_err(TRI, GREY_MTL, Some(&toml));
    assert!(
        e.contains("1001 [[luminaires]] entries; the limit is 1000"),
        "{e}"
    );
    // Grid points over all grids.
    let grid = |i: usize| {
        format!("[[grids]]\nid = \"g{i}\"\nmin = [0, 0]\nmax = [14, 14]\nspacing = 0.1\n")
    };
    let e = load_err(TRI, GREY_MTL, Some(&(0..3).map(grid).collect::<String>()));
    assert!(e.contains("points in all; the limit is 50000"), "{e}");
    // Light groups: one per unclaimed emissive material counts too.
    let mut mtl = String::from(GREY_MTL);
    let mut obj = String::from(TRI);
    for i in 0..=limits::MAX_LIGHT_GROUPS {
        mtl += &format!("newmtl e{i}\nKe 1 1 1\n");
        obj += &format!("o lamp{i}\nusemtl e{i}\nf 1 3 2\n");
    }
    let e = load_err(&obj, &mtl, None);
    assert!(
        e.contains("1001 light groups") && e.contains("the limit is 1000"),
        "{e}"
    );
}
