//! A scene folder from an uploaded zip archive, unpacked without trusting it.
//!
//! - Entries are files and folders only: symbolic links (and other special files) are
//!   refused, and so are names that are absolute (`/x`, `\x`, `C:x`), that climb (`..`)
//!   or that hold NUL. `\` separates folders like `/` (archives made on Windows).
//! - At most [`MAX_ARCHIVE_ENTRIES`] entries (counted from the end-of-central-directory
//!   record before the archive is parsed) and [`MAX_ARCHIVE_UNPACKED`] bytes unpacked in
//!   all, counted as the bytes come out, whatever the headers declare: a zip bomb stops
//!   at the limit ([`ArchiveError::TooLarge`]).
//! - One folder around everything (a zipped scene folder) is unwrapped; macOS metadata
//!   (`__MACOSX/`, `.DS_Store`) is skipped.
//! - Files are created new (an entry named twice is an error) inside `dest`, which the
//!   caller removes when anything fails.

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use crate::input_limits::{MAX_ARCHIVE_ENTRIES, MAX_ARCHIVE_UNPACKED};

/// Deepest folder nesting inside an archive.
const MAX_DEPTH: usize = 16;

#[derive(Debug, thiserror::Error)]
pub enum ArchiveError {
    /// Over a size or count limit (HTTP 413).
    #[error("{0}")]
    TooLarge(String),
    /// Not a usable archive (HTTP 422).
    #[error("{0}")]
    Invalid(String),
    /// The server could not write (HTTP 500).
    #[error("cannot write the unpacked scene: {0}")]
    Io(#[from] std::io::Error),
}

/// What was unpacked.
#[derive(Debug, Clone, Copy)]
pub struct Unpacked {
    pub files: usize,
    pub bytes: u64,
}

/// The entry count in the end-of-central-directory record, read before the archive is
/// parsed (so that a directory of millions of entries is refused before it is read).
/// `None` when there is no such record (not a zip file).
fn declared_entries(f: &mut std::fs::File) -> std::io::Result<Option<u64>> {
    let len = f.seek(SeekFrom::End(0))?;
    let tail = len.min(22 + 65_535);
    f.seek(SeekFrom::Start(len - tail))?;
    let mut buf = vec![0u8; tail as usize];
    f.read_exact(&mut buf)?;
    f.seek(SeekFrom::Start(0))?;
    // The record is 22 bytes plus a comment of at most 64 KiB; search from the end.
    let found = (0..buf.len().saturating_sub(21))
        .rev()
        .find(|&i| buf[i..i + 4] == [0x50, 0x4b, 0x05, 0x06]);
    Ok(found.map(|i| {
        let total = u16::from_le_bytes([buf[i + 10], buf[i + 11]]);
        // 0xFFFF: the real count is in a zip64 record, so it is over any limit of ours.
        if total == u16::MAX {
            u64::MAX
        } else {
            total as u64
        }
    }))
}

/// The relative path of an entry name, or why it is refused; None for entries skipped.
fn entry_path(name: &str) -> Result<Option<Vec<String>>, String> {
    if name.contains('\0') {
        return Err("holds a NUL character".into());
    }
    if name.starts_with('/') || name.starts_with('\\') {
        return Err("is an absolute path".into());
    }
    let b = name.as_bytes();
    if b.len() >= 2 && b[1] == b':' && b[0].is_ascii_alphabetic() {
        return Err("starts with a drive letter".into());
    }
    let mut parts = Vec::new();
    for c in name.split(['/', '\\']) {
        match c {
            "" | "." => {}
            ".." => return Err("climbs out of the folder ('..')".into()),
            c => parts.push(c.to_string()),
        }
    }
    if parts.first().is_some_and(|p| p == "__MACOSX")
        || parts.last().is_some_and(|p| p == ".DS_Store")
    {
        return Ok(None);
    }
    if parts.len() > MAX_DEPTH {
        return Err(format!("is nested deeper than {MAX_DEPTH} folders"));
    }
    if parts.iter().any(|p| p.len() > 255) {
        return Err("has a name longer than 255 bytes".into());
    }
    Ok(Some(parts))
}

/// An entry to unpack: its index in the archive, its path parts and whether it is a folder.
struct Entry {
    index: usize,
    parts: Vec<String>,
    is_dir: bool,
}

/// Unpacks the zip file at `zip` into the existing, empty folder `dest`.
pub fn unpack_zip(zip: &Path, dest: &Path) -> Result<Unpacked, ArchiveError> {
    let mut archive = open_archive(zip)?;
    let entries = list_entries(&mut archive)?;
    let strip = wrapping_folder(&entries);
    // Second pass: unpack, counting the bytes that really come out.
    let mut out = Unpacked { files: 0, bytes: 0 };
    for entry in entries {
        let rel: PathBuf = entry.parts[strip..].iter().collect();
        if rel.as_os_str().is_empty() {
            continue;
        }
        let path = dest.join(&rel);
        if entry.is_dir {
            std::fs::create_dir_all(&path)?;
            continue;
        }
        let room = MAX_ARCHIVE_UNPACKED - out.bytes;
        out.bytes += unpack_file(&mut archive, entry.index, &rel, &path, room)?;
        out.files += 1;
    }
    if out.files == 0 {
        return Err(ArchiveError::Invalid("the archive holds no files".into()));
    }
    Ok(out)
}

/// The archive at `zip`, once its entry count (declared and parsed) is within the limit.
fn open_archive(zip: &Path) -> Result<zip::ZipArchive<std::fs::File>, ArchiveError> {
    let mut f = std::fs::File::open(zip)?;
    match declared_entries(&mut f)? {
        None => {
            return Err(ArchiveError::Invalid(
                "not a zip archive (no end-of-central-directory record)".into(),
            ))
        }
        Some(n) if n > MAX_ARCHIVE_ENTRIES as u64 => return Err(too_many_entries()),
        Some(_) => {}
    }
    let archive = zip::ZipArchive::new(f)
        .map_err(|e| ArchiveError::Invalid(format!("not a readable zip archive: {e}")))?;
    if archive.len() > MAX_ARCHIVE_ENTRIES {
        return Err(too_many_entries());
    }
    Ok(archive)
}

fn too_many_entries() -> ArchiveError {
    ArchiveError::TooLarge(format!(
        "the archive has more than {MAX_ARCHIVE_ENTRIES} entries"
    ))
}

/// First pass, on the headers: names, kinds, declared sizes. The entries to unpack, in
/// archive order (skipped ones and the root itself left out).
fn list_entries(archive: &mut zip::ZipArchive<std::fs::File>) -> Result<Vec<Entry>, ArchiveError> {
    let mut entries = Vec::new();
    let mut declared = 0u64;
    for i in 0..archive.len() {
        let e = archive
            .by_index_raw(i)
            .map_err(|e| ArchiveError::Invalid(format!("entry {i}: {e}")))?;
        let name = e.name().to_string();
        let shown: String = name.chars().take(120).collect();
        let parts = match entry_path(&name) {
            Ok(Some(p)) => p,
            Ok(None) => continue,
            Err(why) => return Err(ArchiveError::Invalid(format!("entry '{shown}' {why}"))),
        };
        if e.is_symlink() {
            return Err(ArchiveError::Invalid(format!(
                "entry '{shown}' is a symbolic link; an archive may hold only files and folders"
            )));
        }
        let is_dir = e.is_dir();
        if !is_dir {
            check_file_entry(&e, &shown)?;
            declared = declared.saturating_add(e.size());
            if declared > MAX_ARCHIVE_UNPACKED {
                return Err(ArchiveError::TooLarge(too_large()));
            }
        }
        if !parts.is_empty() {
            entries.push(Entry {
                index: i,
                parts,
                is_dir,
            });
        }
    }
    Ok(entries)
}

/// Refuses a file entry that is not a plain, readable file.
fn check_file_entry(
    e: &zip::read::ZipFile<'_, std::fs::File>,
    shown: &str,
) -> Result<(), ArchiveError> {
    if let Some(mode) = e.unix_mode() {
        // Anything but a regular file (a FIFO, a device, a socket).
        if mode & 0o170000 != 0 && mode & 0o170000 != 0o100000 {
            return Err(ArchiveError::Invalid(format!(
                "entry '{shown}' is not a regular file"
            )));
        }
    }
    if e.encrypted() {
        return Err(ArchiveError::Invalid(format!(
            "entry '{shown}' is encrypted"
        )));
    }
    Ok(())
}

/// How many leading path parts to strip: 1 when one folder is around everything (that
/// folder is the scene folder itself: unwrap it), else 0.
fn wrapping_folder(entries: &[Entry]) -> usize {
    match entries.first() {
        Some(first)
            if entries.iter().all(|e| {
                let p = &e.parts;
                p.len() >= 2 && p[0] == first.parts[0]
                    || (e.is_dir && p.len() == 1 && p[0] == first.parts[0])
            }) =>
        {
            1
        }
        _ => 0,
    }
}

/// Writes entry `index` to the new file `path` (`rel` in messages), at most `room` bytes;
/// the bytes written.
fn unpack_file(
    archive: &mut zip::ZipArchive<std::fs::File>,
    index: usize,
    rel: &Path,
    path: &Path,
    room: u64,
) -> Result<u64, ArchiveError> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    let mut file = match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
    {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            return Err(ArchiveError::Invalid(format!(
                "entry '{}' appears twice (or as a file and a folder)",
                rel.display()
            )))
        }
        Err(e) => return Err(e.into()),
    };
    let mut entry = archive
        .by_index(index)
        .map_err(|e| ArchiveError::Invalid(format!("entry '{}': {e}", rel.display())))?;
    let n = std::io::copy(&mut (&mut entry).take(room + 1), &mut file).map_err(|e| {
        if e.kind() == std::io::ErrorKind::InvalidData
            || e.kind() == std::io::ErrorKind::UnexpectedEof
        {
            ArchiveError::Invalid(format!("entry '{}' is corrupt: {e}", rel.display()))
        } else {
            ArchiveError::Io(e)
        }
    })?;
    if n > room {
        return Err(ArchiveError::TooLarge(too_large()));
    }
    Ok(n)
}

fn too_large() -> String {
    format!(
        "the archive unpacks to more than {}",
        super::files::human_bytes(MAX_ARCHIVE_UNPACKED)
    )
}

#[cfg(test)]
mod tests {
    use super::entry_path;

    #[test]
    fn entry_names_are_confined() {
        let ok = |n: &str| entry_path(n).unwrap().unwrap().join("/");
        assert_eq!(ok("scene/a.obj"), "scene/a.obj");
        assert_eq!(ok("scene\\tex\\wood.png"), "scene/tex/wood.png");
        assert_eq!(ok("./a//b"), "a/b");
        for bad in ["/etc/passwd", "\\x", "C:\\x", "a/../../b", "..", "a\0b"] {
            assert!(entry_path(bad).is_err(), "{bad}");
        }
        assert!(entry_path("__MACOSX/._a.obj").unwrap().is_none());
        assert!(entry_path("scene/.DS_Store").unwrap().is_none());
    }
}
