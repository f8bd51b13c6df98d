//! `relight bench`: bake, cached-load and relight figures, one subprocess per case so
//! that each case's peak memory is its own.

use std::path::{Path, PathBuf};

use anyhow::Result;

use super::outln;
use relight::bake::BakeOptions;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Run one case only: cornell, cornell-10k or groups-10k.
    #[arg(long)]
    case: Option<String>,
    #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
    scenes: PathBuf,
    /// Print the case's figures as JSON (used between the parent and its subprocesses).
    #[arg(long)]
    json: bool,
    /// Only write the 8-group benchmark room (about 10,000 patches, or --patches) into
    /// this folder.
    #[arg(long, value_name = "DIR")]
    make_scene: Option<PathBuf>,
    /// With --make-scene: the room's target patch count (at most 1,000,000).
    #[arg(long, value_name = "N")]
    patches: Option<usize>,
    /// Bench this scene folder as one case (e.g. scenes/office-floor).
    #[arg(long, value_name = "DIR")]
    scene: Option<PathBuf>,
    /// Transfer mode of every case, overriding scene.toml and the cases' defaults: auto,
    /// factored, columns or hierarchical.
    #[arg(long, value_parser = super::parse_transfer)]
    transfer: Option<relight::scene::TransferChoice>,
}

pub fn run(a: BenchArgs) -> Result<()> {
    if let Some(dir) = a.make_scene {
        let target = a.patches.unwrap_or(BENCH_ROOM_TARGET);
        anyhow::ensure!(
            (1..=1_000_000).contains(&target),
            "--patches {target}: give 1 to 1,000,000"
        );
        relight::bench::write_group_room(&dir, 8, target)?;
        outln!("wrote {}", dir.display());
        return Ok(());
    }
    if let Some(dir) = a.scene {
        let opts = BakeOptions {
            choice: a.transfer,
            ..Default::default()
        };
        let label = dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let r = relight::bench::run_case(&label, &dir, &opts)?;
        outln!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    bench(a.case, &a.scenes, a.json, a.transfer)
}

/// `target_patches` that gives the 8-group room just over 10,000 patches.
const BENCH_ROOM_TARGET: usize = 8_200;

const BENCH_CASES: [&str; 3] = ["cornell", "cornell-10k", "groups-10k"];

fn bench(
    case: Option<String>,
    scenes: &Path,
    json: bool,
    transfer: Option<relight::scene::TransferChoice>,
) -> Result<()> {
    let Some(case) = case else {
        return bench_table(scenes, transfer);
    };
    let tmp = tempfile::tempdir()?;
    let (dir, opts) = case_scene(&case, scenes, tmp.path())?;
    let opts = match transfer {
        Some(t) => BakeOptions {
            mode: None,
            choice: Some(t),
            ..opts
        },
        None => opts,
    };
    let r = relight::bench::run_case(&case, &dir, &opts)?;
    if json {
        outln!("{}", serde_json::to_string(&r)?);
    } else {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    }
    Ok(())
}

/// Every case, each in its own process (so that peak memory is the case's own), as a
/// table.
fn bench_table(scenes: &Path, transfer: Option<relight::scene::TransferChoice>) -> Result<()> {
    outln!(
        "{:<12} {:>7} {:>3} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>10} {:>10} {:>9} {:>8}",
        "case",
        "patches",
        "grp",
        "mode",
        "ff s",
        "solve s",
        "cold s",
        "cached s",
        "cache MB",
        "relight µs",
        "solve E ms",
        "peak MB",
        "Mrays/s"
    );
    for c in BENCH_CASES {
        let mut cmd = std::process::Command::new(std::env::current_exe()?);
        cmd.args(["bench", "--json", "--case", c, "--scenes"])
            .arg(scenes);
        if let Some(t) = transfer {
            cmd.args(["--transfer", t.name()]);
        }
        let out = cmd.output()?;
        anyhow::ensure!(
            out.status.success(),
            "case {c} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let r: serde_json::Value = serde_json::from_slice(&out.stdout)?;
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        outln!(
            "{:<12} {:>7} {:>3} {:>9} {:>8.2} {:>8.2} {:>9.2} {:>9.3} {:>9.1} {:>10.1} {:>10} {:>9.0} {:>8.2}",
            c,
            r["patches"],
            r["groups"],
            r["mode"].as_str().unwrap_or(""),
            f("form_factor_s"),
            f("solve_s"),
            f("cold_bake_s"),
            f("cached_load_s"),
            f("cache_mb"),
            f("relight_us"),
            r["solve_emission_ms"]
                .as_f64()
                .map_or("-".to_string(), |v| format!("{v:.1}")),
            f("peak_rss_mb"),
            f("mrays_per_core"),
        );
    }
    Ok(())
}

/// The scene folder and bake options of bench case `case`; `tmp` holds a generated scene.
fn case_scene(case: &str, scenes: &Path, tmp: &Path) -> Result<(std::path::PathBuf, BakeOptions)> {
    Ok(match case {
        "cornell" => (scenes.join("cornell-box"), BakeOptions::default()),
        "cornell-10k" => (
            scenes.join("cornell-box"),
            BakeOptions {
                max_edge: Some(0.033),
                // Factored at 10k patches, to measure the LU at that size.
                mode: Some(relight::transport::transfer::TransferMode::Factored),
                ..Default::default()
            },
        ),
        "groups-10k" => {
            relight::bench::write_group_room(tmp, 8, BENCH_ROOM_TARGET)?;
            (tmp.to_path_buf(), BakeOptions::default())
        }
        other => anyhow::bail!(
            "unknown case '{other}': use one of {}",
            BENCH_CASES.join(", ")
        ),
    })
}
