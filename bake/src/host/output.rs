//! The output file of a bake: checked before any work, written to a temporary file beside it
//! and renamed into place, so that a failed or cancelled bake leaves nothing.

use crate::BakeError;
use std::io::Write;
use std::path::Path;

/// The directory a file goes to (`.` for a bare name).
pub fn parent_dir(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// An I/O error's message without the temporary file's path, which the tempfile crate appends
/// (`… at path "/dir/.radiosity-XXXX"`): the caller names the path the user gave.
pub fn io_message(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" at path \"") {
        Some(at) => s[..at].to_owned(),
        None => s,
    }
}

/// "cannot write PATH: WHY".
fn cannot(path: &Path, why: impl std::fmt::Display) -> BakeError {
    BakeError::Flag(format!("cannot write {}: {why}", path.display()))
}

/// A temporary file in `dir` named `.radiosity-…`, created with mode 0666 so that the umask
/// alone decides its permissions, as for any file the user creates (not the tempfile crate's
/// 0600).
pub fn temp_file_in(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut b = tempfile::Builder::new();
    b.prefix(".radiosity-");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    b.tempfile_in(dir)
}

/// Refuses an output path that cannot be written, before any work: a directory, a missing
/// or non-directory parent, or a directory without write permission (a temporary file is
/// created there and removed).
pub fn check_output(path: &Path) -> Result<(), BakeError> {
    if path.is_dir() {
        return Err(cannot(path, "it is a directory"));
    }
    let dir = parent_dir(path);
    if !dir.exists() {
        return Err(cannot(
            path,
            format!("directory {} does not exist", dir.display()),
        ));
    }
    if !dir.is_dir() {
        return Err(cannot(
            path,
            format!("{} is not a directory", dir.display()),
        ));
    }
    temp_file_in(dir)
        .map(drop)
        .map_err(|e| cannot(path, io_message(&e)))
}

/// `bytes` in a temporary file beside `path`, flushed to disk, not yet renamed ([`persist`]).
pub(super) fn write_temp(path: &Path, bytes: &[u8]) -> Result<tempfile::NamedTempFile, BakeError> {
    let mut tmp = temp_file_in(parent_dir(path)).map_err(|e| cannot(path, io_message(&e)))?;
    tmp.write_all(bytes)
        .map_err(|e| cannot(path, io_message(&e)))?;
    tmp.as_file().sync_all().ok();
    Ok(tmp)
}

/// Renames a temporary file from [`write_temp`] to `path`.
pub(super) fn persist(tmp: tempfile::NamedTempFile, path: &Path) -> Result<(), BakeError> {
    tmp.persist(path)
        .map_err(|e| cannot(path, io_message(&e.error)))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically (a temporary file beside it, renamed into place).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BakeError> {
    if path.is_dir() {
        return Err(cannot(path, "it is a directory"));
    }
    persist(write_temp(path, bytes)?, path)
}
