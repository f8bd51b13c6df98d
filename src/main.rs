//! The `relight` command line: a thin shell over the library, one file per command in
//! `src/cli/`.

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

mod cli;

use cli::{bake_cmd, bench, export, info, radiosity, render, serve, ugr_table};

#[derive(Parser)]
#[command(
    name = "relight",
    version,
    about = "Relights static 3D scenes from a precomputed radiosity transfer"
)]
struct Cli {
    /// Without a command, `relight` serves the bundled scenes on 127.0.0.1:8080.
    #[command(subcommand)]
    cmd: Option<Cmd>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Serve the scenes and the web page over HTTP (bakes in the background).
    Serve(serve::ServeArgs),
    /// Exit 0 if the server at --addr answers GET /healthz with 200 (for container
    /// health checks; needs no curl).
    Health {
        /// Server address; an unspecified IP (0.0.0.0, ::) means this host's loopback.
        #[arg(long, env = "RELIGHT_ADDR", default_value = "127.0.0.1:8080")]
        addr: std::net::SocketAddr,
    },
    /// Bake a scene's transfer (form factors, factorization, light-group columns) into the cache.
    Bake(bake_cmd::BakeArgs),
    /// Print per-surface radiosity and illuminance and the power balance for a lighting
    /// state, or with --grid the calculation grids' illuminance.
    Radiosity(radiosity::RadiosityArgs),
    /// Measure bake, cached-load and relight performance (one subprocess per case).
    Bench(bench::BenchArgs),
    /// Render an image of a scene under a lighting state (format from the extension:
    /// .png, .jpg, .exr or .pfm for linear radiance).
    Render(render::RenderArgs),
    /// Export the relit scene as glTF binary (.glb): vertex colours, and one attribute per
    /// light group so that viewers can remix the lights.
    Export(export::ExportArgs),
    /// Print a luminaire's CIE 190 standard UGR table (rooms in H, five reflectance
    /// combinations, crosswise and endwise) from its .ies or .ldt file.
    UgrTable(ugr_table::UgrTableArgs),
    /// List the scenes under a folder with their patch counts and light groups.
    Info {
        #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
        scenes: std::path::PathBuf,
    },
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("RELIGHT_LOG")
                .unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        None => serve::run(serve::ServeArgs::parse_from(["serve"])),
        Some(Cmd::Serve(a)) => serve::run(a),
        Some(Cmd::Health { addr }) => serve::health(addr),
        Some(Cmd::Bake(a)) => bake_cmd::run(a),
        Some(Cmd::Radiosity(a)) => radiosity::run(a),
        Some(Cmd::Bench(a)) => bench::run(a),
        Some(Cmd::Render(a)) => render::run(a),
        Some(Cmd::Export(a)) => export::run(a),
        Some(Cmd::Info { scenes }) => info::run(&scenes),
        Some(Cmd::UgrTable(a)) => ugr_table::run(a),
    }
}
