//! `relight bake`: bakes scenes into the cache (form factors, factorization, light-group
//! columns), with a progress bar, or as the server's child process with JSON progress.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::{outln, progress_bar};
use relight::bake::{self, BakeOptions, CachePolicy, Stage};

#[derive(clap::Args)]
pub struct BakeArgs {
    /// Scene folder (OBJ + MTL + optional scene.toml). Omit with --all.
    scene: Option<PathBuf>,
    /// Bake every scene under --scenes.
    #[arg(long)]
    all: bool,
    /// Folder of scenes for --all.
    #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
    scenes: PathBuf,
    /// Cache folder [default: $RELIGHT_CACHE, $XDG_CACHE_HOME/relight or ~/.cache/relight].
    #[arg(long, env = "RELIGHT_CACHE")]
    cache: Option<PathBuf>,
    /// Bake even if a valid cache entry exists.
    #[arg(long)]
    force: bool,
    /// Memory budget: refuse a scene whose bake is estimated to need more (bytes with
    /// an optional unit such as 4G, or a percentage of memory such as 50%)
    /// [default: half of the machine's or the container's memory].
    #[arg(long, env = "RELIGHT_MEMORY_BUDGET", value_parser = relight::budget::parse_budget)]
    memory_budget: Option<u64>,
    /// Report progress as JSON lines on stdout (used by `relight serve`, which bakes in
    /// a child process).
    #[arg(long, hide = true)]
    progress_json: bool,
    /// Transfer mode, overriding scene.toml: auto, factored, columns or hierarchical.
    #[arg(long, value_parser = super::parse_transfer)]
    transfer: Option<relight::scene::TransferChoice>,
    /// Compute only shard K of N of a hierarchical bake into a shard file in the cache
    /// folder (`/N` takes K from JOB_COMPLETION_INDEX). Then `--merge`.
    #[arg(long, value_name = "K/N", value_parser = relight::bake::shard::ShardId::parse, conflicts_with_all = ["all", "merge", "force"])]
    shard: Option<relight::bake::shard::ShardId>,
    /// Merge the shard files of a sharded bake into the cache entry (all N must be done).
    #[arg(long, conflicts_with_all = ["all", "force"])]
    merge: bool,
    /// With --merge: only print which shards are done, running or missing.
    #[arg(long, requires = "merge")]
    status: bool,
}

pub fn run(a: BakeArgs) -> Result<()> {
    let BakeArgs {
        scene,
        all,
        scenes,
        cache,
        force,
        memory_budget,
        progress_json,
        transfer,
        shard,
        merge,
        status,
    } = a;
    let cache = cache.unwrap_or_else(bake::default_cache_dir);
    let budget = memory_budget.unwrap_or_else(relight::budget::default_budget);
    if shard.is_some() || merge {
        let Some(dir) = scene else {
            anyhow::bail!("--shard and --merge take one scene folder");
        };
        let opts = BakeOptions {
            memory_budget: Some(budget),
            choice: transfer,
            ..Default::default()
        };
        return sharded(&dir, &cache, &opts, shard, status);
    }
    if progress_json {
        // The server's child: the kernel's OOM killer should pick this process
        // before the server.
        let _ = std::fs::write("/proc/self/oom_score_adj", "1000");
        let Some(dir) = scene else {
            anyhow::bail!("--progress-json bakes one scene folder");
        };
        return match bake_child(&dir, &cache, budget, transfer) {
            Ok(()) => Ok(()),
            Err(e) => {
                outln!("{}", serde_json::json!({ "error": format!("{e:#}") }));
                std::process::exit(2);
            }
        };
    }
    let dirs = match (scene, all) {
        (Some(s), false) => vec![s],
        (None, true) => {
            bake::scene_dirs(&scenes).with_context(|| format!("reading {}", scenes.display()))?
        }
        _ => anyhow::bail!("give a scene folder or --all"),
    };
    let mut failed = 0;
    for d in dirs {
        if let Err(e) = bake_one(&d, &cache, force, budget, transfer) {
            eprintln!("error: {e:#}");
            failed += 1;
        }
    }
    if failed > 0 {
        anyhow::bail!("{failed} scene(s) failed");
    }
    Ok(())
}

/// `relight bake DIR --progress-json`: bakes into the cache, reporting progress as JSON
/// lines (`{"progress": 0.42}`) for the server that started this process.
fn bake_child(
    dir: &Path,
    cache: &Path,
    budget: u64,
    transfer: Option<relight::scene::TransferChoice>,
) -> Result<()> {
    let opts = BakeOptions {
        memory_budget: Some(budget),
        choice: transfer,
        ..Default::default()
    };
    use std::sync::atomic::{AtomicU64, Ordering};
    let last = AtomicU64::new((-1.0f64).to_bits());
    let progress = |stage: Stage, f: f64| {
        let p = stage.overall(f);
        if p - f64::from_bits(last.load(Ordering::Relaxed)) >= 0.005 {
            last.store(p.to_bits(), Ordering::Relaxed);
            outln!("{}", serde_json::json!({ "progress": p }));
        }
    };
    bake::load_or_bake(dir, CachePolicy::ReadWrite(cache), &opts, &progress)?;
    outln!("{}", serde_json::json!({ "progress": 1.0, "done": true }));
    Ok(())
}

fn bake_one(
    dir: &Path,
    cache: &Path,
    force: bool,
    budget: u64,
    transfer: Option<relight::scene::TransferChoice>,
) -> Result<()> {
    let label = dir
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let pb = progress_bar(&label);
    let policy = if force {
        CachePolicy::Rebuild(cache)
    } else {
        CachePolicy::ReadWrite(cache)
    };
    let progress = |stage: Stage, f: f64| {
        pb.set_message(format!("{stage:?}"));
        pb.set_position((stage.overall(f) * 1000.0) as u64);
    };
    let opts = BakeOptions {
        memory_budget: Some(budget),
        choice: transfer,
        ..Default::default()
    };
    let baked = bake::load_or_bake(dir, policy, &opts, &progress)?;
    pb.finish_and_clear();
    let s = &baked.stats;
    for w in &baked.scene.warnings {
        eprintln!("warning: {}: {w}", baked.scene.id);
    }
    outln!("scene          {}  ({})", baked.scene.id, baked.scene.name);
    outln!("patches        {}", s.patches);
    outln!("mode           {:?}", baked.transfer.mode);
    if s.from_cache {
        outln!("loaded from    cache in {:.3} s", s.load_s);
    } else {
        outln!("form factors   {:.2} s", s.form_factor_s);
        outln!("solve          {:.2} s", s.solve_s);
    }
    outln!("residual       {:.2e}", s.residual);
    if let Some(h) = &baked.transfer.hierarchy {
        let st = &h.stats;
        outln!(
            "links          {} ({:.1} per patch, {:.1} per node; {} patch to patch)",
            st.links,
            st.links as f64 / h.n.max(1) as f64,
            st.links as f64 / h.nodes().max(1) as f64,
            st.leaf_links
        );
        outln!(
            "closure        |S - (1 - escape)| mean {:.2e}, max {:.2e}; sigma {:.4}..{:.4}",
            st.closure_mean,
            st.closure_max,
            st.sigma_min,
            st.sigma_max
        );
        outln!(
            "hierarchy      refine {:.2} s, closure rays {:.2} s, {} sweeps",
            st.refine_s,
            st.closure_s,
            baked.transfer.info.sweeps
        );
    }
    outln!(
        "cache          {:.1} MB  {}",
        s.cache_bytes as f64 / 1e6,
        s.cache_path
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    );
    Ok(())
}

/// `--shard K/N`, `--merge` and `--merge --status`.
fn sharded(
    dir: &Path,
    cache: &Path,
    opts: &BakeOptions,
    shard: Option<relight::bake::shard::ShardId>,
    status: bool,
) -> Result<()> {
    use relight::bake::shard;
    if let Some(id) = shard {
        let last = std::sync::atomic::AtomicU64::new(u64::MAX);
        let progress = |x: f64| {
            let pct = (x * 100.0) as u64;
            if last.swap(pct, std::sync::atomic::Ordering::Relaxed) != pct {
                eprintln!("shard {}/{}: {pct} %", id.k, id.n);
            }
        };
        let r = shard::bake_shard(dir, cache, id, opts, &progress)?;
        outln!(
            "shard {}/{}: {} planes, {} patches, {} links, {:.1} s, {:.1} MB  {}",
            id.k,
            id.n,
            r.planes,
            r.patches,
            r.links,
            r.seconds,
            r.bytes as f64 / 1e6,
            r.path.display()
        );
        return Ok(());
    }
    if status {
        for s in shard::status(dir, cache, opts, None)? {
            outln!(
                "shard {}/{}  {:<8} {:.0} %",
                s.shard,
                s.shards,
                s.state,
                100.0 * s.progress
            );
        }
        return Ok(());
    }
    let t = std::time::Instant::now();
    let baked = shard::merge(dir, cache, opts, &|_, _| {})?;
    outln!(
        "merged         {} patches, {} links in {:.1} s (solve {:.1} s); cache {:.1} MB  {}",
        baked.stats.patches,
        baked
            .transfer
            .hierarchy
            .as_ref()
            .map_or(0, |h| h.stats.links),
        t.elapsed().as_secs_f64(),
        baked.stats.solve_s,
        baked.stats.cache_bytes as f64 / 1e6,
        baked
            .stats
            .cache_path
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    );
    Ok(())
}
