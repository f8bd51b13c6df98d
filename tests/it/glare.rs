//! Discomfort glare (CIE 117 UGR) at observers, against a hand calculation.

use glam::DVec3;
use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::color::Rgb;
use relight::model::{Cancel, LightState, Lighting, Model};

use crate::common::{self, *};

/// One luminaire of known intensity and luminous area in front of a black room whose only
/// background is a self-luminous wall of known exitance, so every quantity of the formula
/// has a closed form:
/// - the wall (4 × 4 m, M = 200 lm/m², 3 m ahead, centred on the eye) gives
///   E_ind = M · F, F = 4 · F_corner(2, 2, 3) (point to parallel rectangle), L_b = E_ind/π;
/// - the luminaire (Lambertian, I = I₀ cos γ, a 0.6 × 0.6 m opening) hangs R = 2 m ahead and
///   H = 1 m above the eye: L = I₀ / A towards every direction, ω = A cos γ / r², and
///   H/R = 0.5, T/R = 0 gives p = 2.86 from CIE 117's table.
#[test]
fn ugr_at_an_observer_matches_the_hand_calculation() {
    let _gate = common::shared();
    let (i0, side, m) = (2000.0f64, 0.6f64, 200.0f64);
    let eye = DVec3::new(0.0, 1.2, 0.0);
    let (r, h) = (2.0f64, 1.0f64);
    let wall = quad(
        "wall",
        "glow",
        [
            [-2.0, eye.y - 2.0, 3.0],
            [2.0, eye.y - 2.0, 3.0],
            [2.0, eye.y + 2.0, 3.0],
            [-2.0, eye.y + 2.0, 3.0],
        ],
        [0.0, 0.0, -1.0],
    );
    let cd: Vec<String> = (0..=18)
        .map(|k| format!("{:.6}", i0 * (5.0 * k as f64).to_radians().cos()))
        .collect();
    let gammas: Vec<String> = (0..=18).map(|k| format!("{}", 5 * k)).collect();
    let ies = format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 19 1 1 2 {side} {side} 0\n1 1 30\n{}\n0\n{}\n",
        gammas.join(" "),
        cd.join(" ")
    );
    let toml = format!(
        "transfer = \"columns\"\n[mesh]\nmax_edge = 0.5\n[[luminaires]]\nid = \"panel\"\n\
         position = [0, {}, {r}]\nphotometry = \"panel.ies\"\n",
        eye.y + h
    );
    let s = write_scene(
        &wall,
        &format!("newmtl glow\nKd 0 0 0\nKe {m} {m} {m}\n"),
        Some(&toml),
    );
    std::fs::write(s.path().join("panel.ies"), ies).unwrap();
    let model = Model::new(
        load_or_bake(
            s.path(),
            CachePolicy::Off,
            &BakeOptions::default(),
            &|_, _| {},
        )
        .unwrap(),
    );
    let w = Lighting::Groups(model.weights(&LightState::default()).unwrap());
    let answer = model
        .glare(&[(eye, DVec3::Z)], &w, &Cancel::default())
        .unwrap();
    let o = &answer[0];
    // By hand.
    let corner = |a: f64, b: f64, c: f64| {
        let (x, y) = (a / c, b / c);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    let e_ind = m * 4.0 * corner(2.0, 2.0, 3.0);
    let lb = e_ind / std::f64::consts::PI;
    let d2 = r * r + h * h;
    let cos_g = h / d2.sqrt();
    let area = side * side;
    let (l, omega, p) = (i0 / area, area * cos_g / d2, 2.86);
    let ugr = 8.0 * (0.25 / lb * l * l * omega / (p * p)).log10();
    assert!(
        (o.indirect_illuminance / e_ind - 1.0).abs() < 0.005,
        "E_ind {} lx, by hand {e_ind:.3} lx",
        o.indirect_illuminance
    );
    assert_eq!(o.luminaires.len(), 1, "{o:?}");
    let t = &o.luminaires[0];
    assert!(
        (t.luminance / l - 1.0).abs() < 1e-3,
        "L {} vs {l}",
        t.luminance
    );
    assert!(
        (t.solid_angle / omega - 1.0).abs() < 1e-3,
        "ω {} vs {omega}",
        t.solid_angle
    );
    assert!(
        (t.position_index - p).abs() < 1e-9,
        "p {}",
        t.position_index
    );
    let got = o.ugr.unwrap();
    assert!((got - ugr).abs() < 0.05, "UGR {got:.3}, by hand {ugr:.3}");
    // Dimming the panel to 25 % lowers the rating by 8·log₁₀(16) (L² falls 16-fold; the
    // background here is the wall's alone).
    let mut dim = LightState::default();
    dim.lights.insert(
        "panel".into(),
        relight::model::LightSetting {
            intensity: 0.25,
            color: Rgb::ONE,
        },
    );
    let w = Lighting::Groups(model.weights(&dim).unwrap());
    let dimmed = model
        .glare(&[(eye, DVec3::Z)], &w, &Cancel::default())
        .unwrap();
    let drop = got - dimmed[0].ugr.unwrap();
    assert!((drop - 8.0 * 16f64.log10()).abs() < 1e-6, "{drop}");
    // Looking away, the panel is behind the eye: no source, no rating.
    let away = model
        .glare(&[(eye, -DVec3::Z)], &w, &Cancel::default())
        .unwrap();
    assert_eq!(away[0].ugr, None);
    assert_eq!(away[0].left_out[0].reason, "behind the eye");
}
