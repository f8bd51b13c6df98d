//! Sharded hierarchical bakes: shards computed apart merge into the same cache entry as a
//! one-process bake, and missing, renamed, corrupt or mixed shards are named.

use std::path::{Path, PathBuf};
use std::process::Command;

use relight::bake::shard::{self, ShardId};
use relight::bake::{load_or_bake, BakeError, BakeOptions, CachePolicy};
use relight::scene::TransferChoice;

use crate::common::{self, TempScene};

/// The closed room with a block and a lamp panel of the hierarchical tests.
fn room() -> TempScene {
    crate::hierarchical::closed_room_of(600)
}

fn opts() -> BakeOptions {
    BakeOptions {
        choice: Some(TransferChoice::Hierarchical),
        ..Default::default()
    }
}

fn shards_in(cache: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(cache)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "rls"))
        .collect();
    v.sort();
    v
}

fn run_shards(s: &TempScene, cache: &Path, n: usize, which: &[usize]) {
    for &k in which {
        shard::bake_shard(s.path(), cache, ShardId { k, n }, &opts(), &|_| {}).unwrap();
    }
}

fn merge_err(s: &TempScene, cache: &Path) -> String {
    match shard::merge(s.path(), cache, &opts(), &|_, _| {}) {
        Err(e @ BakeError::Shards { .. }) => e.to_string(),
        Err(e) => panic!("expected a shard error, got {e}"),
        Ok(_) => panic!("expected a shard error, the merge succeeded"),
    }
}

#[test]
fn sharded_bakes_merge_to_the_one_process_bits() {
    let _gate = common::shared();
    let s = room();
    let one = load_or_bake(s.path(), CachePolicy::Off, &opts(), &|_, _| {}).unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for n in [1usize, 3, 7] {
        let cache = tempfile::tempdir().unwrap();
        run_shards(&s, cache.path(), n, &(0..n).collect::<Vec<_>>());
        assert_eq!(shards_in(cache.path()).len(), n);
        let st = shard::status(s.path(), cache.path(), &opts(), None).unwrap();
        assert!(
            st.iter().all(|x| x.state == "done") && st.len() == n,
            "{st:?}"
        );
        let merged = shard::merge(s.path(), cache.path(), &opts(), &|_, _| {}).unwrap();
        for (a, b) in one.transfer.groups.iter().zip(&merged.transfer.groups) {
            assert_eq!(bits(&a.b), bits(&b.b), "{n} shards: radiosity differs");
            assert_eq!(bits(&a.h), bits(&b.h), "{n} shards: illuminance differs");
        }
        assert_eq!(bits(&one.transfer.escape), bits(&merged.transfer.escape));
        // The entry is the normal one: a read-only load finds it; the shards are gone.
        let again = load_or_bake(
            s.path(),
            CachePolicy::ReadOnly(cache.path()),
            &opts(),
            &|_, _| {},
        )
        .unwrap();
        assert!(again.stats.from_cache);
        assert!(shards_in(cache.path()).is_empty());
    }
}

#[test]
fn missing_renamed_corrupt_and_mixed_shards_are_named() {
    let _gate = common::shared();
    let s = room();
    // Shard 1 of 3 never ran.
    let cache = tempfile::tempdir().unwrap();
    run_shards(&s, cache.path(), 3, &[0, 2]);
    let e = merge_err(&s, cache.path());
    assert!(e.contains("missing shard(s) 1 of 3"), "{e}");
    let st = shard::status(s.path(), cache.path(), &opts(), None).unwrap();
    let states: Vec<&str> = st.iter().map(|x| x.state).collect();
    assert_eq!(states, ["done", "missing", "done"]);
    // Shard 0's file copied over shard 1's name: a duplicate.
    let files = shards_in(cache.path());
    let one = files[0]
        .to_string_lossy()
        .replace("shard-0-of-3", "shard-1-of-3");
    std::fs::copy(&files[0], &one).unwrap();
    let e = merge_err(&s, cache.path());
    assert!(
        e.contains("shard 1 of 3") && e.contains("renamed or duplicated"),
        "{e}"
    );
    std::fs::remove_file(&one).unwrap();
    // A flipped byte in shard 2's data.
    run_shards(&s, cache.path(), 3, &[1]);
    let two = shards_in(cache.path())[2].clone();
    let mut bytes = std::fs::read(&two).unwrap();
    let last = bytes.len() - 5;
    bytes[last] ^= 0x40;
    std::fs::write(&two, &bytes).unwrap();
    let e = merge_err(&s, cache.path());
    assert!(
        e.contains("shard 2 of 3") && e.contains("checksum mismatch"),
        "{e}"
    );
    // Re-running the shard replaces it; then a stray shard of another count is refused.
    run_shards(&s, cache.path(), 3, &[2]);
    run_shards(&s, cache.path(), 2, &[0]);
    let e = merge_err(&s, cache.path());
    assert!(e.contains("different counts") && e.contains("2, 3"), "{e}");
    let stray = shards_in(cache.path())
        .into_iter()
        .find(|p| p.to_string_lossy().contains("-of-2"))
        .unwrap();
    std::fs::remove_file(stray).unwrap();
    // Shard 0 of another scene's bake (other reflectances) under this bake's name.
    let other = room();
    std::fs::write(
        other.path().join("scene.mtl"),
        std::fs::read_to_string(s.path().join("scene.mtl"))
            .unwrap()
            .replace("Kd 0.7 0.7 0.7", "Kd 0.6 0.6 0.6"),
    )
    .unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    run_shards(&other, elsewhere.path(), 3, &[0]);
    std::fs::copy(&shards_in(elsewhere.path())[0], &shards_in(cache.path())[0]).unwrap();
    let e = merge_err(&s, cache.path());
    assert!(e.contains("shard 0 of 3") && e.contains("foreign"), "{e}");
}

#[test]
fn shard_options_are_checked() {
    let _gate = common::shared();
    for (arg, needle) in [
        ("3/3", "K must be below N"),
        ("1/0", "N must be 1 to"),
        ("x/2", "K must be a whole number"),
        ("2", "give K/N"),
    ] {
        let e = ShardId::parse(arg).unwrap_err();
        assert!(e.contains(needle), "{arg}: {e}");
    }
    assert_eq!(ShardId::parse("2/8").unwrap(), ShardId { k: 2, n: 8 });
    // A scene that is not hierarchical cannot be sharded.
    let s = room();
    let cache = tempfile::tempdir().unwrap();
    let dense = BakeOptions {
        choice: Some(TransferChoice::Columns),
        ..Default::default()
    };
    let e = shard::bake_shard(
        s.path(),
        cache.path(),
        ShardId { k: 0, n: 2 },
        &dense,
        &|_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("need the hierarchical mode"), "{e}");
}

/// The CLI as a Kubernetes Indexed Job runs it: `--shard /N` reads JOB_COMPLETION_INDEX.
#[test]
fn cli_shards_read_the_job_completion_index_and_merge() {
    let _gate = common::shared();
    let s = room();
    let cache = tempfile::tempdir().unwrap();
    // `relight bake ROOM --transfer hierarchical ARGS --cache CACHE`.
    let bake = |args: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_relight"));
        c.args([
            "bake",
            s.path().to_str().unwrap(),
            "--transfer",
            "hierarchical",
        ])
        .args(args)
        .args(["--cache", cache.path().to_str().unwrap()]);
        c
    };
    for k in 0..2 {
        let out = bake(&["--shard", "/2"])
            .env("JOB_COMPLETION_INDEX", k.to_string())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(&format!("shard {k}/2:")), "{text}");
    }
    let out = bake(&["--merge", "--status"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("shard 0/2  done") && text.contains("shard 1/2  done"),
        "{text}"
    );
    let out = bake(&["--merge"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("merged"));
    // Without JOB_COMPLETION_INDEX, `/2` is a clear error.
    let out = Command::new(env!("CARGO_BIN_EXE_relight"))
        .args(["bake", s.path().to_str().unwrap(), "--shard", "/2"])
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("JOB_COMPLETION_INDEX"));
}
