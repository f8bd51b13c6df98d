//! The `relight` command line: a thin shell over the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use relight::bake::{self, BakeOptions, CachePolicy, Stage};
use relight::color::luminance64;
use relight::model::lighting::LightState;
use relight::model::report::Report;

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
    Serve(ServeArgs),
    /// Exit 0 if the server at --addr answers GET /healthz with 200 (for container
    /// health checks; needs no curl).
    Health {
        /// Server address; an unspecified IP (0.0.0.0, ::) means this host's loopback.
        #[arg(long, env = "RELIGHT_ADDR", default_value = "127.0.0.1:8080")]
        addr: std::net::SocketAddr,
    },
    /// Bake a scene's transfer (form factors, factorization, light-group columns) into the cache.
    Bake {
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
    },
    /// Print per-surface radiosity and illuminance and the power balance for a lighting state.
    Radiosity {
        scene: PathBuf,
        /// Light setting: ID=INTENSITY or ID=R,G,B (repeatable). Other groups keep defaults.
        #[arg(long = "light", value_name = "ID=VALUE")]
        lights: Vec<String>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        #[arg(long, env = "RELIGHT_CACHE")]
        cache: Option<PathBuf>,
        /// Override the mesh size (longest patch edge, metres).
        #[arg(long)]
        max_edge: Option<f64>,
    },
    /// Measure bake, cached-load and relight performance (one subprocess per case).
    Bench {
        /// Run one case only: cornell, cornell-10k or groups-10k.
        #[arg(long)]
        case: Option<String>,
        #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
        scenes: PathBuf,
        /// Print the case's figures as JSON (used between the parent and its subprocesses).
        #[arg(long)]
        json: bool,
        /// Only write the 8-group benchmark room (about 10,000 patches) into this folder.
        #[arg(long, value_name = "DIR")]
        make_scene: Option<PathBuf>,
    },
    /// Render an image of a scene under a lighting state (format from the extension:
    /// .png, .jpg, .exr or .pfm for linear radiance).
    Render(RenderArgs),
    /// List the scenes under a folder with their patch counts and light groups.
    Info {
        #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
        scenes: PathBuf,
    },
}

#[derive(clap::Parser)]
#[command(
    after_help = "Every option also reads the environment variable shown in brackets \
(flags win). RELIGHT_LOG sets the log filter: error, warn, info (default), debug, or \
per module, e.g. relight=debug,tower_http=info."
)]
struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "RELIGHT_ADDR", default_value = "127.0.0.1:8080")]
    addr: std::net::SocketAddr,
    /// Folder of scene folders.
    #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
    scenes: PathBuf,
    /// Cache folder for baked transfers [default: $XDG_CACHE_HOME/relight or ~/.cache/relight].
    #[arg(long, env = "RELIGHT_CACHE")]
    cache: Option<PathBuf>,
    /// Serve only what the cache holds: never bake, never write.
    #[arg(long, env = "RELIGHT_READ_ONLY")]
    read_only: bool,
    /// Folder with the web page, served at /.
    #[arg(long, env = "RELIGHT_STATIC", default_value = "static")]
    static_dir: PathBuf,
    /// Origins allowed by CORS (repeat or comma-separate; `*` for any). Default: same origin only.
    #[arg(
        long = "cors-origin",
        env = "RELIGHT_CORS_ORIGINS",
        value_delimiter = ','
    )]
    cors_origins: Vec<String>,
    /// Largest request body in bytes.
    #[arg(long, env = "RELIGHT_BODY_LIMIT", default_value_t = relight::server::DEFAULT_BODY_LIMIT)]
    body_limit: usize,
    /// Memory budget for requests and bakes: bytes with an optional unit (4G, 512M) or a
    /// percentage of the machine's or the container's memory (50%) [default: 50%].
    #[arg(long, env = "RELIGHT_MEMORY_BUDGET", value_parser = relight::budget::parse_budget)]
    memory_budget: Option<u64>,
    /// Heavy requests (renders, batches, point gathers, solves) running at once; more
    /// wait briefly, then get 503 [default: the number of cores].
    #[arg(long, env = "RELIGHT_MAX_CONCURRENT")]
    max_concurrent: Option<usize>,
    /// Longest time for one request, seconds (503 after that).
    #[arg(long, env = "RELIGHT_REQUEST_TIMEOUT", default_value_t = 60.0)]
    request_timeout: f64,
    /// Longest time a client may take to send its request headers, seconds.
    #[arg(long, env = "RELIGHT_HEADER_TIMEOUT", default_value_t = 10.0)]
    header_timeout: f64,
    /// Most open connections.
    #[arg(long, env = "RELIGHT_MAX_CONNECTIONS", default_value_t = relight::server::DEFAULT_MAX_CONNECTIONS)]
    max_connections: usize,
    /// Bake in this process instead of a child `relight bake` process.
    #[arg(long, env = "RELIGHT_BAKE_IN_PROCESS")]
    bake_in_process: bool,
}

/// Seconds from the command line as a Duration (finite, positive, at most a day).
fn seconds(what: &str, s: f64) -> Result<std::time::Duration> {
    anyhow::ensure!(
        s.is_finite() && s > 0.0 && s <= 86_400.0,
        "--{what} {s}: give seconds in (0, 86400]"
    );
    Ok(std::time::Duration::from_secs_f64(s))
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("RELIGHT_LOG")
                .unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// GET /healthz over a plain TCP connection, with a 3 s budget.
fn health(mut addr: std::net::SocketAddr) -> Result<()> {
    use std::io::{Read, Write};
    use std::time::Duration;
    if addr.ip().is_unspecified() {
        addr.set_ip(match addr.ip() {
            std::net::IpAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
            std::net::IpAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
        });
    }
    let t = Duration::from_secs(3);
    let mut s = std::net::TcpStream::connect_timeout(&addr, t)
        .with_context(|| format!("cannot connect to {addr}"))?;
    s.set_read_timeout(Some(t))?;
    s.set_write_timeout(Some(t))?;
    s.write_all(b"GET /healthz HTTP/1.0\r\nHost: localhost\r\n\r\n")?;
    let mut head = [0u8; 64];
    let n = s.read(&mut head)?;
    let line = String::from_utf8_lossy(&head[..n]);
    let status = line.lines().next().unwrap_or("");
    anyhow::ensure!(
        status.split_whitespace().nth(1) == Some("200"),
        "{addr}/healthz answered '{status}'"
    );
    outln!("ok: {addr} healthy");
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    let cmd = match cli.cmd {
        Some(c) => c,
        None => Cmd::Serve(ServeArgs::parse_from(["serve"])),
    };
    match cmd {
        Cmd::Serve(a) => {
            let defaults = relight::server::ServerConfig::default();
            let bake_command = if a.bake_in_process {
                None
            } else {
                std::env::current_exe().ok()
            };
            let config = relight::server::ServerConfig {
                addr: a.addr,
                scenes: a.scenes,
                cache: a.cache.unwrap_or_else(bake::default_cache_dir),
                read_only: a.read_only,
                static_dir: a.static_dir,
                cors_origins: a.cors_origins,
                body_limit: a.body_limit,
                memory_budget: a.memory_budget.unwrap_or(defaults.memory_budget),
                max_concurrent: a.max_concurrent.unwrap_or(defaults.max_concurrent).max(1),
                request_timeout: seconds("request-timeout", a.request_timeout)?,
                header_timeout: seconds("header-timeout", a.header_timeout)?,
                max_connections: a.max_connections.max(1),
                bake_command,
                ..defaults
            };
            let rt = tokio::runtime::Runtime::new()?;
            rt.block_on(relight::server::serve(config))
        }
        Cmd::Bake {
            scene,
            all,
            scenes,
            cache,
            force,
            memory_budget,
            progress_json,
        } => {
            let cache = cache.unwrap_or_else(bake::default_cache_dir);
            let budget = memory_budget.unwrap_or_else(relight::budget::default_budget);
            if progress_json {
                // The server's child: the kernel's OOM killer should pick this process
                // before the server.
                let _ = std::fs::write("/proc/self/oom_score_adj", "1000");
                let Some(dir) = scene else {
                    anyhow::bail!("--progress-json bakes one scene folder");
                };
                return match bake_child(&dir, &cache, budget) {
                    Ok(()) => Ok(()),
                    Err(e) => {
                        outln!("{}", serde_json::json!({ "error": format!("{e:#}") }));
                        std::process::exit(2);
                    }
                };
            }
            let dirs = match (scene, all) {
                (Some(s), false) => vec![s],
                (None, true) => bake::scene_dirs(&scenes)
                    .with_context(|| format!("reading {}", scenes.display()))?,
                _ => anyhow::bail!("give a scene folder or --all"),
            };
            let mut failed = 0;
            for d in dirs {
                if let Err(e) = bake_one(&d, &cache, force, budget) {
                    eprintln!("error: {e:#}");
                    failed += 1;
                }
            }
            if failed > 0 {
                anyhow::bail!("{failed} scene(s) failed");
            }
            Ok(())
        }
        Cmd::Radiosity {
            scene,
            lights,
            json,
            cache,
            max_edge,
        } => radiosity(&scene, &lights, json, cache, max_edge),
        Cmd::Info { scenes } => info(&scenes),
        Cmd::Health { addr } => health(addr),
        Cmd::Render(a) => render(a),
        Cmd::Bench {
            make_scene: Some(dir),
            ..
        } => {
            relight::bench::write_group_room(&dir, 8, BENCH_ROOM_TARGET)?;
            outln!("wrote {}", dir.display());
            Ok(())
        }
        Cmd::Bench {
            case, scenes, json, ..
        } => bench(case, &scenes, json),
    }
}

fn progress_bar(label: &str) -> ProgressBar {
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% {msg} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}

/// `relight bake DIR --progress-json`: bakes into the cache, reporting progress as JSON
/// lines (`{"progress": 0.42}`) for the server that started this process.
fn bake_child(dir: &Path, cache: &Path, budget: u64) -> Result<()> {
    let opts = BakeOptions {
        memory_budget: Some(budget),
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

fn bake_one(dir: &Path, cache: &Path, force: bool, budget: u64) -> Result<()> {
    let label = dir
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let pb = progress_bar(&label);
    let policy = if force {
        CachePolicy::Off
    } else {
        CachePolicy::ReadWrite(cache)
    };
    let progress = |stage: Stage, f: f64| {
        pb.set_message(format!("{stage:?}"));
        pb.set_position((stage.overall(f) * 1000.0) as u64);
    };
    let opts = BakeOptions {
        memory_budget: Some(budget),
        ..Default::default()
    };
    let mut baked = bake::load_or_bake(dir, policy, &opts, &progress)?;
    if force {
        // Baked without reading the cache: write the fresh entry now.
        let settings = bake::settings_json(
            &baked.scene,
            &BakeOptions::default(),
            baked.scene.mesh.max_edge,
        );
        let key = relight::bake::cache::cache_key(&baked.scene.files, &settings)?;
        let path = relight::bake::cache::entry_path(cache, &baked.scene.id, &key);
        baked.stats.cache_bytes = relight::bake::cache::write(
            &path,
            &baked.scene.id,
            &key,
            &settings,
            baked.mesh.fingerprint(),
            &baked.transfer,
        )?;
        relight::bake::cache::prune(cache, &baked.scene.id, &path);
        baked.stats.cache_path = Some(path);
    }
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

fn radiosity(
    dir: &Path,
    lights: &[String],
    json: bool,
    cache: Option<PathBuf>,
    max_edge: Option<f64>,
) -> Result<()> {
    let cache = cache.unwrap_or_else(bake::default_cache_dir);
    let opts = BakeOptions {
        max_edge,
        ..Default::default()
    };
    let pb = progress_bar("baking");
    let progress = |stage: Stage, f: f64| pb.set_position((stage.overall(f) * 1000.0) as u64);
    let baked = bake::load_or_bake(dir, CachePolicy::ReadWrite(&cache), &opts, &progress)?;
    pb.finish_and_clear();
    let mut state = LightState::default();
    for l in lights {
        state.parse_arg(l).map_err(anyhow::Error::msg)?;
    }
    let weights = state.weights(&baked.scene)?;
    let sol = baked.transfer.relight(&weights);
    let report = Report::new(&baked.scene, &baked.mesh, &baked.transfer, &sol);
    if json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    outln!(
        "{} — {} patches; radiosity B in lm/m², illuminance E in lux (area-weighted means)",
        baked.scene.name,
        baked.stats.patches
    );
    outln!(
        "{:<20} {:>9}  {:>28} {:>9}  {:>28} {:>9}",
        "surface",
        "area m²",
        "B (R G B)",
        "B lum",
        "E (R G B)",
        "E lux"
    );
    for (name, s) in &report.surfaces {
        let rgb = |v: [f64; 3]| format!("{:>9.4} {:>9.4} {:>9.4}", v[0], v[1], v[2]);
        outln!(
            "{:<20} {:>9.4}  {} {:>9.4}  {} {:>9.4}",
            name,
            s.area,
            rgb(s.radiosity),
            s.radiosity_y(),
            rgb(s.illuminance),
            s.illuminance_y()
        );
    }
    let p = &report.power;
    outln!();
    outln!(
        "power (lm)   emitted {:.4}   absorbed {:.4}   escaped {:.4}   imbalance {:+.2e}",
        p.emitted_lm,
        p.absorbed_lm,
        p.escaped_lm,
        p.imbalance
    );
    outln!(
        "  per channel emitted {:.4}/{:.4}/{:.4}  absorbed {:.4}/{:.4}/{:.4}  escaped {:.4}/{:.4}/{:.4}",
        p.emitted[0], p.emitted[1], p.emitted[2], p.absorbed[0], p.absorbed[1], p.absorbed[2],
        p.escaped[0], p.escaped[1], p.escaped[2]
    );
    let _ = luminance64;
    Ok(())
}

fn info(root: &Path) -> Result<()> {
    let dirs = bake::scene_dirs(root).with_context(|| format!("reading {}", root.display()))?;
    if dirs.is_empty() {
        outln!("no scenes under {}", root.display());
    }
    for d in dirs {
        match relight::scene::Scene::load(&d) {
            Ok(s) => {
                let patches = match relight::geometry::mesh::Mesh::try_build_with(
                    &s,
                    s.mesh.max_edge,
                    bake::DEFAULT_MAX_PATCHES,
                ) {
                    Ok(mesh) => mesh.len().to_string(),
                    Err(e) => format!(">{}", e.at_least.max(e.limit as u64)),
                };
                let groups: Vec<String> = s.lights.iter().map(|l| l.id.clone()).collect();
                let cams: Vec<String> = s.cameras.iter().map(|c| c.id.clone()).collect();
                outln!(
                    "{:<16} {:<28} {:>6} patches  surfaces {:<3} lights [{}]  cameras [{}]",
                    s.id,
                    s.name,
                    patches,
                    s.surfaces.len(),
                    groups.join(", "),
                    cams.join(", ")
                );
            }
            Err(e) => outln!(
                "{:<16} FAILED: {e}",
                d.file_name().unwrap_or_default().to_string_lossy()
            ),
        }
    }
    Ok(())
}

/// `target_patches` that gives the 8-group room just over 10,000 patches.
const BENCH_ROOM_TARGET: usize = 8_200;

const BENCH_CASES: [&str; 3] = ["cornell", "cornell-10k", "groups-10k"];

fn bench(case: Option<String>, scenes: &Path, json: bool) -> Result<()> {
    let Some(case) = case else {
        outln!(
            "{:<12} {:>7} {:>3} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>10} {:>10} {:>9}",
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
            "peak MB"
        );
        for c in BENCH_CASES {
            let out = std::process::Command::new(std::env::current_exe()?)
                .args(["bench", "--json", "--case", c, "--scenes"])
                .arg(scenes)
                .output()?;
            anyhow::ensure!(
                out.status.success(),
                "case {c} failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            let r: serde_json::Value = serde_json::from_slice(&out.stdout)?;
            let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
            outln!(
                "{:<12} {:>7} {:>3} {:>9} {:>8.2} {:>8.2} {:>9.2} {:>9.3} {:>9.1} {:>10.1} {:>10} {:>9.0}",
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
            );
        }
        return Ok(());
    };
    let tmp = tempfile::tempdir()?;
    let (dir, opts) = match case.as_str() {
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
            relight::bench::write_group_room(tmp.path(), 8, BENCH_ROOM_TARGET)?;
            (tmp.path().to_path_buf(), BakeOptions::default())
        }
        other => anyhow::bail!(
            "unknown case '{other}': use one of {}",
            BENCH_CASES.join(", ")
        ),
    };
    let r = relight::bench::run_case(&case, &dir, &opts)?;
    if json {
        outln!("{}", serde_json::to_string(&r)?);
    } else {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    }
    Ok(())
}

#[derive(clap::Args)]
struct RenderArgs {
    scene: PathBuf,
    /// Camera preset id from scene.toml (default: the first).
    #[arg(long)]
    camera: Option<String>,
    /// Light setting: ID=INTENSITY or ID=R,G,B (repeatable).
    #[arg(long = "light", value_name = "ID=VALUE")]
    lights: Vec<String>,
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Exposure in stops (the image is scaled by 2^exposure before tone mapping);
    /// default: auto (log-average luminance to middle grey).
    #[arg(long)]
    exposure: Option<f32>,
    /// Tone mapping: clamp or filmic.
    #[arg(long, default_value = "filmic")]
    tonemap: String,
    /// Show illuminance (lux) in false colour instead of the shaded image.
    #[arg(long)]
    falsecolor: bool,
    #[arg(long, env = "RELIGHT_CACHE")]
    cache: Option<PathBuf>,
}

fn render(a: RenderArgs) -> Result<()> {
    use relight::render::{self, Camera, Format, Shading, ToneMap, ViewBuffer};
    let cache = a.cache.unwrap_or_else(bake::default_cache_dir);
    let pb = progress_bar("baking");
    let progress = |stage: Stage, f: f64| pb.set_position((stage.overall(f) * 1000.0) as u64);
    let baked = bake::load_or_bake(
        &a.scene,
        CachePolicy::ReadWrite(&cache),
        &BakeOptions::default(),
        &progress,
    )?;
    pb.finish_and_clear();
    let scene = &baked.scene;
    let def = match &a.camera {
        Some(id) => scene
            .cameras
            .iter()
            .find(|c| &c.id == id)
            .with_context(|| {
                let ids: Vec<&str> = scene.cameras.iter().map(|c| c.id.as_str()).collect();
                format!("unknown camera '{id}' (known: {})", ids.join(", "))
            })?,
        None => scene
            .cameras
            .first()
            .context("the scene defines no camera; add [[cameras]] to scene.toml")?,
    };
    let cam = Camera::from_def(def, a.width, a.height);
    cam.validate().map_err(anyhow::Error::msg)?;
    let tm = match a.tonemap.as_str() {
        "clamp" => ToneMap::Clamp,
        "filmic" => ToneMap::Filmic,
        other => anyhow::bail!("tonemap '{other}': use clamp or filmic"),
    };
    let mut state = LightState::default();
    for l in &a.lights {
        state.parse_arg(l).map_err(anyhow::Error::msg)?;
    }
    let sol = baked.transfer.relight(&state.weights(scene)?);
    let shading = Shading::new(&baked.mesh);
    let t0 = std::time::Instant::now();
    let view = ViewBuffer::build(&baked.mesh, &shading, &cam);
    let t_view = t0.elapsed();
    let ext = a
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let t1 = std::time::Instant::now();
    let bytes = if a.falsecolor {
        let img = view.gather(&shading.vertex_values(&sol.h), 1.0);
        let max = img
            .iter()
            .map(|p| relight::color::luminance(*p))
            .fold(0.0, f32::max);
        let rgb = render::false_color(&img, a.width, a.height, max / 100.0, max);
        eprintln!(
            "false colour: log scale {:.3} to {:.3} lux",
            max / 100.0,
            max
        );
        render::encode_8bit(
            &rgb,
            a.width,
            a.height,
            if ext == "jpg" || ext == "jpeg" {
                Format::Jpeg
            } else {
                Format::Png
            },
        )
        .map_err(anyhow::Error::msg)?
    } else {
        let img = view.gather(&shading.vertex_values(&sol.b), std::f32::consts::FRAC_1_PI);
        let ev = a.exposure.unwrap_or_else(|| render::auto_exposure(&img));
        match ext.as_str() {
            "png" => render::encode_8bit(
                &render::tonemap(&img, ev, tm),
                a.width,
                a.height,
                Format::Png,
            ),
            "jpg" | "jpeg" => render::encode_8bit(
                &render::tonemap(&img, ev, tm),
                a.width,
                a.height,
                Format::Jpeg,
            ),
            "exr" => render::encode_exr(&img, a.width, a.height),
            "pfm" => Ok(render::encode_pfm(&img, a.width, a.height)),
            other => Err(format!(
                "output extension '.{other}': use .png, .jpg, .exr or .pfm"
            )),
        }
        .map_err(anyhow::Error::msg)?
    };
    let t_img = t1.elapsed();
    std::fs::write(&a.output, &bytes).with_context(|| format!("writing {}", a.output.display()))?;
    outln!(
        "{} {}×{}: view buffer {:.1} ms, relit image {:.1} ms, {} bytes",
        a.output.display(),
        a.width,
        a.height,
        t_view.as_secs_f64() * 1e3,
        t_img.as_secs_f64() * 1e3,
        bytes.len()
    );
    Ok(())
}
