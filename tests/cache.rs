//! The on-disk cache: reloads fast and identically, rejects corrupt, stale and foreign
//! entries, and never leaves temporary files behind.

mod common;

use common::*;
use relight::bake::{load_or_bake, BakeError, BakeOptions, CachePolicy};

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

#[test]
fn corrupt_entry_is_detected_and_rebaked() {
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

#[test]
fn foreign_and_future_files_are_rejected_with_a_clear_message() {
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
