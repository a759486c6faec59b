//! Output files: written whole or not at all. Content goes to a temporary file next to the
//! target, is flushed to disk, and is renamed over the target in one step, so an interrupted or
//! failed run leaves the previous file (or none), never half of a new one. Every host output
//! (the tool's commands, xtask's estimates and plots) is written through here.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::Error;

/// Writes `bytes` to `path` atomically.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    write_atomically_with(path, |w| w.write_all(bytes))
}

/// Writes what `fill` produces to `path` atomically (for outputs made by a writer, e.g. an
/// encoder). If `fill` fails, the temporary file is removed and `path` is untouched.
pub fn write_atomically_with(path: &Path, fill: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), Error> {
    let shown = path.display().to_string();
    let tmp = temporary_path(path).ok_or_else(|| Error::file(&shown, "output path has no file name"))?;
    let written = (|| -> io::Result<()> {
        let mut w = BufWriter::new(File::create(&tmp)?);
        fill(&mut w)?;
        // On disk before the rename makes it visible: a power cut cannot leave an empty target.
        w.into_inner().map_err(io::IntoInnerError::into_error)?.sync_all()
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::file(&shown, format!("cannot write ({e}); left unchanged")));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::file(&shown, format!("cannot move the new file into place ({e}); left unchanged"))
    })
}

/// A hidden name in the target's directory (a rename is only atomic within one file system),
/// unique per process.
fn temporary_path(path: &Path) -> Option<PathBuf> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name()?;
    Some(dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("ipmc-recording-output-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn a_write_that_fails_midway_leaves_the_old_file_and_no_temporary() {
        let dir = scratch("midway");
        let out = dir.join("EST.csv");
        write_atomically(&out, b"old complete content\n").unwrap();
        let err = write_atomically_with(&out, |w| {
            w.write_all(b"t_s,base_est_m\n0,1e-3\n")?;
            w.flush()?; // the partial content really reached the temporary file
            Err(io::Error::other("interrupted"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("left unchanged"), "{err}");
        assert_eq!(std::fs::read(&out).unwrap(), b"old complete content\n");
        assert_eq!(entries(&dir), ["EST.csv"]);
        write_atomically_with(&out, |w| w.write_all(b"new\n")).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"new\n");
        assert_eq!(entries(&dir), ["EST.csv"]);
    }

    #[test]
    fn a_failed_rename_leaves_no_temporary() {
        let dir = scratch("rename");
        let target = dir.join("is-a-directory");
        std::fs::create_dir(target.join("")).unwrap();
        std::fs::write(target.join("inside"), b"x").unwrap();
        assert!(write_atomically(&target, b"data").is_err());
        assert_eq!(entries(&dir), ["is-a-directory"]);
    }
}
