//! Every file the commands write goes through here: the destination is checked before any
//! work (its directory exists and takes new files, the path is not a directory), and the
//! bytes go to a temporary file beside it, renamed into place once complete, so that readers
//! never see half a file and a failure leaves nothing behind. The file ends with the mode an
//! ordinary file created under the user's umask gets (`0666 & !umask`), and every message
//! names the path the user gave, never the temporary one.

use anyhow::{Context, anyhow, bail};
use radiosity_bake::host::output::{
    check_output, io_message as plain, parent_dir, temp_file_in as temp_in,
};
use std::io::Write;
use std::path::Path;

/// Refuses, before any work, an output file that could not be written: a path that is a
/// directory, a directory that does not exist or is not one, or one that takes no new file
/// (the bake's own check, `radiosity_bake::host::output::check_output`).
pub(crate) fn check_file(path: &Path) -> anyhow::Result<()> {
    Ok(check_output(path)?)
}

/// Refuses, before any work, an output directory that exists as something else.
pub(crate) fn check_dir_path(dir: &Path) -> anyhow::Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "cannot write into {}: it exists and is not a directory",
            dir.display()
        );
    }
    Ok(())
}

/// Creates an output directory (and its parents) and checks that it takes new files.
pub(crate) fn create_dir(dir: &Path) -> anyhow::Result<()> {
    check_dir_path(dir)?;
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    temp_in(dir)
        .map(drop)
        .map_err(|e| anyhow!("cannot write into {}: {}", dir.display(), plain(&e)))
}

/// Writes a file atomically: `write` fills a temporary file in the same directory, which is
/// renamed to `path` once it succeeds.
pub(crate) fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<&std::fs::File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let cannot = |e: &std::io::Error| anyhow!("cannot write {}: {}", path.display(), plain(e));
    if path.is_dir() {
        bail!("cannot write {}: it is a directory", path.display());
    }
    let tmp = temp_in(parent_dir(path)).map_err(|e| cannot(&e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        write(&mut w).with_context(|| format!("cannot encode {}", path.display()))?;
        w.flush().map_err(|e| cannot(&e))?;
    }
    tmp.as_file().sync_all().ok();
    tmp.persist(path).map_err(|e| cannot(&e.error))?;
    Ok(())
}

/// [`write_atomic`] of a byte buffer.
pub(crate) fn write_bytes(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic(path, |w| Ok(w.write_all(bytes)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_cannot_be_written_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let err = check_file(d).unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
        let missing = d.join("no/such/x.png");
        let err = check_file(&missing).unwrap_err().to_string();
        assert!(
            err.contains("does not exist") && err.contains("no/such/x.png"),
            "{err}"
        );
        let file = d.join("f");
        std::fs::write(&file, "x").unwrap();
        let err = check_file(&file.join("x.png")).unwrap_err().to_string();
        assert!(err.contains("is not a directory"), "{err}");
        let err = check_dir_path(&file).unwrap_err().to_string();
        assert!(err.contains("not a directory"), "{err}");
        check_file(&d.join("ok.png")).unwrap();
        assert_eq!(
            std::fs::read_dir(d).unwrap().count(),
            1,
            "the probe is gone"
        );
    }

    #[test]
    fn temporary_names_are_cut_from_messages() {
        let e = std::io::Error::other(
            "No such file or directory (os error 2) at path \"/x/.radiosity-AbC\"",
        );
        assert_eq!(plain(&e), "No such file or directory (os error 2)");
    }

    #[test]
    fn writes_whole_files() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.bin");
        write_bytes(&p, b"abc").unwrap();
        write_bytes(&p, b"de").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"de");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
