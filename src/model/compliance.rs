//! Maintained values and compliance with EN 12464-1 requirements.
//!
//! **Maintenance factor.** A light group's maintenance factor MF (CIE 97: lamp lumen
//! maintenance × lamp survival × luminaire maintenance × room surface maintenance) scales
//! what the group gives after the maintenance interval: maintained = MF × initial. Light is
//! linear in the group weights, so maintained answers are the same queries under the weights
//! `MF_g · w_g` ([`maintained_weights`]). Each group takes its own MF from `scene.toml`, else
//! the scene's (default 1); a request may override either.
//!
//! **Compliance.** A grid may carry [`Requirements`]: the least maintained average
//! illuminance Ēm, the least uniformity U₀ = Emin / Eavg (both of the maintained values),
//! the highest UGR (UGR_L), and the least colour rendering index Ra of the lamps that
//! light it. [`check`] answers each with the achieved value, pass or fail, and the margin
//! (positive when it passes). The UGR of an area is the highest of its [`task_observers`]
//! under the initial state (the installation new, its brightest: the conservative
//! choice), by [`crate::photometry::glare`].

use glam::DVec3;
use serde::Serialize;

use crate::color::Rgb;
use crate::scene::{Grid, Requirements, Scene};

/// Weights `w` with each group's maintenance factor applied.
pub fn maintained_weights(w: &[Rgb], mf: &[f64]) -> Vec<Rgb> {
    w.iter()
        .zip(mf)
        .map(|(wg, &m)| (wg.to_f64() * m).to_f32())
        .collect()
}

/// The scene's maintenance factors, one per light group.
pub fn scene_factors(scene: &Scene) -> Vec<f64> {
    scene.lights.iter().map(|g| g.maintenance_factor).collect()
}

/// One requirement's answer.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Check {
    /// `em`, `u0`, `ugr_l` or `ra`.
    pub requirement: &'static str,
    /// `lx` for Ēm; empty for the ratios and indices.
    pub unit: &'static str,
    /// The required value: a least value, or for `ugr_l` the highest allowed.
    pub required: f64,
    /// What the lighting state achieves; null when it cannot be known (see `note`).
    #[cfg_attr(feature = "server", schema(required = true))]
    pub achieved: Option<f64>,
    pub pass: bool,
    /// How far inside the requirement the achieved value is (achieved − required, or
    /// required − achieved for `ugr_l`): positive when it passes, negative when it fails.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub margin: Option<f64>,
    /// Why a value is missing or how it was found.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub note: Option<String>,
}

/// The UGR at one observer of a task area.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct ObserverUgr {
    /// Eye position, m.
    pub eye: [f64; 3],
    /// Unit direction of view.
    pub direction: [f64; 3],
    /// UGR; null when no luminaire is in view (no discomfort glare to rate).
    #[cfg_attr(feature = "server", schema(required = true))]
    pub ugr: Option<f64>,
}

/// A grid's requirements answered.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Compliance {
    /// Every requirement passes.
    pub pass: bool,
    pub checks: Vec<Check>,
    /// The observers the UGR was rated at (empty without a UGR_L requirement).
    pub observers: Vec<ObserverUgr>,
}

/// What a grid achieves, for [`check`].
#[derive(Debug, Clone)]
pub struct Achieved {
    /// Maintained Eavg and U₀; None without a value (no measured point).
    pub em: Option<f64>,
    pub u0: Option<f64>,
    /// UGR at each task observer; None when they could not be rated (a per-patch emission).
    pub observers: Option<Vec<ObserverUgr>>,
    /// The lowest Ra of the lit groups: Ok(None) when nothing is lit, Err(ids) naming lit
    /// groups without an Ra.
    pub ra: Result<Option<f64>, Vec<String>>,
}

/// Answers requirements `r` from what is `achieved`.
pub fn check(r: &Requirements, achieved: &Achieved) -> Compliance {
    let mut checks = Vec::new();
    let at_least = |requirement, unit, required: f64, got: Option<f64>, note| {
        let margin = got.map(|g| g - required);
        Check {
            requirement,
            unit,
            required,
            achieved: got,
            pass: margin.is_some_and(|m| m >= 0.0),
            margin,
            note,
        }
    };
    if let Some(em) = r.em {
        checks.push(at_least("em", "lx", em, achieved.em, None));
    }
    if let Some(u0) = r.u0 {
        checks.push(at_least("u0", "", u0, achieved.u0, None));
    }
    if let Some(limit) = r.ugr_l {
        checks.push(ugr_check(limit, achieved.observers.as_deref()));
    }
    if let Some(ra) = r.ra {
        let (got, note) = match &achieved.ra {
            Ok(Some(v)) => (Some(*v), None),
            Ok(None) => (None, Some("no light group is lit".to_string())),
            Err(ids) => (
                None,
                Some(format!(
                    "no Ra given for the lit group(s) {} (set `ra` in scene.toml)",
                    ids.join(", ")
                )),
            ),
        };
        checks.push(at_least("ra", "", ra, got, note));
    }
    Compliance {
        pass: checks.iter().all(|c| c.pass),
        checks,
        observers: achieved.observers.clone().unwrap_or_default(),
    }
}

/// The UGR_L check over the observers' ratings.
fn ugr_check(limit: f64, observers: Option<&[ObserverUgr]>) -> Check {
    let Some(obs) = observers else {
        return Check {
            requirement: "ugr_l",
            unit: "",
            required: limit,
            achieved: None,
            pass: false,
            margin: None,
            note: Some("UGR needs a lighting state of light groups".into()),
        };
    };
    let worst = highest(obs);
    match worst {
        Some(u) => Check {
            requirement: "ugr_l",
            unit: "",
            required: limit,
            achieved: Some(u),
            pass: u <= limit,
            margin: Some(limit - u),
            note: Some(format!("the highest of {} observers", obs.len())),
        },
        // No luminaire in view of any observer: nothing to glare.
        None => Check {
            requirement: "ugr_l",
            unit: "",
            required: limit,
            achieved: None,
            pass: true,
            margin: None,
            note: Some("no lit luminaire in view of any observer".into()),
        },
    }
}

/// The highest UGR of `observers`; None when none has a luminaire in view.
pub fn highest(observers: &[ObserverUgr]) -> Option<f64> {
    observers
        .iter()
        .filter_map(|o| o.ugr)
        .fold(None, |m: Option<f64>, u| Some(m.map_or(u, |m| m.max(u))))
}

/// The observers that rate a task area's glare: seated eyes (1.2 m above the floor) at the
/// middle of each edge of the area's bounding rectangle, looking horizontally across it
/// towards its centre. Eye positions, m, and unit directions.
pub fn task_observers(grid: &Grid) -> Vec<(DVec3, DVec3)> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &grid.points {
        for (k, v) in [p[0], p[2]].into_iter().enumerate() {
            lo[k] = lo[k].min(v);
            hi[k] = hi[k].max(v);
        }
    }
    if !lo[0].is_finite() {
        return vec![];
    }
    let y = grid.floor + super::glare::SEATED_EYE_HEIGHT;
    let (cx, cz) = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    // An area without extent in a direction: observers half a metre out.
    let half = |k: usize| ((hi[k] - lo[k]) / 2.0).max(0.5);
    let (hx, hz) = (half(0), half(1));
    [
        (DVec3::new(cx - hx, y, cz), DVec3::X),
        (DVec3::new(cx + hx, y, cz), DVec3::new(-1.0, 0.0, 0.0)),
        (DVec3::new(cx, y, cz - hz), DVec3::Z),
        (DVec3::new(cx, y, cz + hz), DVec3::new(0.0, 0.0, -1.0)),
    ]
    .to_vec()
}

/// The lowest Ra of the groups lit by weights `w`: Ok(None) when none is lit, Err with
/// the lit groups that give no Ra.
pub fn lit_ra(scene: &Scene, w: &[Rgb]) -> Result<Option<f64>, Vec<String>> {
    let lit = scene
        .lights
        .iter()
        .zip(w)
        .filter(|(_, wg)| wg.iter().any(|&c| c > 0.0));
    let mut lowest: Option<f64> = None;
    let mut unknown = Vec::new();
    for (g, _) in lit {
        match g.ra {
            Some(ra) => lowest = Some(lowest.map_or(ra, |l| l.min(ra))),
            None => unknown.push(g.id.clone()),
        }
    }
    if unknown.is_empty() {
        Ok(lowest)
    } else {
        Err(unknown)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(ugr: Option<f64>) -> ObserverUgr {
        ObserverUgr {
            eye: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            ugr,
        }
    }

    #[test]
    fn each_requirement_passes_or_fails_with_its_signed_margin() {
        let r = Requirements {
            em: Some(500.0),
            u0: Some(0.6),
            ugr_l: Some(19.0),
            ra: Some(80.0),
        };
        let a = Achieved {
            em: Some(520.0),
            u0: Some(0.55),
            observers: Some(vec![obs(Some(17.5)), obs(Some(19.4)), obs(None)]),
            ra: Ok(Some(85.0)),
        };
        let c = check(&r, &a);
        let by = |k: &str| c.checks.iter().find(|x| x.requirement == k).unwrap();
        assert!(by("em").pass && (by("em").margin.unwrap() - 20.0).abs() < 1e-12);
        assert!(!by("u0").pass && (by("u0").margin.unwrap() + 0.05).abs() < 1e-12);
        // UGR_L is an upper limit over the worst observer: 19.4 > 19 fails by 0.4.
        assert_eq!(by("ugr_l").achieved, Some(19.4));
        assert!(!by("ugr_l").pass && (by("ugr_l").margin.unwrap() + 0.4).abs() < 1e-12);
        assert!(by("ra").pass && by("ra").margin == Some(5.0));
        assert!(!c.pass);
        assert_eq!(c.observers.len(), 3);
    }

    #[test]
    fn unknown_values_fail_except_glare_with_no_luminaire_in_view() {
        let r = Requirements {
            em: Some(300.0),
            ugr_l: Some(19.0),
            ra: Some(80.0),
            ..Default::default()
        };
        let a = Achieved {
            em: None,
            u0: None,
            observers: Some(vec![obs(None)]),
            ra: Err(vec!["panels".into()]),
        };
        let c = check(&r, &a);
        assert!(!c.checks[0].pass && c.checks[0].achieved.is_none());
        assert!(c.checks[1].pass, "no luminaire in view: nothing glares");
        assert!(!c.checks[2].pass && c.checks[2].note.as_ref().unwrap().contains("panels"));
        // Without group weights, UGR cannot be rated: it fails, saying why.
        let c = check(
            &r,
            &Achieved {
                em: None,
                u0: None,
                observers: None,
                ra: Ok(Some(90.0)),
            },
        );
        assert!(!c.checks[1].pass && c.checks[1].note.is_some());
    }

    #[test]
    fn maintained_weights_scale_each_group_by_its_factor() {
        let w = maintained_weights(&[Rgb::new(1.0, 2.0, 3.0), Rgb::splat(4.0)], &[0.5, 0.8]);
        assert_eq!(w, vec![[0.5, 1.0, 1.5], [3.2; 3]]);
    }
}
