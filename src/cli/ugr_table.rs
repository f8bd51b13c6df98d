//! `relight ugr-table FILE`: the CIE 190:2010 standard UGR table of a luminaire from its
//! IES LM-63 or EULUMDAT file ([`relight::photometry::ugr_table`]), as text laid out as
//! catalogues print it, JSON or CSV.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use super::outln;
use relight::photometry::ugr_table::{ugr_table, UgrTable, UgrTableOptions, REFLECTANCES};
use relight::photometry::{parse_ies, parse_ldt, CandelaTable};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Text,
    Json,
    Csv,
}

#[derive(clap::Args)]
pub struct UgrTableArgs {
    /// Photometric file: .ies (IES LM-63) or .ldt (EULUMDAT, first lamp set).
    file: PathBuf,
    /// Total lamp flux the table refers to, lm (default: the file's rated lamp flux;
    /// for absolute photometry, the luminaire's flux). Every cell moves by
    /// 8·log10(LM / rated).
    #[arg(long, value_name = "LM")]
    lumens: Option<f64>,
    /// Luminaire spacing in multiples of H: 1 by CIE 190:2010; 0.25 for the older
    /// CIE 117 catalogue convention.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    spacing: f64,
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
}

/// Reads an .ies or .ldt file (by its extension, either case).
fn read_photometry(path: &Path) -> Result<CandelaTable> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext != "ies" && ext != "ldt" {
        bail!(
            "{}: expected an IES LM-63 (.ies) or EULUMDAT (.ldt) file",
            path.display()
        );
    }
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    // Photometric files are ASCII; tolerate Latin-1 text in their free-form fields.
    let text = String::from_utf8_lossy(&bytes);
    let shown = path.display().to_string();
    Ok(if ext == "ldt" {
        parse_ldt(&shown, &text, None)?
    } else {
        parse_ies(&shown, &text)?
    })
}

pub fn run(a: UgrTableArgs) -> Result<()> {
    let table = read_photometry(&a.file)?;
    let t = ugr_table(
        &table,
        UgrTableOptions {
            spacing: a.spacing,
            lamp_lumens: a.lumens,
        },
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    match a.format {
        Format::Json => {
            let mut v = serde_json::to_value(&t)?;
            v["file"] = a.file.display().to_string().into();
            v["standard"] = "CIE 190:2010".into();
            v["h_m"] = relight::photometry::ugr_table::H_M.into();
            outln!("{}", serde_json::to_string_pretty(&v)?);
        }
        Format::Csv => print_csv(&t),
        Format::Text => print_text(&a.file, &t),
    }
    Ok(())
}

fn cell(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |v| format!("{v:.1}"))
}

fn print_csv(t: &UgrTable) {
    let names: Vec<String> = REFLECTANCES
        .iter()
        .map(|r| {
            format!(
                "{:.0}/{:.0}/{:.0}",
                r.ceiling * 100.0,
                r.walls * 100.0,
                r.floor * 100.0
            )
        })
        .collect();
    let mut head = vec!["x_h".to_string(), "y_h".to_string()];
    head.extend(names.iter().map(|n| format!("crosswise {n}")));
    head.extend(names.iter().map(|n| format!("endwise {n}")));
    outln!("{}", head.join(","));
    for r in &t.rooms {
        let mut row = vec![format!("{}", r.x), format!("{}", r.y)];
        row.extend(
            r.crosswise
                .iter()
                .chain(&r.endwise)
                .map(|v| v.map_or_else(String::new, |v| format!("{v:.2}"))),
        );
        outln!("{}", row.join(","));
    }
}

fn print_text(file: &Path, t: &UgrTable) {
    outln!(
        "UGR table (CIE 190:2010 standard conditions): {}",
        file.display()
    );
    outln!(
        "Luminaire flux {:.0} lm ({:.0} lm down, {:.0} lm up) for {:.0} lm of lamp flux; the values are for this flux.",
        t.luminaire_lumens,
        t.downward_lumens,
        t.upward_lumens,
        t.lamp_lumens
    );
    outln!(
        "Correction summand 8·log10({:.0} lm / 1000 lm) = {:.1}: subtract it for the table referred to 1000 lm of lamp flux.",
        t.lamp_lumens,
        t.correction_summand
    );
    outln!(
        "Spacing S = {} H; H = height of the luminaires above the eye; observer at the middle of wall X, looking along Y.",
        t.spacing
    );
    outln!("Crosswise: line of sight in the C0-C180 plane; endwise: in the C90-C270 plane.");
    outln!();
    let refl = |f: fn(&relight::photometry::ugr_table::Reflectances) -> f64| {
        let v: Vec<String> = REFLECTANCES
            .iter()
            .map(|r| format!("{:>5.2}", f(r)))
            .collect();
        let v = v.join(" ");
        format!("{v} | {v}")
    };
    outln!("Reflectances   ceiling {}", refl(|r| r.ceiling));
    outln!("               walls   {}", refl(|r| r.walls));
    outln!("               floor   {}", refl(|r| r.floor));
    outln!(
        "{:<22} {:^29} | {:^29}",
        "Room size",
        "Viewed crosswise",
        "Viewed endwise"
    );
    outln!("{:>5} {:>5}", "X", "Y");
    let mut last_x = None;
    for r in &t.rooms {
        let x = if last_x == Some(r.x) {
            String::new()
        } else {
            format!("{}H", r.x)
        };
        last_x = Some(r.x);
        let cells = |c: &[Option<f64>; 5]| {
            c.iter()
                .map(|v| format!("{:>5}", cell(*v)))
                .collect::<Vec<_>>()
                .join(" ")
        };
        outln!(
            "{:>5} {:>5}{:11} {} | {}",
            x,
            format!("{}H", r.y),
            "",
            cells(&r.crosswise),
            cells(&r.endwise)
        );
    }
}
