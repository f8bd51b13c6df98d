//! The on-disk cache: reloads fast and identically, rejects corrupt, stale and foreign
//! entries, and never leaves temporary files behind.

use relight::bake::{load_or_bake, BakeError, BakeOptions, CachePolicy};

use crate::common::{self, *};

fn small_scene() -> TempScene {
    let obj = box_faces("room", "wall", [0., 0., 0.], [2., 2., 2.], true)
        + &quad(
            "lamp",
            "lamp",
            [
                [0.8, 1.99, 0.8],
                [1.2, 1.99, 0.8],
                [1.2, 1.99, 1.2],
                [0.8, 1.99, 1.2],
            ],
            [0., -1., 0.],
        );
    write_scene(
        &obj,
        "newmtl wall\nKd 0.6 0.5 0.4\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n",
        Some("[mesh]\ntarget_patches = 600\n"),
    )
}

fn load(dir: &std::path::Path, policy: CachePolicy<'_>) -> Result<relight::bake::Baked, BakeError> {
    load_or_bake(dir, policy, &BakeOptions::default(), &|_, _| {})
}

#[test]
fn second_load_comes_from_the_cache_and_is_identical() {
    let _gate = common::shared();
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(!a.stats.from_cache);
    let b = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(b.stats.from_cache);
    assert_eq!(a.transfer.groups[0].b, b.transfer.groups[0].b);
    assert_eq!(a.transfer.groups[0].h, b.transfer.groups[0].h);
    let e: Vec<f32> = a.transfer.groups[0].e.iter().map(|x| x * 0.5).collect();
    assert_eq!(
        a.transfer.solve(&e).unwrap().b,
        b.transfer.solve(&e).unwrap().b
    );
    // Only the entry itself is in the folder: no temporary files.
    let names: Vec<String> = std::fs::read_dir(cache.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    assert!(names[0].ends_with(".rlt"));
}

/// Grid responses are part of the bake: the cache entry holds them, so a cached load
/// gathers nothing and answers the same numbers.
#[test]
fn grid_responses_are_baked_into_the_cache() {
    let _gate = common::shared();
    let s = small_scene();
    let toml = "[mesh]\ntarget_patches = 600\n[[grids]]\nid = \"floor\"\npoints = [[0.5, 0.0, 0.5], [1.0, 0.0, 1.0], [1.5, 0.0, 0.5]]\n";
    std::fs::write(s.path().join("scene.toml"), toml).unwrap();
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert_eq!(a.transfer.grids.len(), 1);
    assert_eq!(a.transfer.grids[0].len(), 1);
    assert_eq!(a.transfer.grids[0][0].len(), 9);
    // A 1.6 lm panel 2 m above, in a closed 2 m box of ρ ≈ 0.5: a fraction of a lux.
    assert!(
        a.transfer.grids[0][0].iter().all(|&v| v > 0.02 && v < 2.0),
        "{:?}",
        a.transfer.grids[0][0]
    );
    let header = relight::bake::cache::read_header(a.stats.cache_path.as_ref().unwrap()).unwrap();
    assert_eq!(header.grid_points, vec![3]);
    assert!(header.sections.iter().any(|s| s.name == "grid0g0"));
    let b = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(b.stats.from_cache);
    assert_eq!(a.transfer.grids, b.transfer.grids);
    // The gather weights come back too, and give the group's indirect light: the group's
    // response less its luminaires' direct light (none: the panel is emissive, and its
    // light reaches the points through the gather as well).
    assert_eq!(a.transfer.grid_gathers, b.transfer.grid_gathers);
    assert_eq!(header.grid_weights.len(), 1);
    let w = &b.transfer.grid_gathers[0];
    assert_eq!(w.points(), 3);
    let radiosity = relight::color::Rgb::column(&b.transfer.groups[0].b);
    for p in 0..3 {
        let e = w.illuminance(p, radiosity);
        for c in 0..3 {
            let want = b.transfer.grids[0][0][3 * p + c] as f64;
            assert!(
                (e.0[c] - want).abs() <= 1e-4 * want,
                "point {p}: {} against {want}",
                e.0[c]
            );
        }
    }
    // A grid whose weights were not kept (over MAX_GRID_WEIGHTS) gathers at its points
    // instead, with rays where the radiosity is: within 2 % of the weights here.
    let none = relight::transport::probe::GridGather::default();
    let grid = &b.scene.grids[0];
    let n = glam::DVec3::from_array(grid.normal);
    for (p, x) in grid.points.iter().enumerate() {
        let x = glam::DVec3::from_array(*x);
        let got = none.indirect(p, &b.transfer.groups[0].b, &b.mesh, &b.bvh, x, n);
        let want = w.illuminance(p, radiosity);
        assert!(
            (got.luminance() / want.luminance() - 1.0).abs() < 0.02,
            "point {p}: {got:?} against {want:?}"
        );
    }
}

/// A grid in a scene without light groups (the bundled rooflight: daylight only) has no
/// per-group responses, and the header counted its points from them: 0. The gather
/// weights' offsets were then expected to be 4 bytes long, and the entry the bake had
/// just written was rejected on every load.
#[test]
fn a_grid_in_a_scene_without_light_groups_made_its_cache_entry_unreadable() {
    let _gate = common::shared();
    let obj = box_faces("room", "wall", [0., 0., 0.], [2., 2., 2.], true);
    let toml = "[mesh]\ntarget_patches = 300\n[[grids]]\nid = \"floor\"\npoints = [[0.5, 0.0, 0.5], [1.5, 0.0, 1.5]]\n";
    let s = write_scene(&obj, "newmtl wall\nKd 0.6 0.5 0.4\n", Some(toml));
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert_eq!(a.transfer.groups.len(), 0);
    assert_eq!(a.transfer.grid_gathers[0].points(), 2);
    let b = load(s.path(), CachePolicy::ReadOnly(cache.path())).expect("the entry loads");
    assert!(b.stats.from_cache);
    assert_eq!(a.transfer.grid_gathers, b.transfer.grid_gathers);
}

#[test]
fn corrupt_entry_is_detected_and_rebaked() {
    let _gate = common::shared();
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    let path = a.stats.cache_path.clone().unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let k = bytes.len() - 100;
    bytes[k] ^= 0x55;
    std::fs::write(&path, &bytes).unwrap();
    // Read-only: the corruption is reported, nothing is baked.
    match load(s.path(), CachePolicy::ReadOnly(cache.path())) {
        Err(BakeError::BadCache { source, .. }) => {
            assert!(source.to_string().contains("checksum"), "{source}")
        }
        other => panic!("expected BadCache, got {:?}", other.err()),
    }
    let b = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(!b.stats.from_cache);
    assert!(b
        .stats
        .cache_note
        .as_deref()
        .unwrap_or("")
        .contains("checksum"));
    assert_eq!(a.transfer.groups[0].b, b.transfer.groups[0].b);
    // Truncated files are caught too.
    std::fs::write(&path, &std::fs::read(&path).unwrap()[..1000]).unwrap();
    assert!(
        !load(s.path(), CachePolicy::ReadWrite(cache.path()))
            .unwrap()
            .stats
            .from_cache
    );
}

#[test]
fn editing_the_scene_makes_the_entry_stale() {
    let _gate = common::shared();
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    let mtl = s.path().join("scene.mtl");
    let text = std::fs::read_to_string(&mtl)
        .unwrap()
        .replace("Kd 0.6 0.5 0.4", "Kd 0.3 0.5 0.4");
    std::fs::write(&mtl, text).unwrap();
    // Read-only finds no entry for the new key.
    assert!(matches!(
        load(s.path(), CachePolicy::ReadOnly(cache.path())),
        Err(BakeError::NotCached { .. })
    ));
    let b = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(!b.stats.from_cache);
    // The old entry was pruned.
    assert_eq!(std::fs::read_dir(cache.path()).unwrap().count(), 1);
}

/// Regression: the cache key hashed scene.toml whole, so adding a camera (which only
/// places a view) rebaked a real model for 8 minutes. Cameras keep the entry; anything
/// else in scene.toml (here the mesh resolution) still makes it stale.
#[test]
fn adding_a_camera_keeps_the_baked_transfer() {
    let _gate = common::shared();
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    let toml = s.path().join("scene.toml");
    let text = std::fs::read_to_string(&toml).unwrap();
    let with_camera = format!(
        "{text}\n[[cameras]]\nid = \"corner\"\nposition = [0.2, 1.5, 0.2]\ntarget = [1, 1, 1]\nfov_deg = 60\n"
    );
    std::fs::write(&toml, &with_camera).unwrap();
    let b = load(s.path(), CachePolicy::ReadOnly(cache.path())).unwrap();
    assert!(b.stats.from_cache);
    assert_eq!(b.scene.cameras.len(), 1);
    std::fs::write(&toml, with_camera.replace("600", "500")).unwrap();
    assert!(matches!(
        load(s.path(), CachePolicy::ReadOnly(cache.path())),
        Err(BakeError::NotCached { .. })
    ));
}

#[test]
fn foreign_and_future_files_are_rejected_with_a_clear_message() {
    let _gate = common::shared();
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    let path = a.stats.cache_path.unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[8] = 99; // format version
    std::fs::write(&path, &bytes).unwrap();
    let e = load(s.path(), CachePolicy::ReadOnly(cache.path()))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("format version 99"), "{e}");
    std::fs::write(&path, b"GIF89a not a cache").unwrap();
    let e = load(s.path(), CachePolicy::ReadOnly(cache.path()))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("not a relight cache"), "{e}");
}

// ---- Hardening: each test is named after the finding it guards. ----

use relight::transport::transfer::TransferMode;

#[test]
fn patch_limit_is_checked_before_meshing() {
    let _gate = common::shared();
    // target_patches = 1,000,000 (the largest scene.toml accepts): refused from the
    // estimate, in milliseconds, instead of meshing for minutes: by a patch limit, and by
    // the memory budget (the limit a bake really has).
    let s = write_scene(
        &box_faces("room", "wall", [0., 0., 0.], [4., 3., 3.], true),
        "newmtl wall\nKd 0.5 0.5 0.5\n",
        Some("[mesh]\ntarget_patches = 1000000\n"),
    );
    let limited = BakeOptions {
        max_patches: 30_000,
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let e = load_or_bake(s.path(), CachePolicy::Off, &limited, &|_, _| {})
        .err()
        .unwrap();
    assert!(t0.elapsed().as_secs_f64() < 2.0, "{:?}", t0.elapsed());
    match &e {
        BakeError::TooLarge {
            patches,
            max,
            estimated,
            ..
        } => {
            assert!(*estimated);
            assert_eq!(*max, 30_000);
            // About 1e6 / 2.2 (the bound is below the real count, never above).
            assert!(*patches > 300_000 && *patches < 1_000_000, "{patches}");
        }
        other => panic!("{other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("would give at least") && msg.contains("the limit of 30000"),
        "{msg}"
    );
    // Without a patch limit, the memory budget refuses it before meshing.
    let budgeted = BakeOptions {
        memory_budget: Some(1 << 30),
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let e = load_or_bake(s.path(), CachePolicy::Off, &budgeted, &|_, _| {})
        .err()
        .unwrap();
    assert!(t0.elapsed().as_secs_f64() < 2.0, "{:?}", t0.elapsed());
    match &e {
        BakeError::OverBudget {
            patches,
            mode,
            needed,
            ..
        } => {
            assert!(*patches > 300_000, "{patches}");
            assert_eq!(*mode, TransferMode::Hierarchical);
            assert!(*needed > 1 << 30);
        }
        other => panic!("{other}"),
    }
    // A tiny max_edge override (CLI --max-edge) is refused the same way; a non-positive one
    // is an error of its own.
    let s = small_scene();
    for (edge, needle) in [
        (1e-6, "would give at least"),
        (0.0, "max_edge = 0"),
        (f64::NAN, "max_edge = NaN"),
    ] {
        let opts = BakeOptions {
            max_edge: Some(edge),
            ..Default::default()
        };
        let e = load_or_bake(s.path(), CachePolicy::Off, &opts, &|_, _| {})
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(needle), "{edge}: {e}");
    }
}

#[test]
fn meshing_stops_at_the_patch_limit() {
    let _gate = common::shared();
    // The estimate is a lower bound: when it passes but the mesh would not fit, refinement
    // itself stops as soon as it passes the limit.
    let s = small_scene();
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let full = relight::geometry::mesh::Mesh::build(&scene).len();
    let bound = relight::geometry::mesh::estimate_patches(&scene, scene.mesh.max_edge);
    assert!(bound as usize <= full && bound > 0, "{bound} vs {full}");
    let limit = (bound as usize + full) / 2;
    let e = relight::geometry::mesh::Mesh::try_build_with(&scene, scene.mesh.max_edge, limit)
        .unwrap_err();
    assert!(
        !e.estimated && e.limit == limit && e.at_least > limit as u64,
        "{e:?}"
    );
    // Within the limit, the limited mesh is the mesh.
    let m =
        relight::geometry::mesh::Mesh::try_build_with(&scene, scene.mesh.max_edge, full).unwrap();
    assert_eq!(
        m.fingerprint(),
        relight::geometry::mesh::Mesh::build(&scene).fingerprint()
    );
    // Through the bake: a limit between the bound and the real count.
    let opts = BakeOptions {
        max_patches: limit,
        ..Default::default()
    };
    let e = load_or_bake(s.path(), CachePolicy::Off, &opts, &|_, _| {})
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("meshing gives") && e.contains(&format!("limit of {limit}")),
        "{e}"
    );
}

#[test]
fn memory_budget_refuses_a_bake_before_allocating() {
    let _gate = common::shared();
    use relight::bake::{estimate_bake_bytes, estimate_load_bytes};
    // The estimate: 4n² for F; in factored mode 4n² per distinct channel LU and one
    // irradiance response more while the responses replace the LUs; a loaded factored
    // transfer holds the responses only.
    let n = 39_000usize;
    let sq = 4 * (n as u64) * (n as u64);
    let f1 = estimate_bake_bytes(n, TransferMode::Factored, 1, 1);
    let f3 = estimate_bake_bytes(n, TransferMode::Factored, 1, 3);
    let c = estimate_bake_bytes(n, TransferMode::Columns, 8, 3);
    assert!(f1 >= 3 * sq && f1 < 3 * sq + sq / 20, "{f1}");
    assert!(f3 >= 5 * sq && f3 < 5 * sq + sq / 20, "{f3}");
    assert!(c >= sq && c < sq + sq / 20, "{c}");
    assert!(estimate_load_bytes(n, TransferMode::Columns, 8, 3) < 200 << 20);
    assert_eq!(
        estimate_load_bytes(n, TransferMode::Factored, 1, 1),
        f1 - 2 * sq
    );
    assert_eq!(
        estimate_load_bytes(n, TransferMode::Factored, 1, 3),
        f3 - 2 * sq
    );

    let s = small_scene();
    let scene = relight::scene::Scene::load(s.path()).unwrap();
    let mesh = relight::geometry::mesh::Mesh::build(&scene);
    let est = relight::bake::memory_estimate(&scene, &mesh, TransferMode::Factored);
    // Two materials with grey and coloured reflectance: three distinct channels.
    assert_eq!((est.lu_count, est.groups, est.patches), (3, 1, mesh.len()));
    let opts = BakeOptions {
        memory_budget: Some(est.bake - 1),
        mode: Some(TransferMode::Factored),
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let e = load_or_bake(s.path(), CachePolicy::Off, &opts, &|_, _| {})
        .err()
        .unwrap();
    assert!(
        t0.elapsed().as_secs_f64() < 2.0,
        "refused before the form factors"
    );
    assert!(
        matches!(e, BakeError::OverBudget { action: "bake", .. }),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("needs about")
            && msg.contains(&format!("to bake {} patches in factored mode", mesh.len()))
            && msg.contains("the memory budget is"),
        "{msg}"
    );
    // Within budget, the bake runs; a cached load is checked against the load estimate.
    let cache = tempfile::tempdir().unwrap();
    let ok = BakeOptions {
        memory_budget: Some(est.bake),
        mode: Some(TransferMode::Factored),
        ..Default::default()
    };
    load_or_bake(
        s.path(),
        CachePolicy::ReadWrite(cache.path()),
        &ok,
        &|_, _| {},
    )
    .unwrap();
    let tight = BakeOptions {
        memory_budget: Some(est.load - 1),
        mode: Some(TransferMode::Factored),
        ..Default::default()
    };
    let e = load_or_bake(
        s.path(),
        CachePolicy::ReadOnly(cache.path()),
        &tight,
        &|_, _| {},
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("to load"), "{e}");
    // Columns mode: a cached load needs little, whatever the bake needed.
    let est = relight::bake::memory_estimate(&scene, &mesh, TransferMode::Columns);
    assert!(est.load < est.bake);
}

/// Writes a cache entry for the small scene and returns (scene, cache dir, entry path).
fn cached() -> (TempScene, tempfile::TempDir, std::path::PathBuf) {
    let s = small_scene();
    let cache = tempfile::tempdir().unwrap();
    let a = load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    let path = a.stats.cache_path.unwrap();
    (s, cache, path)
}

/// Rewrites the JSON header of a cache file through `edit`.
fn edit_header(path: &std::path::Path, edit: impl Fn(&mut serde_json::Value)) {
    let bytes = std::fs::read(path).unwrap();
    let hlen = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut h: serde_json::Value = serde_json::from_slice(&bytes[16..16 + hlen]).unwrap();
    edit(&mut h);
    let hj = serde_json::to_vec(&h).unwrap();
    let mut out = bytes[..12].to_vec();
    out.extend_from_slice(&(hj.len() as u32).to_le_bytes());
    out.extend_from_slice(&hj);
    out.extend_from_slice(&bytes[16 + hlen..]);
    std::fs::write(path, out).unwrap();
}

#[test]
fn cache_section_lengths_are_checked_before_allocating() {
    let _gate = common::shared();
    let reject = |path: &std::path::Path, s: &TempScene, cache: &std::path::Path, needle: &str| {
        let t0 = std::time::Instant::now();
        match load(s.path(), CachePolicy::ReadOnly(cache)) {
            Err(BakeError::BadCache { source, .. }) => {
                let m = source.to_string();
                assert!(m.contains(needle), "{needle}: {m}");
                // The message names the entry by its file name only.
                assert!(!m.contains(&*cache.to_string_lossy()), "{m}");
                assert!(
                    m.starts_with(&*path.file_name().unwrap().to_string_lossy()),
                    "{m}"
                );
            }
            other => panic!("{needle}: expected BadCache, got {:?}", other.err()),
        }
        assert!(t0.elapsed().as_secs_f64() < 2.0);
    };
    // A section claiming 1 TB: refused from the table, nothing is allocated.
    let (s, cache, path) = cached();
    edit_header(&path, |h| {
        h["sections"][0]["len"] = serde_json::json!(1u64 << 40)
    });
    reject(&path, &s, cache.path(), "bad extent");
    // A huge patch count (sizes overflow or exceed the file).
    let (s, cache, path) = cached();
    edit_header(&path, |h| h["patch_count"] = serde_json::json!(1u64 << 40));
    reject(&path, &s, cache.path(), "");
    // Thousands of groups that the section table does not list.
    let (s, cache, path) = cached();
    edit_header(&path, |h| h["groups"] = serde_json::json!(1u64 << 50));
    reject(&path, &s, cache.path(), "invalid");
    // Grids of a billion points each, which the section table does not list.
    let (s, cache, path) = cached();
    edit_header(&path, |h| {
        h["grid_points"] = serde_json::json!(vec![1u64 << 30; 4])
    });
    reject(&path, &s, cache.path(), "");
    // A section renamed, or listed twice.
    let (s, cache, path) = cached();
    edit_header(&path, |h| {
        h["sections"][1]["name"] = serde_json::json!("rho")
    });
    reject(
        &path,
        &s,
        cache.path(),
        "unexpected or repeated section 'rho'",
    );
    // Bytes appended after the last section, or missing.
    let (s, cache, path) = cached();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.extend_from_slice(&[0; 16]);
    std::fs::write(&path, &bytes).unwrap();
    reject(&path, &s, cache.path(), "the sections need");
    let (s, cache, path) = cached();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 4]).unwrap();
    reject(&path, &s, cache.path(), "the sections need");
    // A header length past the end of the file.
    let (s, cache, path) = cached();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[12..16].copy_from_slice(&(15u32 << 20).to_le_bytes());
    std::fs::write(&path, &bytes[..4096]).unwrap();
    reject(&path, &s, cache.path(), "runs past the end");
    // ... and beyond the header limit.
    let (s, cache, path) = cached();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    reject(&path, &s, cache.path(), "implausible");
}

#[test]
fn stale_temporary_files_are_removed() {
    let _gate = common::shared();
    use relight::bake::cache::{remove_stale_temps, STALE_TEMP_AGE, TEMP_PREFIX};
    let cache = tempfile::tempdir().unwrap();
    let old = std::time::SystemTime::now() - STALE_TEMP_AGE - std::time::Duration::from_secs(5);
    let mk = |name: &str, aged: bool| {
        let p = cache.path().join(name);
        std::fs::write(&p, b"partial").unwrap();
        if aged {
            std::fs::File::options()
                .write(true)
                .open(&p)
                .unwrap()
                .set_modified(old)
                .unwrap();
        }
        p
    };
    let dead = mk(
        &format!("{TEMP_PREFIX}123-abc-room-0123456789abcdef.rlt"),
        true,
    );
    let legacy = mk(".room-0123456789abcdef.rlt.tmp-4242", true);
    let live = mk(
        &format!("{TEMP_PREFIX}124-abd-room-0123456789abcdef.rlt"),
        false,
    );
    let foreign = mk("notes.txt", true);
    let entry = mk("room-0123456789abcdef.rlt", true);
    assert_eq!(remove_stale_temps(cache.path()), 2);
    assert!(!dead.exists() && !legacy.exists());
    assert!(live.exists() && foreign.exists() && entry.exists());
    assert_eq!(remove_stale_temps(cache.path()), 0);
    assert_eq!(remove_stale_temps(&cache.path().join("missing")), 0);
    // The bake pipeline cleans up when it starts using a cache folder.
    let dead = mk(&format!("{TEMP_PREFIX}125-abe-x.rlt"), true);
    let s = small_scene();
    load(s.path(), CachePolicy::ReadWrite(cache.path())).unwrap();
    assert!(!dead.exists());
    assert!(
        live.exists(),
        "a young temporary file may belong to a live writer"
    );
}
