//! `relight render`: an image of a scene under a lighting state, through the same
//! pipeline as the server ([`relight::render::pipeline`]). The format follows the output's
//! extension: .png or .jpg (tone-mapped), .exr or .pfm (linear radiance).

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::{outln, ModelArgs};
use relight::model::sky_state::SkySpec;
use relight::model::{LightState, Lighting};
use relight::render::pipeline::{render_once, Quality, RenderOptions};
use relight::render::{Camera, Format, Shading, ToneMap};

#[derive(clap::Args)]
pub struct RenderArgs {
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
    #[arg(long, allow_hyphen_values = true)]
    exposure: Option<f32>,
    /// Tone mapping: clamp or filmic.
    #[arg(long, default_value = "filmic")]
    tonemap: String,
    /// Show illuminance (lux) in false colour instead of the shaded image.
    #[arg(long)]
    falsecolor: bool,
    /// fast (the solved patches, blended) or final (direct light traced per pixel, a
    /// final gather, the luminaires in view and glossy glTF materials; seconds per
    /// image).
    #[arg(long, default_value = "fast")]
    quality: String,
    /// Daylight from this sky added (a scene with a [site]), in the grammar of the HTTP
    /// API's `sky`, as JSON: '{"type": "cie_overcast", "horizontal_illuminance": 10000}'.
    #[arg(long, value_name = "JSON", value_parser = parse_sky)]
    sky: Option<SkySpec>,
    #[command(flatten)]
    model: ModelArgs,
}

pub fn run(a: RenderArgs) -> Result<()> {
    let model = a.model.load(&a.scene, None)?;
    let scene = &model.baked.scene;
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
    let camera = Camera::from_def(def, a.width, a.height);
    camera.validate().map_err(anyhow::Error::msg)?;
    let quality = match a.quality.as_str() {
        "fast" => Quality::Fast,
        "final" => Quality::Final,
        other => anyhow::bail!("quality '{other}': use fast or final"),
    };
    let o = RenderOptions {
        camera,
        quality,
        exposure: a.exposure,
        format: format_of(&a.output, a.falsecolor)?,
        falsecolor: a.falsecolor,
        tonemap: match a.tonemap.as_str() {
            "clamp" => ToneMap::Clamp,
            "filmic" => ToneMap::Filmic,
            other => anyhow::bail!("tonemap '{other}': use clamp or filmic"),
        },
        range: None,
    };
    let state = LightState::parse_args(scene, &a.lights)?;
    let lighting = Lighting::Groups(model.weights(&state)?);
    let shading = Shading::new(&model.baked.mesh);
    let t0 = std::time::Instant::now();
    let settings = relight::render::final_gather::FinalSettings::from_env();
    let sky = match &a.sky {
        Some(spec) => Some(spec.resolve(model.site()?)?),
        None => None,
    };
    let image = render_once(&model, &shading, &lighting, sky.as_ref(), &o, &settings)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if let Some((lo, hi)) = image.range {
        eprintln!("false colour: log scale {lo:.3} to {hi:.3} lux");
    }
    std::fs::write(&a.output, &image.bytes)
        .with_context(|| format!("writing {}", a.output.display()))?;
    outln!(
        "{} {}×{}: rendered in {ms:.1} ms, {} bytes",
        a.output.display(),
        a.width,
        a.height,
        image.bytes.len()
    );
    Ok(())
}

/// `--sky`: a sky in the JSON grammar of the HTTP API ([`SkySpec`]).
fn parse_sky(s: &str) -> Result<SkySpec, String> {
    serde_json::from_str(s).map_err(|e| {
        format!("{e} (e.g. '{{\"type\": \"cie_overcast\", \"horizontal_illuminance\": 10000}}')")
    })
}

/// The format of an output file name's extension.
fn format_of(path: &std::path::Path, falsecolor: bool) -> Result<Format> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let format = match ext.as_str() {
        "png" => Format::Png,
        "jpg" | "jpeg" => Format::Jpeg,
        "exr" => Format::Exr,
        "pfm" => Format::Pfm,
        other => anyhow::bail!("output extension '.{other}': use .png, .jpg, .exr or .pfm"),
    };
    anyhow::ensure!(
        !(falsecolor && matches!(format, Format::Exr | Format::Pfm)),
        "false colour is an 8-bit image: use .png or .jpg"
    );
    Ok(format)
}
