//! `relight export`: the relit scene as a glTF binary (`.glb`), as the server's
//! `GET /api/scenes/{id}/export.glb` writes it ([`relight::render::export`]).

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::{outln, ModelArgs};
use relight::model::{LightState, Lighting};
use relight::render::{export_glb, ExportOptions, Shading, ToneMap};

#[derive(clap::Args)]
pub struct ExportArgs {
    scene: PathBuf,
    /// Light setting: ID=INTENSITY or ID=R,G,B (repeatable).
    #[arg(long = "light", value_name = "ID=VALUE")]
    lights: Vec<String>,
    /// Output file (.glb).
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure in stops (radiance is scaled by 2^exposure before tone mapping);
    /// default: auto (log-average vertex luminance to middle grey).
    #[arg(long, allow_hyphen_values = true)]
    exposure: Option<f32>,
    /// Tone mapping of the vertex colours: clamp or filmic.
    #[arg(long, default_value = "filmic")]
    tonemap: String,
    /// Leave out the per-group `_LIGHT_<GROUP>` attributes (a smaller file that cannot be
    /// relit by a client).
    #[arg(long)]
    no_groups: bool,
    #[command(flatten)]
    model: ModelArgs,
}

pub fn run(a: ExportArgs) -> Result<()> {
    let ext = a
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase());
    anyhow::ensure!(
        ext.as_deref() == Some("glb"),
        "output {}: the export is glTF binary, name it .glb",
        a.output.display()
    );
    if let Some(e) = a.exposure {
        anyhow::ensure!(
            e.is_finite() && e.abs() <= 40.0,
            "exposure {e}: use −40 … 40 stops"
        );
    }
    let model = a.model.load(&a.scene, None)?;
    let o = ExportOptions {
        exposure: a.exposure,
        tonemap: match a.tonemap.as_str() {
            "clamp" => ToneMap::Clamp,
            "filmic" => ToneMap::Filmic,
            other => anyhow::bail!("tonemap '{other}': use clamp or filmic"),
        },
        relightable: !a.no_groups,
    };
    let state = LightState::parse_args(&model.baked.scene, &a.lights)?;
    let weights = model.weights(&state)?;
    let t0 = std::time::Instant::now();
    let shading = Shading::new(&model.baked.mesh);
    let out = export_glb(&model, &shading, &Lighting::Groups(weights), &o)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    std::fs::write(&a.output, &out.bytes)
        .with_context(|| format!("writing {}", a.output.display()))?;
    outln!(
        "{}: {} shading vertices, {} triangles, {} light groups, exposure {:.2} stops; \
         exported in {ms:.1} ms, {} bytes",
        a.output.display(),
        shading.len(),
        model.baked.mesh.len(),
        if o.relightable { model.groups.len() } else { 0 },
        out.exposure,
        out.bytes.len()
    );
    Ok(())
}
