//! The scene folder on disk: where references may point, and bounded reads.
//!
//! Rules (see the `src/scene/` entry of `ARCHITECTURE.md`):
//! - Every file a scene references (the OBJ, `scene.toml`, `mtllib`, `ies`) must resolve,
//!   after canonicalization with symlinks followed, to a path inside the scene folder.
//! - Only regular files are read. A FIFO, a device or a directory is refused from its
//!   metadata, taken from the opened handle (opened non-blocking, so a FIFO never blocks).
//! - Each kind of file has a size limit ([`crate::input_limits`]); reads stop at limit + 1 bytes,
//!   so a file that grows while it is read is refused too.
//! - Error messages name files relative to the scene folder, prefixed by the scene id
//!   (`office/office.mtl:12: …`): no absolute server path leaks into an HTTP answer.

use std::io::Read;
use std::path::{Path, PathBuf};

use super::SceneError;

/// The model file of a scene folder.
#[derive(Debug, Clone)]
pub(crate) enum ModelFile {
    Obj(PathBuf),
    /// `.gltf` or `.glb`.
    Gltf(PathBuf),
}

/// A scene folder: its canonical root and the label errors use for it.
#[derive(Debug, Clone)]
pub(crate) struct SceneDir {
    /// Canonical path of the folder (symlinks resolved).
    pub root: PathBuf,
    /// The scene id (folder name), the prefix of every path in an error message.
    pub label: String,
}

impl SceneDir {
    /// Opens the folder `dir`: it must exist and be a directory.
    pub fn open(dir: &Path) -> Result<SceneDir, SceneError> {
        let given_label = dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty() && s != "." && s != "..");
        let fallback = given_label.clone().unwrap_or_else(|| "scene".into());
        let root = std::fs::canonicalize(dir).map_err(|source| {
            if source.kind() == std::io::ErrorKind::NotFound {
                SceneError::Invalid {
                    path: PathBuf::from(&fallback),
                    message: "scene folder not found".into(),
                }
            } else {
                SceneError::Io {
                    path: PathBuf::from(&fallback),
                    source,
                }
            }
        })?;
        let label = given_label
            .or_else(|| root.file_name().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "scene".into());
        let meta = std::fs::metadata(&root).map_err(|source| SceneError::Io {
            path: PathBuf::from(&label),
            source,
        })?;
        if !meta.is_dir() {
            return Err(SceneError::Invalid {
                path: PathBuf::from(&label),
                message: "not a directory".into(),
            });
        }
        Ok(SceneDir { root, label })
    }

    /// The name errors use for a file inside the folder: `<scene id>/<relative path>`.
    pub fn display(&self, file: &Path) -> PathBuf {
        let rel = file.strip_prefix(&self.root).unwrap_or_else(|_| {
            // Never print a path outside the folder: fall back to its file name.
            file.file_name().map_or(Path::new("?"), Path::new)
        });
        Path::new(&self.label).join(rel)
    }

    /// The name errors use for the folder itself.
    pub fn display_root(&self) -> PathBuf {
        PathBuf::from(&self.label)
    }

    /// Resolves `name`, referenced by `what` on line `line` of `referrer` (a display path),
    /// to a canonical path inside the folder.
    pub fn resolve(
        &self,
        name: &str,
        referrer: &Path,
        line: usize,
        what: &str,
    ) -> Result<PathBuf, SceneError> {
        let refused = |problem: String| SceneError::Reference {
            path: referrer.to_path_buf(),
            line,
            what: what.to_string(),
            name: name.to_string(),
            problem,
        };
        if name.is_empty() {
            return Err(refused("is empty".into()));
        }
        if name.contains('\0') {
            return Err(refused("contains a NUL byte".into()));
        }
        let candidate = self.root.join(name);
        let canon = match std::fs::canonicalize(&candidate) {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                // Say "outside" rather than "not found" for paths that leave the folder,
                // so the error does not reveal what exists elsewhere on the server.
                if Path::new(name).is_absolute()
                    || Path::new(name)
                        .components()
                        .any(|c| matches!(c, std::path::Component::ParentDir))
                {
                    return Err(refused("is outside the scene folder".into()));
                }
                return Err(refused("not found in the scene folder".into()));
            }
            Err(e) => return Err(refused(format!("cannot be resolved ({})", e.kind()))),
        };
        if !canon.starts_with(&self.root) || canon == self.root {
            return Err(refused(
                "is outside the scene folder (files must resolve inside it, symlinks included)"
                    .into(),
            ));
        }
        Ok(canon)
    }

    /// Like [`SceneDir::resolve`], but a file that is simply not there (a plain relative
    /// name, nothing in the way) is `None`, for lenient loads. A name that leaves the
    /// folder is still an error.
    pub fn resolve_lenient(
        &self,
        name: &str,
        referrer: &Path,
        line: usize,
        what: &str,
    ) -> Result<Option<PathBuf>, SceneError> {
        let plain = !name.is_empty()
            && !name.contains('\0')
            && !Path::new(name).is_absolute()
            && Path::new(name).components().all(|c| {
                matches!(
                    c,
                    std::path::Component::Normal(_) | std::path::Component::CurDir
                )
            });
        if plain {
            if let Err(e) = std::fs::symlink_metadata(self.root.join(name)) {
                if e.kind() == std::io::ErrorKind::NotFound {
                    return Ok(None);
                }
            }
        }
        self.resolve(name, referrer, line, what).map(Some)
    }

    /// Reads the regular file at canonical path `path` (inside the folder), refusing
    /// anything larger than `limit` bytes.
    pub fn read(&self, path: &Path, limit: u64) -> Result<Vec<u8>, SceneError> {
        let shown = self.display(path);
        if !path.starts_with(&self.root) {
            return Err(SceneError::Invalid {
                path: shown,
                message: "is outside the scene folder".into(),
            });
        }
        read_bounded(path, limit).map_err(|e| match e {
            ReadError::Io(source) => SceneError::Io {
                path: shown,
                source,
            },
            ReadError::NotRegular(kind) => SceneError::Invalid {
                path: shown,
                message: format!("not a regular file ({kind}); only regular files are read"),
            },
            ReadError::TooLarge(size) => SceneError::Invalid {
                path: shown,
                message: format!(
                    "{} is larger than the limit of {} for this kind of file",
                    size.map_or_else(|| "the file".to_string(), |s| format!("{s} bytes")),
                    human_bytes(limit)
                ),
            },
        })
    }
}

/// Why a bounded read failed.
pub(crate) enum ReadError {
    Io(std::io::Error),
    NotRegular(&'static str),
    /// The size, when known from the metadata (None: the file grew while being read).
    TooLarge(Option<u64>),
}

/// Opens `path` without blocking (a FIFO would otherwise wait for a writer) and without
/// following a final symlink.
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK | libc::O_NOFOLLOW);
    }
    o.open(path)
}

fn kind_of(ft: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO";
        }
        if ft.is_char_device() || ft.is_block_device() {
            return "a device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        "a directory"
    } else if ft.is_symlink() {
        "a symlink"
    } else {
        "not a plain file"
    }
}

/// Reads a regular file of at most `limit` bytes. The type and size come from the opened
/// handle; the read itself stops after `limit + 1` bytes.
pub(crate) fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    let file = open_nonblocking(path).map_err(ReadError::Io)?;
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind_of(meta.file_type())));
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge(Some(meta.len())));
    }
    let mut buf = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1)
        .read_to_end(&mut buf)
        .map_err(ReadError::Io)?;
    if buf.len() as u64 > limit {
        return Err(ReadError::TooLarge(None));
    }
    Ok(buf)
}

/// Bytes as text: UTF-8 (a leading byte-order mark is dropped), or an error naming the line
/// of the first invalid byte.
pub(crate) fn to_text(path: &Path, bytes: Vec<u8>) -> Result<String, SceneError> {
    let bytes = match bytes.strip_prefix(b"\xEF\xBB\xBF") {
        Some(rest) => rest.to_vec(),
        None => bytes,
    };
    match String::from_utf8(bytes) {
        Ok(s) => Ok(s),
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let b = e.as_bytes();
            let line = 1 + b[..at].iter().filter(|&&c| c == b'\n').count();
            Err(SceneError::Syntax {
                path: path.to_path_buf(),
                line,
                message: format!("not UTF-8 text (byte 0x{:02x})", b[at]),
            })
        }
    }
}

/// "16 MiB", "256 MiB", "512 KiB", "100 bytes".
pub(crate) fn human_bytes(n: u64) -> String {
    if n >= 1 << 20 && n.is_multiple_of(1 << 20) {
        format!("{} MiB", n >> 20)
    } else if n >= 1 << 10 && n.is_multiple_of(1 << 10) {
        format!("{} KiB", n >> 10)
    } else {
        format!("{n} bytes")
    }
}

impl SceneDir {
    /// The folder's one model file (`.obj`, `.gltf` or `.glb`), canonicalized (it must
    /// resolve inside the folder).
    pub fn find_model(&self) -> Result<ModelFile, SceneError> {
        let root = self.display_root();
        let is_model = |p: &Path| {
            p.extension().is_some_and(|e| {
                ["obj", "gltf", "glb"]
                    .iter()
                    .any(|m| e.eq_ignore_ascii_case(m))
            })
        };
        let mut models: Vec<PathBuf> = std::fs::read_dir(&self.root)
            .map_err(|source| SceneError::Io {
                path: root.clone(),
                source,
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| is_model(p))
            .collect();
        models.sort();
        match models.len() {
            0 => Err(SceneError::NoObj(root)),
            1 => {
                let p = self.resolve_own(&models[0])?;
                let obj = models[0]
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
                Ok(if obj {
                    ModelFile::Obj(p)
                } else {
                    ModelFile::Gltf(p)
                })
            }
            _ => Err(SceneError::ManyObj {
                dir: root,
                files: models
                    .iter()
                    .map(|p| {
                        p.file_name()
                            .unwrap_or_default()
                            .to_string_lossy()
                            .into_owned()
                    })
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }

    /// Canonicalizes `path`, a file found by listing the folder (the OBJ, `scene.toml`): it
    /// must resolve inside the folder.
    pub fn resolve_own(&self, path: &Path) -> Result<PathBuf, SceneError> {
        let shown = self.display(path);
        let canon = std::fs::canonicalize(path).map_err(|source| SceneError::Io {
            path: shown.clone(),
            source,
        })?;
        if !canon.starts_with(&self.root) || canon == self.root {
            return Err(SceneError::Invalid {
                path: shown,
                message: "resolves to outside the scene folder (a symlink?); \
                          files must resolve inside it"
                    .into(),
            });
        }
        Ok(canon)
    }
}

/// Reads a regular file of at most `limit` bytes, as [`SceneDir::read`] does, with plain
/// I/O errors (for the cache key, which re-reads the scene's files).
pub(crate) fn read_regular_file(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    read_bounded(path, limit).map_err(|e| match e {
        ReadError::Io(e) => e,
        ReadError::NotRegular(kind) => {
            std::io::Error::other(format!("not a regular file ({kind})"))
        }
        ReadError::TooLarge(_) => {
            std::io::Error::other(format!("larger than the limit of {}", human_bytes(limit)))
        }
    })
}
