//! [`QueryError`]: why a query cannot be answered. Every variant is the asker's mistake
//! (or their leaving); the server turns them into 4xx problem documents.

use super::lighting::LightError;
use super::optimize::OptimizeError;

#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    /// An unknown light group or a bad intensity or colour.
    #[error(transparent)]
    Light(#[from] LightError),
    /// A per-patch emission on a scene baked without the factored transfer.
    #[error(
        "scene '{scene}' uses the {mode} transfer, which answers light groups only; per-patch \
         emission and luminaires placed per request need transfer = \"factored\", \
         \"hierarchical\" or \"auto\" in scene.toml"
    )]
    NeedsFactored { scene: String, mode: &'static str },
    /// Anything else the query names or sets wrongly, with a message saying what.
    #[error("{0}")]
    Invalid(String),
    /// Optimization targets that cannot be met.
    #[error(transparent)]
    Optimize(#[from] OptimizeError),
    /// The asker is gone (see [`super::Cancel`]).
    #[error("the request was abandoned")]
    Cancelled,
}

/// A client-given string as shown in messages: at most 200 characters, then `…`.
pub fn shorten(s: &str) -> String {
    const MAX: usize = 200;
    if s.chars().count() <= MAX {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(MAX).collect::<String>())
    }
}

/// Known ids as messages list them: comma-separated, or `none`.
pub fn known_list<'a>(ids: impl IntoIterator<Item = &'a str>) -> String {
    let ids: Vec<&str> = ids.into_iter().collect();
    if ids.is_empty() {
        "none".into()
    } else {
        ids.join(", ")
    }
}
