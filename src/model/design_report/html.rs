//! The report as one HTML document: inline CSS for screen and print (A4, a page per
//! section, rows that do not split), images as data URLs, plans as inline SVG. Every text
//! from the scene or the request is escaped.

use std::fmt::Write;

use base64::Engine as _;

use super::{fmt_lux, plan, DesignReport, GridReport, ScheduleRow};
use crate::model::compliance::Check;

/// The page's style: screen and print.
const CSS: &str = r#"
@page { size: A4; margin: 14mm 12mm; }
* { box-sizing: border-box; }
body { font: 10pt/1.35 "DejaVu Sans", "Helvetica", "Arial", sans-serif; color: #111;
  max-width: 186mm; margin: 0 auto; padding: 8mm 0; }
h1 { font-size: 18pt; margin: 0 0 2mm; }
h2 { font-size: 13pt; margin: 0 0 3mm; border-bottom: 1px solid #444; padding-bottom: 1mm; }
h3 { font-size: 11pt; margin: 4mm 0 2mm; }
section { margin-bottom: 8mm; }
section.page { break-before: page; page-break-before: always; }
table { border-collapse: collapse; width: 100%; margin: 2mm 0 4mm; }
thead { display: table-header-group; }
tr, img, svg, figure, .keep { break-inside: avoid; page-break-inside: avoid; }
th, td { border: 1px solid #999; padding: 1.2mm 2mm; text-align: left; vertical-align: top; }
th { background: #eee; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
.pass { color: #06702a; font-weight: bold; }
.fail { color: #b3121b; font-weight: bold; }
.muted { color: #555; font-size: 9pt; }
dl.meta { display: grid; grid-template-columns: 32mm 1fr; gap: 1mm 4mm; margin: 3mm 0 5mm; }
dl.meta dt { font-weight: bold; } dl.meta dd { margin: 0; }
figure { margin: 0 0 5mm; }
figure img { width: 100%; max-width: 160mm; height: auto; border: 1px solid #999; }
figcaption { font-size: 9pt; color: #333; margin-top: 1mm; }
svg.plan { width: 100%; max-width: 170mm; height: auto; }
@media print { body { padding: 0; max-width: none; } }
"#;

/// Escapes text for HTML content and quoted attribute values.
pub(super) fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// ✓ or ✗ in its colour.
fn mark(pass: bool) -> &'static str {
    if pass {
        r#"<span class="pass">✓</span>"#
    } else {
        r#"<span class="fail">✗</span>"#
    }
}

impl DesignReport {
    /// The document.
    pub fn html(&self) -> String {
        let mut h = String::with_capacity(64 * 1024);
        let title = self
            .meta
            .title
            .as_deref()
            .unwrap_or("Lighting design report");
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
             <title>{} · {}</title><style>{CSS}</style></head><body>\n",
            esc(title),
            esc(&self.scene_name)
        );
        self.title_block(&mut h, title);
        self.schedule_section(&mut h);
        for (i, g) in self.grids.iter().enumerate() {
            grid_section(&mut h, g, i);
        }
        self.assumptions(&mut h);
        self.images_section(&mut h);
        h.push_str("</body></html>\n");
        h
    }

    fn title_block(&self, h: &mut String, title: &str) {
        let _ = write!(
            h,
            "<section id=\"title\"><h1>{}</h1><dl class=\"meta\">",
            esc(title)
        );
        let mut row = |k: &str, v: &str| {
            let _ = write!(h, "<dt>{k}</dt><dd>{v}</dd>");
        };
        if let Some(p) = &self.meta.project {
            row("Project", &esc(p));
        }
        let scene = format!("{} ({})", esc(&self.scene_name), esc(&self.scene_id));
        row("Scene", &scene);
        row("Date", &self.date);
        if let Some(a) = &self.meta.author {
            row("Author", &esc(a));
        }
        row("Software", &format!("relight {}", esc(self.version)));
        h.push_str(
            "</dl><h3>Lighting state</h3><table id=\"state\"><thead><tr><th>Group</th>\
            <th>Name</th><th class=\"num\">Level</th><th>Colour</th><th class=\"num\">MF</th>\
            <th class=\"num\">Ra</th></tr></thead><tbody>",
        );
        for g in &self.groups {
            let colour = g.color.map_or("white".to_string(), |c| {
                format!("{:.3}, {:.3}, {:.3}", c[0], c[1], c[2])
            });
            let ra = g.ra.map_or("–".to_string(), |r| format!("{r:.0}"));
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td class=\"num\">{:.0} %</td><td>{colour}</td>\
                 <td class=\"num\">{:.2}</td><td class=\"num\">{ra}</td></tr>",
                esc(&g.id),
                esc(&g.name),
                100.0 * g.level,
                g.maintenance_factor
            );
        }
        h.push_str("</tbody></table>");
        self.power_table(h);
        h.push_str("</section>\n");
    }

    fn power_table(&self, h: &mut String) {
        let p = &self.power;
        let area = p.floor_area;
        let watts = |w: Option<f64>| w.map_or("–".to_string(), |w| format!("{w:.1}"));
        let density = |w: Option<f64>| match (w, area) {
            (Some(w), Some(a)) if a > 0.0 => format!("{:.2}", w / a),
            _ => "–".to_string(),
        };
        let area_text = area.map_or("–".to_string(), |a| format!("{a:.2}"));
        let _ = write!(
            h,
            "<h3>Power</h3><table id=\"power\"><thead><tr><th></th><th class=\"num\">Luminous \
             flux (lm)</th><th class=\"num\">Power (W)</th><th class=\"num\">Power density \
             (W/m²)</th></tr></thead><tbody>\
             <tr><td>Installed (rated output)</td><td class=\"num\">{}</td>\
             <td class=\"num\" id=\"installed-watts\">{}</td><td class=\"num\">{}</td></tr>\
             <tr><td>In this lighting state</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{}</td></tr></tbody></table>\
             <p class=\"muted\">Floor area {area_text} m² ({}). Dimmed power is taken as \
             proportional to the light output.</p>",
            fmt_lux(p.installed_lumens),
            watts(p.installed_watts),
            density(p.installed_watts),
            fmt_lux(p.state.luminaire_lumens),
            watts(p.state.luminaire_watts),
            density(p.state.luminaire_watts),
            p.floor_source
        );
    }

    fn schedule_section(&self, h: &mut String) {
        h.push_str(
            "<section id=\"schedule\"><h2>Luminaire schedule</h2><table id=\"schedule-table\">\
             <thead><tr><th>Type</th><th>Photometric file</th><th>Groups</th>\
             <th class=\"num\">Count</th><th class=\"num\">Lumens each (lm)</th>\
             <th class=\"num\">Lumens total (lm)</th><th class=\"num\">Watts each (W)</th>\
             <th class=\"num\">Watts total (W)</th><th class=\"num\">Efficacy (lm/W)</th>\
             </tr></thead><tbody>",
        );
        for r in &self.schedule {
            schedule_row(h, r);
        }
        let count: usize = self.schedule.iter().map(|r| r.count).sum();
        let _ = writeln!(
            h,
            "</tbody><tfoot><tr><th colspan=\"3\">Total</th><td class=\"num\" id=\"luminaire-count\">\
             {count}</td><td></td><td class=\"num\" id=\"total-lumens\">{}</td><td></td>\
             <td class=\"num\">{}</td><td></td></tr></tfoot></table></section>",
            fmt_lux(self.power.installed_lumens),
            self.power
                .installed_watts
                .map_or("–".to_string(), |w| format!("{w:.1}"))
        );
    }

    fn assumptions(&self, h: &mut String) {
        h.push_str(
            "<section id=\"assumptions\" class=\"page\"><h2>Assumptions</h2>\
             <h3>Maintenance factors</h3><p>Maintained illuminance = MF × initial \
             (CIE 97), per light group:</p><table><thead><tr><th>Group</th>\
             <th class=\"num\">MF</th></tr></thead><tbody>",
        );
        for g in &self.groups {
            let _ = write!(
                h,
                "<tr><td>{}</td><td class=\"num\">{:.2}</td></tr>",
                esc(&g.name),
                g.maintenance_factor
            );
        }
        h.push_str(
            "</tbody></table><h3>Reflectances of the main surfaces</h3>\
             <table id=\"reflectances\"><thead><tr><th>Material</th><th class=\"num\">Area (m²)\
             </th><th class=\"num\">Reflectance ρ</th><th>Kd (linear RGB)</th></tr></thead><tbody>",
        );
        for r in &self.reflectances {
            let _ = write!(
                h,
                "<tr><td>{}</td><td class=\"num\">{:.1}</td><td class=\"num\">{:.2}</td>\
                 <td>{:.2}, {:.2}, {:.2}</td></tr>",
                esc(&r.material),
                r.area,
                r.rho,
                r.kd[0],
                r.kd[1],
                r.kd[2]
            );
        }
        h.push_str(
            "</tbody></table><p class=\"muted\">UGR (CIE 117) is rated under the initial \
             state at four seated observers (1.2 m) at the middle of each edge of the area, \
             looking across it; the highest counts.</p></section>\n",
        );
    }

    fn images_section(&self, h: &mut String) {
        if self.images.is_empty() {
            return;
        }
        h.push_str("<section id=\"images\" class=\"page\"><h2>Relit views</h2>");
        for im in &self.images {
            let data = base64::engine::general_purpose::STANDARD.encode(&im.png);
            let _ = write!(
                h,
                "<figure><img class=\"view\" width=\"{}\" height=\"{}\" alt=\"camera {}\" \
                 src=\"data:image/png;base64,{data}\"><figcaption>Camera “{}”, same lighting \
                 state.</figcaption></figure>",
                im.width,
                im.height,
                esc(&im.camera),
                esc(&im.camera)
            );
        }
        h.push_str("</section>\n");
    }
}

fn schedule_row(h: &mut String, r: &ScheduleRow) {
    let n = r.count as f64;
    let w = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{x:.1}"));
    let efficacy = match r.watts {
        Some(w) if w > 0.0 => format!("{:.1}", r.lumens / w),
        _ => "–".into(),
    };
    let _ = write!(
        h,
        "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
         <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
         <td class=\"num\">{efficacy}</td></tr>",
        esc(&r.kind),
        r.file.as_deref().map_or("–".to_string(), esc),
        esc(&r.groups.join(", ")),
        r.count,
        fmt_lux(r.lumens),
        fmt_lux(r.lumens * n),
        w(r.watts),
        w(r.watts.map(|x| x * n)),
    );
}

/// A grid's check for `requirement`, if required.
fn check<'a>(g: &'a GridReport, requirement: &str) -> Option<&'a Check> {
    g.compliance
        .as_ref()?
        .checks
        .iter()
        .find(|c| c.requirement == requirement)
}

/// One statistic's row: name, value, required, pass.
fn stat_row(h: &mut String, key: &str, name: &str, value: &str, c: Option<&Check>) {
    let (req, pass) = match c {
        Some(c) => {
            let op = if c.requirement == "ugr_l" {
                "≤"
            } else {
                "≥"
            };
            let req = match c.unit {
                "lx" => format!("{op} {} lx", fmt_lux(c.required)),
                _ => format!("{op} {}", c.required),
            };
            (req, mark(c.pass))
        }
        None => ("–".to_string(), ""),
    };
    let _ = write!(
        h,
        "<tr><th>{name}</th><td class=\"num\" id=\"{key}\">{value}</td><td class=\"num\">{req}\
         </td><td class=\"verdict\">{pass}</td></tr>"
    );
}

fn grid_section(h: &mut String, g: &GridReport, i: usize) {
    let kind = match g.kind {
        Some(k) => format!(" · {k:?} area").to_lowercase(),
        None => String::new(),
    };
    let _ = write!(
        h,
        "<section class=\"page grid\" id=\"grid-{i}\" data-grid=\"{}\"><h2>{}</h2>\
         <p class=\"muted\">Grid “{}”{kind} · {} points{}</p>",
        esc(&g.id),
        esc(&g.name),
        esc(&g.id),
        g.maintained.count,
        g.spacing.map_or(String::new(), |s| format!(
            " · spacing {} m",
            (s * 1e4).round() / 1e4
        ))
    );
    h.push_str(&plan::svg(g));
    let (m, init) = (&g.maintained, &g.initial);
    h.push_str(
        "<table class=\"stats keep\"><thead><tr><th>Quantity</th><th class=\"num\">Value</th>\
         <th class=\"num\">Required</th><th>Pass</th></tr></thead><tbody>",
    );
    let lx = |v: f64| format!("{} lx", fmt_lux(v));
    let key = |k: &str| format!("{k}-{i}");
    stat_row(
        h,
        &key("em"),
        "Ēm (maintained average)",
        &lx(m.avg),
        check(g, "em"),
    );
    stat_row(h, &key("emin"), "Emin (maintained)", &lx(m.min), None);
    stat_row(h, &key("emax"), "Emax (maintained)", &lx(m.max), None);
    stat_row(
        h,
        &key("u0"),
        "U₀ = Emin / Ēm",
        &m.u0
            .map_or_else(|| "– (unlit)".to_string(), |u| format!("{u:.2}")),
        check(g, "u0"),
    );
    stat_row(h, &key("eavg"), "Eavg (initial)", &lx(init.avg), None);
    if let Some(c) = check(g, "ugr_l") {
        let v = c.achieved.map_or("–".to_string(), |u| format!("{u:.1}"));
        stat_row(h, &key("ugr"), "UGR (highest observer)", &v, Some(c));
    }
    if let Some(c) = check(g, "ra") {
        let v = c.achieved.map_or("–".to_string(), |r| format!("{r:.0}"));
        stat_row(h, &key("ra"), "Ra (lowest lit group)", &v, Some(c));
    }
    h.push_str("</tbody></table>");
    if let Some(c) = &g.compliance {
        let _ = write!(
            h,
            "<p>Requirements: {} <span id=\"verdict-{i}\">{}</span></p>",
            mark(c.pass),
            if c.pass { "all met" } else { "not all met" }
        );
        for note in c.checks.iter().filter_map(|c| c.note.as_ref()) {
            let _ = write!(h, "<p class=\"muted\">{}</p>", esc(note));
        }
    }
    h.push_str("</section>\n");
}

#[cfg(test)]
mod tests {
    use super::esc;

    #[test]
    fn escapes_markup_and_quotes() {
        assert_eq!(
            esc(r#"<script>"a" & 'b'</script>"#),
            "&lt;script&gt;&quot;a&quot; &amp; &#39;b&#39;&lt;/script&gt;"
        );
    }
}
