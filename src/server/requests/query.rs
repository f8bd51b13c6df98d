//! Query strings: the one reader of `render.png`, `report` and `export.glb`. A query is
//! read as a list of pairs, in order, so that a parameter given twice is refused (400), as
//! is an unknown one or a value that is not a number where one is expected; values out of
//! range are the conversions' 422s.

use std::collections::BTreeMap;

use super::lighting::{LightSetting, Lights, Triple};
use super::Choice;
use crate::model::lighting::parse_value;
use crate::server::json::FIELD;
use crate::server::parse::shorten;
use crate::server::AppError;

/// A query's parameters other than `light.<group>`, walked in order by [`read_query`].
pub(crate) struct Param<'q> {
    /// The parameter's name (an alias read as its canonical name: `w` as `width`).
    pub name: &'q str,
    /// The name as the client wrote it, for messages.
    pub written: &'q str,
    pub value: &'q str,
}

impl Param<'_> {
    /// The value as a number: 400 when it is not one.
    pub fn number(&self) -> Result<f64, AppError> {
        self.value.parse::<f64>().map_err(|_| {
            AppError::BadRequest(format!(
                "query parameter {}={}: not a number",
                shorten(self.written),
                shorten(self.value)
            ))
        })
    }

    /// The value as one of a [`Choice`]'s names: 422 for any other.
    pub fn choice<T: Choice>(&self) -> Result<T, AppError> {
        T::pick(self.value).ok_or_else(|| {
            AppError::Invalid(T::refuse(&shorten(self.value)).replacen(FIELD, self.name, 1))
        })
    }
}

/// Walks query `q` in order: each parameter at most once (`canonical` maps an alias to
/// its name; 400 for one given twice), `light.<group>=0.5` or `light.<group>=r,g,b` into
/// the lights it returns, any other parameter to `each`, which answers false for one it
/// does not know (400, listing `known`).
pub(crate) fn read_query<'q>(
    q: &'q [(String, String)],
    canonical: fn(&str) -> &str,
    known: &str,
    mut each: impl FnMut(Param<'q>) -> Result<bool, AppError>,
) -> Result<Lights, AppError> {
    let mut lights = BTreeMap::new();
    let mut seen: Vec<&str> = Vec::with_capacity(q.len());
    for (k, v) in q {
        let name = canonical(k);
        if seen.contains(&name) {
            return Err(given_twice(k));
        }
        seen.push(name);
        if let Some(group) = k.strip_prefix("light.") {
            lights.insert(group.to_string(), light(k, v)?);
            continue;
        }
        let param = Param {
            name,
            written: k,
            value: v,
        };
        if !each(param)? {
            return Err(AppError::BadRequest(format!(
                "unknown query parameter '{}' ({known})",
                shorten(k)
            )));
        }
    }
    Ok(Lights(lights))
}

/// Parameter names read as they are written.
pub(crate) fn as_written(k: &str) -> &str {
    k
}

/// The 400 for query parameter `k` given twice.
fn given_twice(k: &str) -> AppError {
    AppError::BadRequest(format!("query parameter '{}' is given twice", shorten(k)))
}

/// `light.ID=0.5` or `light.ID=r,g,b`, in the one text grammar of a setting (as on the
/// command line).
fn light(k: &str, v: &str) -> Result<LightSetting, AppError> {
    let bad = |e: String| {
        AppError::BadRequest(format!(
            "query parameter {}={}: {e}",
            shorten(k),
            shorten(v)
        ))
    };
    Ok(match parse_value(v).map_err(bad)? {
        (_, Some(c)) => LightSetting::colored(Triple(c)),
        (i, None) => LightSetting::Intensity(i.unwrap_or(1.0)),
    })
}
