//! `relight radiosity`: per-surface radiosity (lm/m²) and illuminance (lux) with the power
//! balance (lm) for a lighting state; with `--grid`, the calculation grids' statistics
//! and point values (lux), the same answer as `POST /api/scenes/{id}/illuminance`.

use std::path::PathBuf;

use anyhow::Result;

use super::{outln, ModelArgs};
use relight::model::query::{GridAnswer, IlluminanceQuery};
use relight::model::report::Report;
use relight::model::{Cancel, LightState, Lighting, Model};

#[derive(clap::Args)]
pub struct RadiosityArgs {
    scene: PathBuf,
    /// Light setting: ID=INTENSITY (the group keeps its colour) or ID=R,G,B (intensity 1,
    /// this colour); repeatable. Other groups keep their defaults.
    #[arg(long = "light", value_name = "ID=VALUE")]
    lights: Vec<String>,
    /// Answer these calculation grids (repeatable): statistics and point values in lux.
    #[arg(long = "grid", value_name = "ID")]
    grids: Vec<String>,
    /// Print JSON instead of a table (with --grid: the HTTP /illuminance answer).
    #[arg(long)]
    json: bool,
    /// Override the mesh size (longest patch edge, metres).
    #[arg(long)]
    max_edge: Option<f64>,
    #[command(flatten)]
    model: ModelArgs,
}

pub fn run(a: RadiosityArgs) -> Result<()> {
    let model = a.model.load(&a.scene, a.max_edge)?;
    let state = LightState::parse_args(&model.baked.scene, &a.lights)?;
    let lighting = Lighting::Groups(model.weights(&state)?);
    if !a.grids.is_empty() {
        return grids(&model, &lighting, &a.grids, a.json);
    }
    let sol = model.solve(&lighting)?;
    let b = &model.baked;
    let report = Report::new(&b.scene, &b.mesh, &b.transfer, &sol);
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print_report(&model, &report);
    Ok(())
}

fn grids(model: &Model, lighting: &Lighting, ids: &[String], json: bool) -> Result<()> {
    let mut q = IlluminanceQuery::default();
    for id in ids {
        let g = model.grid_index(id)?;
        anyhow::ensure!(!q.grids.contains(&g), "grid '{id}' is given twice");
        q.grids.push(g);
    }
    let answer = model.illuminance(lighting, &q, &Cancel::default())?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&answer)?);
        return Ok(());
    }
    for id in ids {
        if let Some(g) = answer.grids.get(id) {
            print_grid(id, g);
        }
    }
    if let Some(p) = answer.power {
        let watts = p
            .luminaire_watts
            .map_or("unknown".into(), |w| format!("{w:.1} W"));
        outln!("luminaires    {:.1} lm, {watts}", p.luminaire_lumens);
    }
    Ok(())
}

fn print_grid(id: &str, g: &GridAnswer) {
    let left = if g.excluded > 0 {
        format!(" ({} inside objects left out, shown as -)", g.excluded)
    } else {
        String::new()
    };
    outln!(
        "grid {id} ({}), {} points{left}, illuminance in lux",
        g.name,
        g.count
    );
    outln!(
        "  Eavg {:.2}  Emin {:.2}  Emax {:.2}  U0 {}  Emin/Emax {}",
        g.avg,
        g.min,
        g.max,
        ratio(g.u0),
        ratio(g.min_max)
    );
    if let Some(note) = g.note {
        outln!("  ({note})");
    }
    let cols = g.layout.map_or(10, |[c, _]| c.max(1));
    for row in g.values.chunks(cols) {
        let cells: Vec<String> = row
            .iter()
            .map(|v| v.map_or_else(|| format!("{:>8}", "-"), |v| format!("{v:8.1}")))
            .collect();
        outln!("  {}", cells.join(""));
    }
}

fn print_report(model: &Model, report: &Report) {
    outln!(
        "{} — {} patches; radiosity B in lm/m², illuminance E in lux (area-weighted means)",
        model.baked.scene.name,
        model.patches()
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
        let rgb = |v: relight::color::Rgb64| format!("{:>9.4} {:>9.4} {:>9.4}", v[0], v[1], v[2]);
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
}

/// A uniformity ratio to three decimals, or "n/a" for an unlit grid's.
fn ratio(x: Option<f64>) -> String {
    x.map_or_else(|| "n/a".to_string(), |x| format!("{x:.3}"))
}
