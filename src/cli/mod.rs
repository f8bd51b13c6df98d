//! The commands of the `relight` binary, one file each. Every command is a thin call into
//! the library: [`relight::bake`] to get a scene ready, [`relight::model`] to answer, and
//! [`relight::render::pipeline`] to draw.

use std::path::{Path, PathBuf};

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};

use relight::bake::{self, BakeOptions, CachePolicy, Stage};
use relight::model::Model;

pub mod bake_cmd;
pub mod bench;
pub mod export;
pub mod info;
pub mod radiosity;
pub mod render;
pub mod serve;
pub mod ugr_table;

/// `println!` that ends the program quietly when stdout is a closed pipe
/// (`relight radiosity … --json | head`), as command-line tools do.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($t)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            eprintln!("error: cannot write to stdout: {e}");
            std::process::exit(1);
        }
    }};
}
pub(crate) use outln;

/// A progress bar on stderr, 0..1000.
pub fn progress_bar(label: &str) -> ProgressBar {
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% {msg} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}

/// Where a query command gets its scene ready: the cache folder and the transfer mode.
#[derive(clap::Args)]
pub struct ModelArgs {
    #[arg(long, env = "RELIGHT_CACHE")]
    cache: Option<PathBuf>,
    /// Transfer mode, overriding scene.toml: auto, factored, columns or hierarchical.
    #[arg(long, value_parser = parse_transfer)]
    transfer: Option<relight::scene::TransferChoice>,
}

impl ModelArgs {
    /// Loads `dir` ([`load_model`]) in the transfer mode asked for, meshed with patches of
    /// at most `max_edge` metres when it is given.
    pub fn load(&self, dir: &Path, max_edge: Option<f64>) -> Result<Model> {
        let opts = BakeOptions {
            max_edge,
            choice: self.transfer,
            ..Default::default()
        };
        load_model(dir, self.cache.clone(), &opts)
    }
}

/// Loads `dir` from the cache (or bakes it into the cache) with a progress bar, as a
/// [`Model`] ready for queries.
pub fn load_model(dir: &Path, cache: Option<PathBuf>, opts: &BakeOptions) -> Result<Model> {
    let cache = cache.unwrap_or_else(bake::default_cache_dir);
    let pb = progress_bar("baking");
    let progress = |stage: Stage, f: f64| pb.set_position((stage.overall(f) * 1000.0) as u64);
    let baked = bake::load_or_bake(dir, CachePolicy::ReadWrite(&cache), opts, &progress)?;
    pb.finish_and_clear();
    for w in &baked.scene.warnings {
        eprintln!("warning: {}: {w}", baked.scene.id);
    }
    Ok(Model::new(baked))
}

/// `--transfer auto|factored|columns|hierarchical`: overrides scene.toml's `transfer`.
pub fn parse_transfer(s: &str) -> Result<relight::scene::TransferChoice, String> {
    serde_json::from_value(serde_json::Value::String(s.to_ascii_lowercase()))
        .map_err(|_| format!("unknown transfer '{s}': use auto, factored, columns or hierarchical"))
}
