//! Scenes over HTTP: `PUT /api/scenes/{id}` uploads a scene (a `.glb`, or a zip of a scene
//! folder) and bakes it in the background; `DELETE /api/scenes/{id}` removes an uploaded
//! scene and its cache entries.
//!
//! Writes need the admin token (`--admin-token`, `Authorization: Bearer …`); a server
//! without one, or a read-only one, answers 403. An upload is streamed to a hidden staging
//! folder under the scenes folder (`.upload-…`, never listed as a scene), unpacked there
//! ([`crate::scene::archive`]), loaded as a scene to check it, and only then renamed into
//! place: a failed upload leaves nothing behind, and a scene folder is never half-written.
//! The server's own scenes (folders without the upload marker) cannot be replaced or
//! deleted, and a scene cannot be replaced or deleted while it bakes (409).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use axum::body::Body;
use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use http_body_util::BodyExt;
use serde::Serialize;
use utoipa::ToSchema;

use crate::budget::human_bytes;
use crate::scene::archive::{self, ArchiveError};
use crate::scene::Scene;
use crate::server::json::essence;
use crate::server::openapi::{GlbModel, SceneIdParam, WriteErrors, ZipArchive};
use crate::server::parse::{shorten, SceneId};
use crate::server::state::{SceneSlot, UPLOAD_MARKER};
use crate::server::{AppError, AppState};

/// What the body of an upload is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Glb,
    Zip,
}

/// An accepted upload: it bakes in the background.
#[derive(Serialize, ToSchema)]
pub(crate) struct Accepted {
    id: String,
    #[schema(schema_with = queued)]
    status: &'static str,
    /// Files in the scene folder.
    files: usize,
    /// Bytes in the scene folder.
    bytes: u64,
    /// What loading fixed or left out, one line each (as `GET /api/scenes/{id}` lists).
    warnings: Vec<String>,
}

fn queued() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
    crate::schema::words(&["queued"])
}

/// Equal strings, compared in time independent of where they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The server state, for a request that carries the admin token: 403 when writes are
/// disabled, 401 without the right bearer token.
pub(crate) struct Admin(Arc<AppState>);

impl FromRequestParts<Arc<AppState>> for Admin {
    type Rejection = AppError;

    async fn from_request_parts(
        parts: &mut Parts,
        state: &Arc<AppState>,
    ) -> Result<Self, Self::Rejection> {
        authorize(state, &parts.headers)?;
        Ok(Admin(state.clone()))
    }
}

/// 403 when writes are disabled, 401 without the right bearer token.
fn authorize(state: &AppState, headers: &HeaderMap) -> Result<(), AppError> {
    let Some(token) = state.config.admin_token.as_deref() else {
        return Err(AppError::Forbidden(
            "scene uploads are disabled: start the server with --admin-token (or \
             RELIGHT_ADMIN_TOKEN) to allow them"
                .into(),
        ));
    };
    if state.config.read_only {
        return Err(AppError::Forbidden(
            "this server is read-only (--read-only): it does not store or bake scenes".into(),
        ));
    }
    let given = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| {
            let (scheme, rest) = v.split_once(' ')?;
            scheme.eq_ignore_ascii_case("bearer").then(|| rest.trim())
        });
    match given {
        None => Err(AppError::Unauthorized(
            "this request needs the admin token: send 'Authorization: Bearer <token>'".into(),
        )),
        Some(t) if same(t.as_bytes(), token.as_bytes()) => Ok(()),
        Some(_) => Err(AppError::Unauthorized("wrong admin token".into())),
    }
}

/// A scene id: 1 to 64 of `a-z`, `0-9` and `-`.
fn check_id(id: &str) -> Result<(), AppError> {
    let ok = (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-');
    if ok {
        Ok(())
    } else {
        Err(AppError::Invalid(format!(
            "scene id '{}': use 1 to 64 characters a-z, 0-9 and '-'",
            shorten(id)
        )))
    }
}

fn kind(headers: &HeaderMap) -> Result<Kind, AppError> {
    let ct = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    match essence(ct).as_str() {
        "model/gltf-binary" => Ok(Kind::Glb),
        "application/zip" | "application/x-zip-compressed" => Ok(Kind::Zip),
        _ => Err(AppError::UnsupportedMediaType(format!(
            "Content-Type '{}': send a .glb as model/gltf-binary or a zipped scene folder as \
             application/zip",
            shorten(ct)
        ))),
    }
}

/// 409 when `id` names one of the server's own scenes, or a scene that is baking.
fn check_replaceable(state: &AppState, id: &str) -> Result<(), AppError> {
    if let Ok(slot) = state.slot(id) {
        if !slot.uploaded {
            return Err(AppError::Conflict(format!(
                "scene '{id}' is one of the server's own scenes; it cannot be replaced or \
                 deleted over HTTP"
            )));
        }
        if slot.busy() {
            return Err(AppError::Conflict(format!(
                "scene '{id}' is {}; retry when it is ready or failed",
                slot.status().0
            )));
        }
    } else if state.config.scenes.join(id).exists() {
        return Err(AppError::Conflict(format!(
            "the scenes folder already holds '{id}', which is not an uploaded scene"
        )));
    }
    Ok(())
}

/// A fresh name for a hidden folder under the scenes folder.
fn hidden(state: &AppState, what: &str) -> PathBuf {
    static N: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    state.config.scenes.join(format!(
        ".{what}-{}-{nanos}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ))
}

/// A folder removed (with its contents) when dropped, unless kept.
struct Staging(Option<PathBuf>);

impl Drop for Staging {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}

fn io(what: &str, e: std::io::Error) -> AppError {
    AppError::Internal(format!("cannot {what}: {}", e.kind()))
}

/// Streams the body into `path`, refusing more than `limit` bytes (413).
async fn receive(body: Body, path: &Path, limit: u64) -> Result<u64, AppError> {
    use tokio::io::AsyncWriteExt;
    let mut file = tokio::fs::File::create(path)
        .await
        .map_err(|e| io("store the upload", e))?;
    let mut body = body;
    let mut n = 0u64;
    while let Some(frame) = body.frame().await {
        let frame =
            frame.map_err(|e| AppError::BadRequest(format!("the upload broke off: {e}")))?;
        let Ok(chunk) = frame.into_data() else {
            continue;
        };
        n += chunk.len() as u64;
        if n > limit {
            return Err(AppError::TooLarge(format!(
                "the upload exceeds the limit of {} (--upload-limit)",
                human_bytes(limit)
            )));
        }
        file.write_all(&chunk)
            .await
            .map_err(|e| io("store the upload", e))?;
    }
    file.sync_all()
        .await
        .map_err(|e| io("store the upload", e))?;
    Ok(n)
}

/// Unpacks the upload into `dir` (named after the scene id): the files' total size.
/// Streams from disk to disk; runs on the blocking pool.
fn unpack(kind: Kind, upload: &Path, dir: &Path, id: &str) -> Result<u64, AppError> {
    std::fs::create_dir(dir).map_err(|e| io("stage the scene", e))?;
    match kind {
        Kind::Glb => {
            let mut magic = [0u8; 4];
            use std::io::Read;
            let ok = std::fs::File::open(upload)
                .and_then(|mut f| f.read_exact(&mut magic))
                .is_ok()
                && &magic == b"glTF";
            if !ok {
                return Err(AppError::Invalid(
                    "the body is not a glTF binary (.glb): it does not start with 'glTF'".into(),
                ));
            }
            let to = dir.join(format!("{id}.glb"));
            std::fs::rename(upload, &to).map_err(|e| io("stage the scene", e))?;
            Ok(std::fs::metadata(&to).map(|m| m.len()).unwrap_or(0))
        }
        Kind::Zip => archive::unpack_zip(upload, dir)
            .map(|u| u.bytes)
            .map_err(|e| match e {
                ArchiveError::TooLarge(m) => AppError::TooLarge(m),
                ArchiveError::Invalid(m) => AppError::Invalid(format!("the archive: {m}")),
                ArchiveError::Io(e) => io("unpack the archive", e),
            }),
    }
}

/// Loads the unpacked scene in `dir` as a check, and marks it as uploaded.
fn check(kind: Kind, dir: &Path, id: &str) -> Result<Accepted, AppError> {
    let scene = Scene::load(dir).map_err(|e| AppError::Invalid(e.to_string()))?;
    let (mut files, mut bytes) = (0usize, 0u64);
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d)
            .map_err(|e| io("list the scene", e))?
            .flatten()
        {
            match e.metadata() {
                Ok(m) if m.is_dir() => stack.push(e.path()),
                Ok(m) => {
                    files += 1;
                    bytes += m.len();
                }
                Err(_) => {}
            }
        }
    }
    let marker = serde_json::json!({
        "uploaded": std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        "kind": match kind { Kind::Glb => "glb", Kind::Zip => "zip" },
        "bytes": bytes,
    });
    std::fs::write(dir.join(UPLOAD_MARKER), marker.to_string())
        .map_err(|e| io("stage the scene", e))?;
    Ok(Accepted {
        id: id.to_string(),
        status: "queued",
        files,
        bytes,
        warnings: scene.warnings,
    })
}

/// Drops everything derived from scene `id`: cache entries and cached views.
fn forget(state: &AppState, id: &str) {
    crate::bake::cache::remove_entries(&state.config.cache, id);
    state
        .views
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .forget_scene(id);
}

#[utoipa::path(put, path = "/api/scenes/{id}", operation_id = "putScene", tags = ["scenes"],
    summary = "Upload a scene: a glTF binary, or a zip of a scene folder (OBJ/MTL/textures/IES/scene.toml, or a .gltf with its files). It is checked (unpacked within limits, loaded as a scene) before it is stored, then baked in the background: poll GET /api/scenes/{id}. Replaces an earlier upload with this id. Needs the admin token.",
    params(SceneIdParam),
    request_body(content((GlbModel = "model/gltf-binary"), (ZipArchive = "application/zip")),
        description = "At most --upload-limit bytes (256 MiB by default). A zip may hold at most 1,000 entries unpacking to at most 1 GiB; entries are files and folders inside the scene folder (no links, no absolute or '..' paths)."),
    responses(
        (status = 202, description = "Stored; the scene is queued for its bake.", body = Accepted,
            headers(("Location" = String, description = "`/api/scenes/{id}`."))),
        WriteErrors,
    ),
    security(("admin_token" = [])))]
pub(crate) async fn put_scene(
    Admin(state): Admin,
    SceneId(id): SceneId,
    headers: HeaderMap,
    body: Body,
) -> Result<Response, AppError> {
    check_id(&id)?;
    let kind = kind(&headers)?;
    let limit = state.config.upload_limit;
    let declared = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok()?.parse::<u64>().ok());
    if declared.is_some_and(|n| n > limit) {
        return Err(AppError::TooLarge(format!(
            "the upload exceeds the limit of {} (--upload-limit)",
            human_bytes(limit)
        )));
    }
    check_replaceable(&state, &id)?;
    let root = hidden(&state, "upload");
    std::fs::create_dir(&root).map_err(|e| io("stage the upload", e))?;
    let staging = Staging(Some(root.clone()));
    let upload = root.join("upload.bin");
    let received = receive(body, &upload, limit).await?;
    if received == 0 {
        return Err(AppError::Invalid("the upload is empty".into()));
    }
    let dir = root.join(&id);
    let (d, i) = (dir.clone(), id.clone());
    let unpacked = tokio::task::spawn_blocking(move || unpack(kind, &upload, &d, &i))
        .await
        .map_err(|e| AppError::Internal(format!("unpacking stopped: {e}")))??;
    // Loading holds the model's text and its parsed form: about twice its files.
    let (d, i) = (dir.clone(), id.clone());
    let accepted = state
        .heavy(2 * unpacked + (16 << 20), "an upload's check", move |_| {
            check(kind, &d, &i)
        })
        .await?;

    // Into place, one write at a time.
    let _one = state.write_lock.lock().await;
    check_replaceable(&state, &id)?;
    let dest = state.config.scenes.join(&id);
    let trash = hidden(&state, "trash");
    if dest.exists() {
        std::fs::rename(&dest, &trash).map_err(|e| io("replace the scene", e))?;
    }
    std::fs::rename(&dir, &dest).map_err(|e| io("store the scene", e))?;
    drop(staging);
    forget(&state, &id);
    let slot = Arc::new(SceneSlot::new(dest));
    state.put_slot(slot.clone());
    state.spawn_bake(slot);
    let _ = tokio::task::spawn_blocking(move || std::fs::remove_dir_all(trash)).await;
    tracing::info!(scene = %id, files = accepted.files, bytes = accepted.bytes, "scene uploaded");
    let mut resp = (StatusCode::ACCEPTED, Json(accepted)).into_response();
    if let Ok(v) = format!("/api/scenes/{id}").parse() {
        resp.headers_mut().insert(header::LOCATION, v);
    }
    Ok(resp)
}

#[utoipa::path(delete, path = "/api/scenes/{id}", operation_id = "deleteScene", tags = ["scenes"],
    summary = "Delete an uploaded scene, its folder and its cache entries. The server's own scenes cannot be deleted, nor a scene while it bakes. Needs the admin token.",
    params(SceneIdParam),
    responses(
        (status = 204, description = "Deleted."),
        WriteErrors,
    ),
    security(("admin_token" = [])))]
pub(crate) async fn delete_scene(
    Admin(state): Admin,
    SceneId(id): SceneId,
) -> Result<Response, AppError> {
    let _one = state.write_lock.lock().await;
    let slot = state.slot(&id)?;
    check_replaceable(&state, &id)?;
    let trash = hidden(&state, "trash");
    std::fs::rename(&slot.dir, &trash).map_err(|e| io("delete the scene", e))?;
    state.remove_slot(&id);
    forget(&state, &id);
    let _ = tokio::task::spawn_blocking(move || std::fs::remove_dir_all(trash)).await;
    tracing::info!(scene = %id, "scene deleted");
    Ok(StatusCode::NO_CONTENT.into_response())
}

#[cfg(test)]
mod tests {
    use super::{check_id, same};

    #[test]
    fn ids_and_tokens() {
        assert!(check_id("my-scene-2").is_ok());
        for bad in ["", "A", "a b", "a/b", "..", "é", &"x".repeat(65)] {
            assert!(check_id(bad).is_err(), "{bad}");
        }
        assert!(same(b"secret-token", b"secret-token"));
        assert!(!same(b"secret-token", b"secret-tokem"));
        assert!(!same(b"secret", b"secret-token"));
    }
}
