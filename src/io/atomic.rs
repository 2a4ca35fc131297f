//! Output files that appear whole or not at all, and never through a link.
//!
//! A file is written under a fresh hidden name beside its destination
//! (`.NAME.PID-N.tmp`, N counting the process's files; created with
//! `O_CREAT | O_EXCL`, which refuses any existing name, links included) and renamed onto
//! the destination when complete. So an interrupted run leaves no truncated frame under a
//! frame's name, and a symbolic link planted where a frame goes is replaced, not
//! followed: nothing is written outside the output folder.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file being written: [`Write`] into it, then [`AtomicFile::commit`]. Dropped
/// without a commit, it removes what it wrote.
pub struct AtomicFile {
    file: Option<BufWriter<File>>,
    tmp: PathBuf,
    dest: PathBuf,
}

impl AtomicFile {
    /// Starts `dest`'s replacement. The error names `dest`.
    pub fn create(dest: &Path) -> std::io::Result<Self> {
        let named =
            |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", dest.display()));
        let name = dest.file_name().ok_or_else(|| {
            named(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a file name",
            ))
        })?;
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let mut hidden = std::ffi::OsString::from(".");
        hidden.push(name);
        hidden.push(format!(
            ".{}-{}.tmp",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        let tmp = dest.with_file_name(hidden);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| {
                std::io::Error::new(
                    e.kind(),
                    format!("{}: temporary {}: {e}", dest.display(), tmp.display()),
                )
            })?;
        Ok(Self {
            file: Some(BufWriter::new(file)),
            tmp,
            dest: dest.to_path_buf(),
        })
    }

    /// Flushes the file and moves it onto its destination (replacing a file or a link
    /// there, never writing through one).
    pub fn commit(mut self) -> std::io::Result<()> {
        let named = |e: std::io::Error| {
            std::io::Error::new(e.kind(), format!("{}: {e}", self.dest.display()))
        };
        let file = self.file.take().expect("not yet committed");
        // Closed before the rename. No fsync: the guard is against an interrupted
        // process, not a power cut, and a sync per frame would cost more than the frame.
        drop(file.into_inner().map_err(|e| named(e.into_error()))?);
        std::fs::rename(&self.tmp, &self.dest).map_err(named)
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.as_mut().expect("not yet committed").write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.as_mut().expect("not yet committed").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` whole or not at all ([`AtomicFile`]).
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("phyxel-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A link planted at the destination is replaced by the file; its target keeps its
    /// content.
    #[cfg(unix)]
    #[test]
    fn a_link_at_the_destination_is_replaced_not_followed() {
        let d = dir("link");
        let victim = d.join("victim.txt");
        std::fs::write(&victim, "keep").unwrap();
        let out = d.join("out");
        std::fs::create_dir(&out).unwrap();
        let dest = out.join("frame.ply");
        std::os::unix::fs::symlink(&victim, &dest).unwrap();
        write(&dest, b"frame").unwrap();
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
        assert!(!std::fs::symlink_metadata(&dest).unwrap().is_symlink());
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "frame");
        assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// Dropped before its commit, the file leaves neither the destination nor a
    /// temporary behind; an existing destination keeps its content.
    #[test]
    fn an_uncommitted_file_leaves_nothing() {
        let d = dir("drop");
        let dest = d.join("frame.ply");
        std::fs::write(&dest, "old").unwrap();
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.write_all(b"half a fra").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
