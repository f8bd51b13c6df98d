//! The standard UGR table of a luminaire (CIE 190:2010, "Calculation and presentation of
//! unified glare rating tables for indoor lighting luminaires"), as catalogues print it.
//!
//! **Standard conditions.** A rectangular room X × Y (multiples of H, the height of the
//! luminaire plane above the eye), the 19 combinations of [`ROOMS`]; a regular array of
//! identical luminaires at spacing S = 1 H (CIE 190's spacing-to-height ratio 1:1;
//! CIE 117:1995 catalogues used 0.25 H, see [`UgrTableOptions::spacing`]), each at the
//! centre of an S × S cell; the observer at the middle of one wall of length X, eye at
//! height H below the luminaire plane, looking horizontally along Y. Five reflectance
//! combinations (ceiling, walls, reference plane at eye height: [`REFLECTANCES`]), two
//! viewing directions:
//! - **crosswise**: the line of sight lies in the luminaires' C0–C180 plane, the eye
//!   towards C0 (an EULUMDAT luminaire's length, along C90–C270, is across the view);
//! - **endwise**: the line of sight lies in the C90–C270 plane, the eye towards C90.
//!
//! **Glare sum** (CIE 117:1995 eq. 1, [`super::glare::ugr`]):
//! `UGR = 8 log₁₀(0.25 / L_b · Σ L² ω / p²)` over the luminaires with `T/R ≤ 3` and
//! γ ≤ 85°, where (R along the sight line, T across it, both from the eye):
//! - `L = I(C, γ) / A_p(C, γ)`, the intensity towards the eye over the luminous area
//!   projected towards it ([`super::LuminousOpening::projected_area`]);
//! - `ω = A_p / r²`, `r² = R² + T² + H²`;
//! - `p`, the Guth position index at `(H/R, T/R)` ([`super::glare::guth_position_index`]);
//!   luminaires outside its table (nearly overhead) do not count.
//!
//! **Background luminance** (CIE 190 eqs. 7–12): `L_b = E_WID / π`, with `E_WID` the
//! indirect illuminance of the walls between the eye and the luminaire plane:
//!
//! `E_WID = N / A_w · (Φ_F · T_FW + Φ_W · T_WW−1 + Φ_C · T_CW)`,
//!
//! - `N` luminaires, `A_w = 2 H (X + Y)` the wall area of that cavity;
//! - per luminaire, its first flux onto the reference plane `Φ_F = Σᵢ F_GLᵢ · Φ_zLᵢ` (the
//!   CIE zonal "direct ratio": `Φ_zL1..4` the downward flux in the cones of half-angle
//!   41.41°, 60°, 75.52° and 90° (solid angles π/2, π, 3π/2, 2π), `F_GL` the standard's
//!   coefficients by room index `k = XY / (H (X + Y))`, [`direct_ratio_coefficients`]);
//!   onto the walls `Φ_W = Φ_down − Φ_F`; onto the ceiling plane `Φ_C = Φ_up`;
//! - `T_FW`, `T_WW−1`, `T_CW`: the flux the walls receive indirectly (after one or more
//!   reflections) per lumen first landing on the reference plane, the walls, the ceiling
//!   ([`transfer_factors`]). CIE 190 tabulates them (its Table 5); here they are derived
//!   in closed form from the three-surface exchange of the cavity, which reproduces all
//!   285 entries of that table within 0.0013 (it prints three decimals).
//!
//! The cone fluxes are integrated from the luminaire's distribution (not from 10° zonal
//! sums), so `Φ_down + Φ_up` is the luminaire's flux.
//!
//! **Flux.** `L²` scales with the flux and `L_b` with it, so every cell moves by
//! `8 log₁₀ k` when the flux is multiplied by k: the table is given for the lamp flux the
//! file rates (or [`UgrTableOptions::lamp_lumens`]), and [`UgrTable::correction_summand`]
//! `= 8 log₁₀(Φ_lamp / 1000 lm)` is what to subtract for the table referred to 1000 lm of
//! lamp flux. H itself cancels (ω ∝ 1/H², L_b ∝ N/A_w ∝ 1/H²); [`H_M`] is used.

use glam::DVec3;

use super::distribution::sphere_rings;
use super::glare::{guth_position_index, ugr, GlareSource};
use super::{CandelaTable, Distribution, Luminaire, LuminaireSpec, LuminousOpening};

/// The 19 standard rooms, (X, Y) in multiples of H: X across the line of sight (the wall
/// the observer sits at), Y along it.
pub const ROOMS: [(f64, f64); 19] = [
    (2.0, 2.0),
    (2.0, 3.0),
    (2.0, 4.0),
    (2.0, 6.0),
    (2.0, 8.0),
    (2.0, 12.0),
    (4.0, 2.0),
    (4.0, 3.0),
    (4.0, 4.0),
    (4.0, 6.0),
    (4.0, 8.0),
    (4.0, 12.0),
    (8.0, 4.0),
    (8.0, 6.0),
    (8.0, 8.0),
    (8.0, 12.0),
    (12.0, 4.0),
    (12.0, 6.0),
    (12.0, 8.0),
];

/// Reflectances of ceiling, walls and reference plane (at eye height).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Reflectances {
    pub ceiling: f64,
    pub walls: f64,
    pub floor: f64,
}

const fn refl(ceiling: f64, walls: f64, floor: f64) -> Reflectances {
    Reflectances {
        ceiling,
        walls,
        floor,
    }
}

/// The standard's five reflectance combinations, in catalogue order.
pub const REFLECTANCES: [Reflectances; 5] = [
    refl(0.7, 0.5, 0.2),
    refl(0.7, 0.3, 0.2),
    refl(0.5, 0.5, 0.2),
    refl(0.5, 0.3, 0.2),
    refl(0.3, 0.3, 0.2),
];

/// Height of the luminaire plane above the eye, metres (any value gives the same table).
pub const H_M: f64 = 2.0;

/// Largest angle from the nadir at which a luminaire still counts, degrees.
pub const GAMMA_MAX_DEG: f64 = 85.0;

/// Half-angles (degrees) of the CIE flux-code cones: solid angles π/2, π, 3π/2 and 2π.
pub const FLUX_CODE_CONES_DEG: [f64; 4] = [41.409_622, 60.0, 75.522_488, 90.0];

/// CIE 190:2010's direct-ratio coefficients `F_GL1..4` by room index k (its Table 4, for
/// spacing 1 H): the first flux on the reference plane is `Σ F_GLi Φ_zLi`. Checked
/// against a direct integration over the room in this module's tests.
const F_GL: [(f64, [f64; 4]); 13] = [
    (1.00, [0.690, 0.109, 0.085, -0.016]),
    (1.20, [0.578, 0.200, 0.127, -0.018]),
    (1.33, [0.528, 0.218, 0.170, -0.017]),
    (1.50, [0.485, 0.215, 0.222, -0.012]),
    (1.60, [0.466, 0.207, 0.249, -0.006]),
    (1.71, [0.448, 0.198, 0.272, 0.005]),
    (2.00, [0.338, 0.257, 0.351, -0.018]),
    (2.40, [0.296, 0.203, 0.449, -0.006]),
    (2.67, [0.280, 0.165, 0.499, 0.006]),
    (3.00, [0.264, 0.125, 0.541, 0.027]),
    (3.43, [0.248, 0.058, 0.628, 0.032]),
    (4.00, [0.239, -0.012, 0.690, 0.058]),
    (4.80, [0.232, -0.084, 0.740, 0.098]),
];

/// The coefficients `F_GL1..4` for room index `k` (one of the standard rooms' values,
/// within 0.01); None for other rooms.
pub fn direct_ratio_coefficients(k: f64) -> Option<[f64; 4]> {
    F_GL.iter()
        .find(|(kk, _)| (kk - k).abs() < 0.01)
        .map(|(_, f)| *f)
}

/// Room index `k = XY / (H (X + Y))` for X, Y in multiples of H.
pub fn room_index(x: f64, y: f64) -> f64 {
    x * y / (x + y)
}

/// Configuration factor between two parallel, directly opposed a × b rectangles at
/// distance c (the closed form, e.g. Howell's catalogue C-11).
pub fn parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    2.0 / (std::f64::consts::PI * x * y)
        * (((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).sqrt().ln()
            + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
            + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
            - x * x.atan()
            - y * y.atan())
}

/// The flux transfer of the cavity between the reference plane (floor, at eye height),
/// the walls and the luminaire plane (ceiling), for a room X × Y (multiples of H, height
/// 1 H): `[T_FW, T_WW−1, T_CW]`, the lumens the walls receive after one or more
/// reflections per lumen first landing on the floor, the walls, the ceiling.
///
/// Three diffuse surfaces of uniform exitance: with `F` the configuration factors
/// (floor↔ceiling by [`parallel_rectangles`], the rest by summation and reciprocity),
/// the illuminances solve `E = E₀ + F ρ E`; for a unit first flux on surface s
/// (`E₀ = 1/A_s` on s), the walls receive `A_w E_w` in all, of which 1 is the first flux
/// itself when s is the walls.
pub fn transfer_factors(x: f64, y: f64, r: Reflectances) -> [f64; 3] {
    let (a_f, a_w) = (x * y, 2.0 * (x + y));
    let f_fc = parallel_rectangles(x, y, 1.0);
    let f_fw = 1.0 - f_fc;
    let f_wf = a_f * f_fw / a_w;
    let f_ww = 1.0 - 2.0 * f_wf;
    // Rows: receiving surface (floor, walls, ceiling); columns: source.
    let f = [[0.0, f_fw, f_fc], [f_wf, f_ww, f_wf], [f_fc, f_fw, 0.0]];
    let rho = [r.floor, r.walls, r.ceiling];
    let area = [a_f, a_w, a_f];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = f64::from(u8::from(i == j)) - f[i][j] * rho[j];
        }
    }
    let mut out = [0.0; 3];
    for (s, o) in out.iter_mut().enumerate() {
        let mut e0 = [0.0; 3];
        e0[s] = 1.0 / area[s];
        let e = solve3(m, e0);
        *o = a_w * e[1] - if s == 1 { 1.0 } else { 0.0 };
    }
    out
}

/// `m x = b` by Cramer's rule (m is well conditioned: diagonally dominant).
fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut mc = m;
        for r in 0..3 {
            mc[r][c] = b[r];
        }
        *xc = det(mc) / d;
    }
    x
}

/// What the table is computed for.
#[derive(Debug, Clone, Copy)]
pub struct UgrTableOptions {
    /// Luminaire spacing, multiples of H: 1 by CIE 190:2010; 0.25 gives the older
    /// CIE 117:1995 catalogue convention (the background model stays CIE 190's).
    pub spacing: f64,
    /// Total lamp flux the table refers to, lm: the intensities are scaled by it over the
    /// file's rated lamp flux (for absolute photometry, over the luminaire's flux). None
    /// keeps the file's.
    pub lamp_lumens: Option<f64>,
}

impl Default for UgrTableOptions {
    fn default() -> Self {
        UgrTableOptions {
            spacing: 1.0,
            lamp_lumens: None,
        }
    }
}

/// One room's row: UGR for the five [`REFLECTANCES`], crosswise and endwise (None where
/// no luminaire counts).
#[derive(Debug, Clone, serde::Serialize)]
pub struct UgrRow {
    /// Room dimensions, multiples of H: X across the line of sight, Y along it.
    pub x: f64,
    pub y: f64,
    pub crosswise: [Option<f64>; 5],
    pub endwise: [Option<f64>; 5],
}

/// A luminaire's standard UGR table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct UgrTable {
    /// Luminaire spacing, multiples of H.
    pub spacing: f64,
    /// Total lamp flux the table refers to, lm.
    pub lamp_lumens: f64,
    /// The luminaire's flux at that lamp flux, lm.
    pub luminaire_lumens: f64,
    /// Its downward and upward flux, lm.
    pub downward_lumens: f64,
    pub upward_lumens: f64,
    /// `8 log₁₀(lamp_lumens / 1000)`: subtract it from every cell for the table referred
    /// to 1000 lm of lamp flux.
    pub correction_summand: f64,
    pub reflectances: [Reflectances; 5],
    /// The [`ROOMS`], in order.
    pub rooms: Vec<UgrRow>,
}

/// Cumulative downward flux in the [`FLUX_CODE_CONES_DEG`] cones, and the upward flux, lm,
/// of `lum` aimed down: rings of 0.05° in γ, 2° in C, midpoint rule, the cumulative flux
/// interpolated linearly inside the ring a cone's edge falls in.
fn cone_fluxes(lum: &Luminaire) -> ([f64; 4], f64) {
    let nt = 3600;
    let dt = std::f64::consts::PI / nt as f64;
    let (c0, c90, aim) = (lum.c0, lum.c90(), lum.aim);
    let rings = sphere_rings(nt, 180, |cg, sg, cc, sc| {
        lum.intensity(aim * cg + c0 * (sg * cc) + c90 * (sg * sc))
    });
    // cumulative[i]: flux from γ = 0 to γ = i·dt.
    let mut cumulative = Vec::with_capacity(nt + 1);
    cumulative.push(0.0);
    let mut sum = 0.0;
    for r in rings {
        sum += r;
        cumulative.push(sum);
    }
    let at = |deg: f64| {
        let f = deg.to_radians() / dt;
        let i = (f.floor() as usize).min(nt - 1);
        let u = f - i as f64;
        cumulative[i] * (1.0 - u) + cumulative[i + 1] * u
    };
    let cones = FLUX_CODE_CONES_DEG.map(at);
    (cones, sum - cones[3])
}

/// The luminaires that count in room X × Y (multiples of H) at `spacing` H, viewed
/// crosswise or endwise, and the number of luminaires in the room.
fn glare_sources(
    lum: &Luminaire,
    x: f64,
    y: f64,
    spacing: f64,
    crosswise: bool,
) -> (Vec<GlareSource>, usize) {
    let h = H_M;
    let (nx, ny) = (
        ((x / spacing).round() as usize).max(1),
        ((y / spacing).round() as usize).max(1),
    );
    let s = spacing * h;
    // The eye looks along +Y (world Z up); the luminaires aim down. Crosswise the eye is
    // towards C0 from the luminaires ahead (c0 = −Y), endwise towards C90 (c90 = −Y).
    let c0 = if crosswise { -DVec3::Y } else { DVec3::X };
    let lum = Luminaire {
        aim: -DVec3::Z,
        c0,
        ..lum.clone()
    };
    debug_assert!(crosswise || (lum.c90() + DVec3::Y).length() < 1e-12);
    let mut sources = Vec::new();
    for i in 0..nx {
        let t = ((i as f64 + 0.5) * s) - 0.5 * nx as f64 * s;
        for j in 0..ny {
            let r = (j as f64 + 0.5) * s;
            let horizontal = t.hypot(r);
            if t.abs() / r > 3.0 + 1e-12 || horizontal.atan2(h).to_degrees() > GAMMA_MAX_DEG {
                continue;
            }
            let Some(p) = guth_position_index(h / r, t.abs() / r) else {
                continue;
            };
            let to_eye = DVec3::new(-t, -r, -h);
            let d2 = to_eye.length_squared();
            let d = to_eye / d2.sqrt();
            let area = lum
                .opening
                .projected_area(d.dot(lum.aim), d.dot(lum.c0), d.dot(lum.c90()));
            if area <= 0.0 {
                continue;
            }
            sources.push(GlareSource {
                luminance: lum.intensity(d) / area,
                solid_angle: area / d2,
                position_index: p,
            });
        }
    }
    (sources, nx * ny)
}

/// The standard UGR table of the luminaire a candela table describes.
///
/// Errors: a point source (no luminous area: UGR needs the luminous size), a distribution
/// that emits nothing, a spacing or lamp flux out of range.
pub fn ugr_table(table: &CandelaTable, opts: UgrTableOptions) -> Result<UgrTable, String> {
    if table.opening == LuminousOpening::Point {
        return Err(
            "the file gives no luminous area (a point source); UGR needs the \
                    luminous dimensions of the luminaire"
                .into(),
        );
    }
    if !(opts.spacing.is_finite() && (0.05..=4.0).contains(&opts.spacing)) {
        return Err(format!(
            "spacing {} H: must be between 0.05 and 4",
            opts.spacing
        ));
    }
    // The standard table is of the luminaire as measured, aimed straight down (this
    // frame is Z-up): an IES file's tilt data do not apply.
    let distribution = Distribution::Table(Box::new(CandelaTable {
        tilt: None,
        ..table.clone()
    }));
    let integral = distribution.integral();
    if !(integral > 0.0 && integral.is_finite()) {
        return Err("the distribution emits no light".into());
    }
    let rated = table.lamp_lumens.filter(|l| *l > 0.0).unwrap_or(integral);
    let lamp_lumens = match opts.lamp_lumens {
        Some(l) if l.is_finite() && l > 0.0 => l,
        Some(l) => return Err(format!("lumens {l}: must be positive")),
        None => rated,
    };
    let lum = Luminaire::with_integral(
        LuminaireSpec {
            id: "ugr",
            position: DVec3::ZERO,
            aim: -DVec3::Z,
            c0: Some(DVec3::X),
            distribution,
            lumens: Some(integral * lamp_lumens / rated),
            color: crate::color::Rgb::ONE,
            watts: None,
        },
        integral,
    )?;
    let (cones, up) = cone_fluxes(&lum);
    let down = cones[3];
    let mut rooms = Vec::with_capacity(ROOMS.len());
    for &(x, y) in &ROOMS {
        let k = room_index(x, y);
        let fgl = direct_ratio_coefficients(k).ok_or_else(|| format!("no F_GL for k = {k}"))?;
        let to_floor: f64 = fgl.iter().zip(&cones).map(|(f, c)| f * c).sum();
        let to_walls = down - to_floor;
        let (cross, n) = glare_sources(&lum, x, y, opts.spacing, true);
        let (end, _) = glare_sources(&lum, x, y, opts.spacing, false);
        let wall_area = 2.0 * H_M * H_M * (x + y);
        let mut row = UgrRow {
            x,
            y,
            crosswise: [None; 5],
            endwise: [None; 5],
        };
        for (c, &r) in REFLECTANCES.iter().enumerate() {
            let [t_fw, t_ww, t_cw] = transfer_factors(x, y, r);
            let e_wid = n as f64 / wall_area * (to_floor * t_fw + to_walls * t_ww + up * t_cw);
            let lb = e_wid / std::f64::consts::PI;
            row.crosswise[c] = ugr(lb, cross.iter().copied());
            row.endwise[c] = ugr(lb, end.iter().copied());
        }
        rooms.push(row);
    }
    Ok(UgrTable {
        spacing: opts.spacing,
        lamp_lumens,
        luminaire_lumens: lum.lumens,
        downward_lumens: down,
        upward_lumens: up,
        correction_summand: 8.0 * (lamp_lumens / 1000.0).log10(),
        reflectances: REFLECTANCES,
        rooms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::{PhotometricFormat, PhotometricType};

    /// A Lambertian disk of `diameter` m, `i0` cd at the nadir, rated `lamp` lm.
    fn lambertian_disk(i0: f64, diameter: f64, lamp: Option<f64>) -> CandelaTable {
        CandelaTable {
            format: PhotometricFormat::Eulumdat,
            opening: LuminousOpening::Disk {
                along_c0: diameter,
                along_c90: diameter,
                sides: 0.0,
            },
            kind: PhotometricType::C,
            vertical: (0..=180).map(f64::from).collect(),
            horizontal: vec![0.0],
            candela: vec![(0..=180)
                .map(|g| i0 * f64::from(g).to_radians().cos().max(0.0))
                .collect()],
            lamp_lumens: lamp,
            input_watts: None,
            tilt: None,
        }
    }

    /// A 1.2 × 0.3 m panel whose intensity falls faster across (C0) than along.
    fn linear_panel() -> CandelaTable {
        let horizontal: Vec<f64> = (0..=18).map(|c| f64::from(c) * 5.0).collect();
        let vertical: Vec<f64> = (0..=36).map(|g| f64::from(g) * 5.0).collect();
        let candela = horizontal
            .iter()
            .map(|c: &f64| {
                vertical
                    .iter()
                    .map(|g: &f64| {
                        let cg = g.to_radians().cos().max(0.0);
                        900.0 * cg.powf(1.0 + c.to_radians().cos().powi(2))
                    })
                    .collect()
            })
            .collect();
        CandelaTable {
            format: PhotometricFormat::Eulumdat,
            opening: LuminousOpening::Rectangle {
                along_c0: 0.3,
                along_c90: 1.2,
                sides: 0.0,
            },
            kind: PhotometricType::C,
            vertical,
            horizontal,
            candela,
            lamp_lumens: Some(3000.0),
            input_watts: None,
            tilt: None,
        }
    }

    fn cells(t: &UgrTable) -> Vec<f64> {
        t.rooms
            .iter()
            .flat_map(|r| r.crosswise.iter().chain(&r.endwise))
            .map(|v| v.expect("every standard cell is defined"))
            .collect()
    }

    /// CIE 190's Table 5 (transfer factors) is the three-surface exchange of the cavity.
    #[test]
    fn transfer_factors_reproduce_the_cie_190_table() {
        // (room, reflectance index, [T_FW, T_WW-1, T_CW]) as CIE 190 tabulates them.
        let cases = [
            ((2.0, 2.0), 0, [0.220, 0.422, 0.646]),
            ((4.0, 8.0), 0, [0.115, 0.211, 0.307]),
            ((8.0, 6.0), 1, [0.088, 0.098, 0.231]),
            ((12.0, 6.0), 2, [0.071, 0.134, 0.148]),
            ((4.0, 3.0), 3, [0.126, 0.143, 0.272]),
            ((8.0, 12.0), 4, [0.049, 0.059, 0.069]),
        ];
        for ((x, y), r, want) in cases {
            let got = transfer_factors(x, y, REFLECTANCES[r]);
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() <= 0.0015, "{x}x{y} #{r}: {got:?} vs {want:?}");
            }
        }
    }

    /// The tabulated direct-ratio coefficients give the first flux on the reference plane
    /// that a direct integration over the room gives, for cos^m distributions at 1 H.
    #[test]
    fn direct_ratio_coefficients_match_an_integration_over_the_room() {
        for m in [1, 3] {
            let cone = |deg: f64| 1.0 - deg.to_radians().cos().powi(m + 1);
            for &(x, y) in &ROOMS {
                let f = direct_ratio_coefficients(room_index(x, y)).unwrap();
                let tabular: f64 = f
                    .iter()
                    .zip(FLUX_CODE_CONES_DEG)
                    .map(|(f, d)| f * cone(d))
                    .sum();
                // Luminaires of unit flux at the cell centres, height 1; the floor's
                // illuminance by the midpoint rule, 16 cells per H.
                let n = 16;
                let i0 = f64::from(m + 1) / (2.0 * std::f64::consts::PI);
                let (nx, ny) = (x as usize, y as usize);
                let mut flux = 0.0;
                for a in 0..nx * n {
                    for b in 0..ny * n {
                        let (px, py) = ((a as f64 + 0.5) / n as f64, (b as f64 + 0.5) / n as f64);
                        for i in 0..nx {
                            for j in 0..ny {
                                let (dx, dy) = (px - i as f64 - 0.5, py - j as f64 - 0.5);
                                let d2 = dx * dx + dy * dy + 1.0;
                                let c = d2.sqrt().recip();
                                flux += i0 * c.powi(m) * c / d2;
                            }
                        }
                    }
                }
                let exact = flux / (n * n) as f64 / (nx * ny) as f64;
                assert!(
                    (tabular - exact).abs() < 0.01,
                    "m {m} room {x}x{y}: {tabular} vs {exact}"
                );
            }
        }
    }

    /// Multiplying the flux by k moves every cell by 8 log₁₀ k (L² by k², L_b by k).
    #[test]
    fn scaling_the_flux_shifts_every_cell_by_8_log_k() {
        let panel = linear_panel();
        let base = ugr_table(&panel, UgrTableOptions::default()).unwrap();
        assert!((base.lamp_lumens - 3000.0).abs() < 1e-9);
        let k = 2.5;
        let scaled = ugr_table(
            &panel,
            UgrTableOptions {
                lamp_lumens: Some(3000.0 * k),
                ..Default::default()
            },
        )
        .unwrap();
        let shift = 8.0 * k.log10();
        for (a, b) in cells(&base).iter().zip(cells(&scaled)) {
            assert!((b - a - shift).abs() < 1e-9, "{a} → {b}");
        }
        assert!((scaled.correction_summand - base.correction_summand - shift).abs() < 1e-9);
        assert!((scaled.luminaire_lumens / base.luminaire_lumens - k).abs() < 1e-9);
    }

    /// The standard table is of the luminaire as measured: tilt data change nothing.
    #[test]
    fn tilt_data_leave_the_standard_table_alone() {
        let panel = linear_panel();
        let tilted = CandelaTable {
            tilt: Some(crate::photometry::Tilt {
                geometry: crate::photometry::LampGeometry::Vertical,
                angles: vec![0.0, 90.0],
                factors: vec![1.0, 0.5],
            }),
            ..panel.clone()
        };
        let a = ugr_table(&panel, UgrTableOptions::default()).unwrap();
        let b = ugr_table(&tilted, UgrTableOptions::default()).unwrap();
        assert_eq!(cells(&a), cells(&b));
        assert_eq!(a.luminaire_lumens, b.luminaire_lumens);
    }

    /// A rotationally symmetric luminaire looks the same crosswise and endwise; a linear
    /// one glares more where its bright side faces the eye.
    #[test]
    fn crosswise_and_endwise() {
        let disk = ugr_table(
            &lambertian_disk(1000.0, 0.2, None),
            UgrTableOptions::default(),
        )
        .unwrap();
        for r in &disk.rooms {
            for (a, b) in r.crosswise.iter().zip(&r.endwise) {
                assert!((a.unwrap() - b.unwrap()).abs() < 1e-9);
            }
        }
        // Lambertian: the flux is π I₀, all downward.
        assert!((disk.luminaire_lumens / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 1e-3);
        assert!(disk.upward_lumens.abs() < 1e-6 * disk.luminaire_lumens);
        let panel = ugr_table(&linear_panel(), UgrTableOptions::default()).unwrap();
        // Across (C0) the intensity falls as cos² γ, along (C90) as cos γ: endwise glares more.
        for r in &panel.rooms {
            assert!(r.endwise[0].unwrap() > r.crosswise[0].unwrap(), "{r:?}");
        }
    }

    /// One cell by hand: a 2H × 2H room at spacing 1 H holds 4 luminaires at
    /// (T, R) = (±0.5, 0.5) H and (±0.5, 1.5) H; the near ones are beyond the Guth
    /// table (H/R = 2), the far ones count.
    #[test]
    fn one_cell_by_hand() {
        let (i0, dia) = (1000.0, 0.2);
        let t = ugr_table(&lambertian_disk(i0, dia, None), UgrTableOptions::default()).unwrap();
        let h = H_M;
        let (tt, r) = (0.5 * h, 1.5 * h);
        let d2 = tt * tt + r * r + h * h;
        let cos_g = h / d2.sqrt();
        let area = std::f64::consts::FRAC_PI_4 * dia * dia * cos_g;
        // Lambertian: L = I0 cos γ / (A cos γ) = I0 / A_disk.
        let l = i0 * cos_g / area;
        let omega = area / d2;
        let p = guth_position_index(h / r, tt / r).unwrap();
        let sum = 2.0 * l * l * omega / (p * p);
        // Background: all flux π I0 downward; cones of cos: 1 − cos² γ.
        let phi = std::f64::consts::PI * i0;
        let cones = FLUX_CODE_CONES_DEG.map(|d| phi * (1.0 - d.to_radians().cos().powi(2)));
        let f = direct_ratio_coefficients(1.0).unwrap();
        let floor: f64 = (0..4).map(|i| f[i] * cones[i]).sum();
        let [t_fw, t_ww, _] = transfer_factors(2.0, 2.0, REFLECTANCES[0]);
        let e = 4.0 / (2.0 * h * h * 4.0) * (floor * t_fw + (phi - floor) * t_ww);
        let want = 8.0 * (0.25 * std::f64::consts::PI / e * sum).log10();
        let got = t.rooms[0].crosswise[0].unwrap();
        assert!((got - want).abs() < 0.01, "{got} vs {want}");
    }

    #[test]
    fn point_sources_and_bad_options_are_refused() {
        let mut point = lambertian_disk(1000.0, 0.2, None);
        point.opening = LuminousOpening::Point;
        let e = ugr_table(&point, UgrTableOptions::default()).unwrap_err();
        assert!(e.contains("luminous area"), "{e}");
        let disk = lambertian_disk(1000.0, 0.2, None);
        for opts in [
            UgrTableOptions {
                spacing: 0.0,
                lamp_lumens: None,
            },
            UgrTableOptions {
                spacing: 1.0,
                lamp_lumens: Some(-5.0),
            },
        ] {
            assert!(ugr_table(&disk, opts).is_err());
        }
    }
}
