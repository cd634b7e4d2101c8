//! Safe output files: checked before the work starts, written to a temporary file beside the
//! target, flushed to disk and renamed over the target only when complete.
//!
//! [`Output::create`] checks the path and opens the temporary file at once, so a path that
//! cannot be written (missing or read-only folder, a directory, a device, a FIFO) is an error
//! before any work is done. Writing goes to `.NAME.PID.N.tmp` in the target's folder;
//! [`Output::commit`] flushes it, `fsync`s it, renames it over the target (an atomic
//! replacement on POSIX file systems) and `fsync`s the folder. Until then the target is never
//! opened, truncated or unlinked: a failed run (a full disk, a write error, an error in the
//! work) removes only its own temporary file, a killed run leaves the previous target intact
//! (and a stray temporary file), and concurrent runs writing the same path each rename a
//! complete file, so the target is always one of them, whole. The path `-` is standard
//! output, written directly (there is nothing to replace).
//!
//! A replaced file keeps its permission bits; a symbolic link to a file is followed, so the
//! file it points to is replaced and the link stays.

use crate::error::{Error, ErrorKind, Result};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

enum Sink {
    Stdout(BufWriter<std::io::Stdout>),
    File {
        file: BufWriter<File>,
        tmp: PathBuf,
        target: PathBuf,
    },
    /// Committed or failed: nothing left to do.
    Done,
}

/// An output file (or standard output) being written; see the [module documentation](self).
pub struct Output {
    sink: Sink,
    name: String,
}

fn io_err(name: &str, message: impl Into<String>) -> Error {
    Error::new(ErrorKind::Io, message).in_file(name.to_string())
}

impl Output {
    /// Checks `path` and opens its temporary file (`-`: standard output).
    pub fn create(path: &Path) -> Result<Output> {
        let name = path.display().to_string();
        if path.as_os_str() == "-" {
            return Ok(Output {
                sink: Sink::Stdout(BufWriter::new(std::io::stdout())),
                name: "standard output".to_string(),
            });
        }
        if path.as_os_str().is_empty() {
            return Err(Error::new(ErrorKind::Usage, "empty output path"));
        }
        let mut target = path.to_path_buf();
        let mut mode = None;
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => {
                return Err(io_err(&name, "is a directory, not an output file"));
            }
            Ok(m) if !m.is_file() => {
                return Err(io_err(
                    &name,
                    "is not a regular file (a device, FIFO or socket); refusing to replace it",
                ));
            }
            Ok(m) => {
                mode = Some(m.permissions());
                if std::fs::symlink_metadata(path).is_ok_and(|l| l.file_type().is_symlink()) {
                    target = std::fs::canonicalize(path)
                        .map_err(|e| io_err(&name, format!("cannot resolve the link: {e}")))?;
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err(&name, e.to_string())),
        }
        let file_name = target
            .file_name()
            .ok_or_else(|| io_err(&name, "has no file name"))?
            .to_string_lossy()
            .into_owned();
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        match std::fs::metadata(&dir) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => return Err(io_err(&name, format!("{} is not a folder", dir.display()))),
            Err(e) => {
                return Err(io_err(
                    &name,
                    format!("cannot write into folder {}: {e}", dir.display()),
                ))
            }
        }
        let (file, tmp) = loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let tmp = dir.join(format!(".{file_name}.{}.{n}.tmp", std::process::id()));
            match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                Ok(f) => break (f, tmp),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => {
                    return Err(io_err(
                        &name,
                        format!("cannot create a file in {}: {e}", dir.display()),
                    ))
                }
            }
        };
        if let Some(p) = mode {
            // Best effort: a replaced file keeps its permissions.
            let _ = file.set_permissions(p);
        }
        Ok(Output {
            sink: Sink::File {
                file: BufWriter::with_capacity(1 << 16, file),
                tmp,
                target,
            },
            name,
        })
    }

    /// True when writing to standard output.
    pub fn is_stdout(&self) -> bool {
        matches!(self.sink, Sink::Stdout(_))
    }

    /// The path as given (or `standard output`), for messages.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Finishes: flushes, `fsync`s and renames the temporary file over the target (standard
    /// output: flushes). On error the temporary file is removed and the target is untouched.
    pub fn commit(mut self) -> Result<()> {
        let name = self.name.clone();
        match std::mem::replace(&mut self.sink, Sink::Done) {
            Sink::Stdout(mut w) => w.flush().map_err(|e| io_err(&name, e.to_string())),
            Sink::File { file, tmp, target } => {
                let result = (|| -> std::io::Result<()> {
                    let file = file.into_inner().map_err(|e| e.into_error())?;
                    file.sync_all()?;
                    drop(file);
                    std::fs::rename(&tmp, &target)?;
                    if let Some(dir) = target.parent().filter(|d| !d.as_os_str().is_empty()) {
                        // The rename itself is made durable by syncing the folder; not every
                        // file system allows opening one, so this is best effort.
                        if let Ok(d) = File::open(dir) {
                            let _ = d.sync_all();
                        }
                    }
                    Ok(())
                })();
                if result.is_err() {
                    let _ = std::fs::remove_file(&tmp);
                }
                result.map_err(|e| io_err(&name, e.to_string()))
            }
            Sink::Done => Ok(()),
        }
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.sink {
            Sink::Stdout(w) => w.write(buf),
            Sink::File { file, .. } => file.write(buf),
            Sink::Done => Err(std::io::Error::other("output already finished")),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        match &mut self.sink {
            Sink::Stdout(w) => w.write_all(buf),
            Sink::File { file, .. } => file.write_all(buf),
            Sink::Done => Err(std::io::Error::other("output already finished")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.sink {
            Sink::Stdout(w) => w.flush(),
            // The temporary file is flushed at commit; nobody reads it before.
            Sink::File { .. } | Sink::Done => Ok(()),
        }
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Sink::File { tmp, .. } = std::mem::replace(&mut self.sink, Sink::Done) {
            // Not committed: remove the temporary file this run created, nothing else.
            let _ = std::fs::remove_file(&tmp);
        }
    }
}

/// Writes `bytes` to `path` safely ([`Output::create`], then [`Output::commit`]).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut out = Output::create(path)?;
    out.write_all(bytes)
        .map_err(|e| io_err(out.name(), e.to_string()))?;
    out.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("limitray-out-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn replaces_only_on_commit() {
        let d = dir("commit");
        let p = d.join("a.txt");
        std::fs::write(&p, "old").unwrap();
        let mut o = Output::create(&p).unwrap();
        o.write_all(b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(entries(&d).len(), 2, "{:?}", entries(&d));
        o.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(&d), vec!["a.txt"]);
        // Dropped without commit (an error in the work): the old file stays, no temp left.
        let mut o = Output::create(&p).unwrap();
        o.write_all(b"partial").unwrap();
        drop(o);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(&d), vec!["a.txt"]);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn refuses_bad_paths_before_work() {
        let d = dir("bad");
        let e = Output::create(&d).err().unwrap();
        assert!(
            e.to_string()
                .ends_with("is a directory, not an output file"),
            "{e}"
        );
        let e = Output::create(Path::new("/dev/null")).err().unwrap();
        assert_eq!(
            e.to_string(),
            "/dev/null: is not a regular file (a device, FIFO or socket); refusing to replace it"
        );
        let e = Output::create(&d.join("missing/x.exr")).err().unwrap();
        assert!(e.to_string().contains("cannot write into folder"), "{e}");
        let e = Output::create(Path::new("")).err().unwrap();
        assert_eq!(e.kind, ErrorKind::Usage);
        assert!(Output::create(Path::new("-")).unwrap().is_stdout());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn follows_links_and_keeps_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let d = dir("link");
        let real = d.join("real.txt");
        std::fs::write(&real, "old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = d.join("link.txt");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_file(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        std::fs::remove_dir_all(&d).ok();
    }
}
