//! Output files that appear whole or not at all, and never through a link.
//!
//! A file is written under a fresh hidden name beside its destination
//! (`.NAME.PID-N.tmp`, N counting the process's files; created with
//! `O_CREAT | O_EXCL`, which refuses any existing name, links included) and renamed onto
//! the destination when complete. So an interrupted run leaves no truncated frame under a
//! frame's name, and a symbolic link planted where a frame goes is replaced, not
//! followed: nothing is written outside the output folder.
//!
//! Every writer of the crate goes through [`AtomicFile`] (frames, renders, the manifest,
//! the contacts stream, the flamegraph, Python's frames), so every output gets the same
//! check ([`check_output`]): a destination that exists must be a regular file or a link;
//! a device, FIFO, socket or directory is refused, before writing and again before the
//! rename (which would otherwise replace `/dev/null` with a regular file).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Checks that an output may go to `dest`: it is absent, a regular file or a link (which
/// the rename replaces, never follows). Anything else (a device, FIFO, socket or
/// directory) is refused: the message says what it is, without the path (the caller
/// names it).
pub fn check_output(dest: &Path) -> Result<(), String> {
    let meta = match std::fs::symlink_metadata(dest) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("cannot inspect the output path: {e}")),
    };
    let t = meta.file_type();
    if t.is_file() || t.is_symlink() {
        return Ok(());
    }
    let what = if t.is_dir() {
        "a directory"
    } else {
        special_kind(&t)
    };
    Err(format!(
        "{what}, not a regular file: outputs only create or replace regular files; give a \
         file path"
    ))
}

#[cfg(unix)]
fn special_kind(t: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "a special file"
}

/// A file being written: [`Write`] into it, then [`AtomicFile::commit`]. Dropped
/// without a commit, it removes what it wrote.
pub struct AtomicFile {
    file: Option<BufWriter<File>>,
    tmp: PathBuf,
    dest: PathBuf,
}

impl AtomicFile {
    /// Starts `dest`'s replacement. The error names `dest`; a destination that
    /// [`check_output`] refuses is an `InvalidInput` error.
    pub fn create(dest: &Path) -> std::io::Result<Self> {
        let named =
            |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", dest.display()));
        check_output(dest)
            .map_err(|e| named(std::io::Error::new(std::io::ErrorKind::InvalidInput, e)))?;
        let name = dest.file_name().ok_or_else(|| {
            named(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a file name",
            ))
        })?;
        let (file, tmp) = create_hidden(dest, name, "temporary", false)?;
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
        self.rename_onto_dest()
    }

    /// Moves the file onto its destination now and goes on writing it there: a stream
    /// (the contacts JSONL) that can be followed during the run, with the same refusals
    /// and the same replacement of a link as a whole file. Flush it at its end.
    pub fn into_stream(mut self) -> std::io::Result<BufWriter<File>> {
        self.rename_onto_dest()?;
        Ok(self.file.take().expect("not yet committed"))
    }

    fn rename_onto_dest(&mut self) -> std::io::Result<()> {
        let named = |e: std::io::Error| {
            std::io::Error::new(e.kind(), format!("{}: {e}", self.dest.display()))
        };
        // Checked again: something may have been made there while the file was written.
        let renamed = check_output(&self.dest)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))
            .and_then(|()| std::fs::rename(&self.tmp, &self.dest));
        if renamed.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
            self.file = None;
        }
        renamed.map_err(named)
    }
}

/// Creates a new file under a fresh hidden name beside `dest` (whose file name is
/// `name`), `.NAME.PID-N.tmp`, for writing (and reading, if `read`); the error names
/// `dest` and the file as `what`.
fn create_hidden(
    dest: &Path,
    name: &std::ffi::OsStr,
    what: &str,
    read: bool,
) -> std::io::Result<(File, PathBuf)> {
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let mut hidden = std::ffi::OsString::from(".");
    hidden.push(name);
    hidden.push(format!(
        ".{}-{}.tmp",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    ));
    let path = dest.with_file_name(hidden);
    let file = OpenOptions::new()
        .read(read)
        .write(true)
        .create_new(true)
        .open(&path)
        .map_err(|e| {
            std::io::Error::new(
                e.kind(),
                format!("{}: {what} {}: {e}", dest.display(), path.display()),
            )
        })?;
    Ok((file, path))
}

/// A working file of `dest`'s writer (data it reads back before writing `dest`), under
/// the hidden name an [`AtomicFile`] for `dest` would get, so that `--overwrite` knows
/// it as the run's; removed when dropped.
pub struct Scratch {
    pub file: File,
    path: PathBuf,
}

impl Scratch {
    /// Creates the working file of `dest` (read and write).
    pub fn create(dest: &Path) -> std::io::Result<Self> {
        let name = dest.file_name().ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name")
        })?;
        let (file, path) = create_hidden(dest, name, "working file", true)?;
        Ok(Self { file, path })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
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

    /// A device, a FIFO or a directory at the destination is refused and left as it
    /// was; nothing is left beside it.
    #[cfg(unix)]
    #[test]
    fn a_special_file_at_the_destination_is_refused() {
        let d = dir("special");
        let fifo = d.join("fifo");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let sub = d.join("sub");
        std::fs::create_dir(&sub).unwrap();
        for dest in [fifo.as_path(), sub.as_path(), Path::new("/dev/null")] {
            let e = write(dest, b"frame").expect_err("refused");
            assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{e}");
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        use std::os::unix::fs::FileTypeExt;
        assert!(
            std::fs::symlink_metadata(&fifo)
                .unwrap()
                .file_type()
                .is_fifo()
        );
        assert!(
            std::fs::symlink_metadata("/dev/null")
                .unwrap()
                .file_type()
                .is_char_device()
        );
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A FIFO made at the destination while the file is written is refused at the
    /// rename, and the temporary is removed.
    #[cfg(unix)]
    #[test]
    fn a_special_file_made_during_the_write_is_refused_at_the_rename() {
        let d = dir("race");
        let dest = d.join("frame.ply");
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"frame").unwrap();
        let made = std::process::Command::new("mkfifo")
            .arg(&dest)
            .status()
            .unwrap();
        assert!(made.success());
        assert!(f.commit().is_err());
        use std::os::unix::fs::FileTypeExt;
        assert!(
            std::fs::symlink_metadata(&dest)
                .unwrap()
                .file_type()
                .is_fifo()
        );
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A stream is visible under its name from the start and keeps what is written.
    #[test]
    fn a_stream_is_renamed_at_once_and_written_there() {
        let d = dir("stream");
        let dest = d.join("contacts.jsonl");
        std::fs::write(&dest, "old").unwrap();
        let mut s = AtomicFile::create(&dest).unwrap().into_stream().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "");
        s.write_all(b"line\n").unwrap();
        s.flush().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "line\n");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
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
