//! Output files: every one is opened before the work starts, so a typo in a path fails at once
//! (usage error) instead of after the work; `-` is stdout (for one output at a time).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::failure::Failure;

/// An output file opened for writing (not yet truncated: an existing file keeps its contents
/// until [`Output::write`] replaces them), or stdout (`-`).
pub struct Output {
    flag: &'static str,
    path: PathBuf,
    file: Option<File>,
    created: bool,
}

/// Whether `path` means stdout.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Opens every `(flag, path)` for writing; on the first failure removes the files this call
/// created and returns a usage error naming the flag and the reason.
pub fn open_all(list: &[(&'static str, &Path)]) -> Result<Vec<Output>, Failure> {
    for (i, (flag, path)) in list.iter().enumerate() {
        if let Some((other, _)) = list[..i].iter().find(|(_, p)| p == path) {
            return Err(Failure::usage(format!(
                "{other} and {flag} name the same file {}; give each output its own path",
                path.display()
            )));
        }
    }
    let mut out: Vec<Output> = Vec::new();
    for (flag, path) in list {
        if is_stdout(path) {
            out.push(Output {
                flag,
                path: path.to_path_buf(),
                file: None,
                created: false,
            });
            continue;
        }
        let existed = path.exists();
        if path.is_dir() {
            discard(out);
            return Err(Failure::usage(format!(
                "cannot write {flag} {}: it is a directory; give a file name",
                path.display()
            )));
        }
        match OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
        {
            Ok(file) => out.push(Output {
                flag,
                path: path.to_path_buf(),
                file: Some(file),
                created: !existed,
            }),
            Err(e) => {
                discard(out);
                return Err(Failure::usage(format!(
                    "cannot write {flag} {}: {e}",
                    path.display()
                )));
            }
        }
    }
    Ok(out)
}

/// Removes the files that [`open_all`] created (the work did not happen).
pub fn discard(outputs: Vec<Output>) {
    for o in outputs {
        if o.created {
            drop(o.file);
            let _ = std::fs::remove_file(&o.path);
        }
    }
}

impl Output {
    /// The flag it was given with.
    pub fn flag(&self) -> &'static str {
        self.flag
    }

    /// The path it was given (`-` for stdout).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Replaces the file's contents with what `fill` writes.
    pub fn write(
        self,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), Failure> {
        self.write_counted(fill).map(|_| ())
    }

    /// As [`Output::write`], returning the number of bytes written.
    pub fn write_counted(
        self,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<u64, Failure> {
        let mut count = 0u64;
        let counted = |w: &mut dyn Write| {
            let mut c = Counter {
                inner: w,
                count: &mut count,
            };
            fill(&mut c)
        };
        self.write_inner(counted)?;
        Ok(count)
    }

    fn write_inner(
        self,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), Failure> {
        let fail = |e: std::io::Error| {
            Failure::Runtime(anyhow::anyhow!(
                "cannot write {} {}: {e}",
                self.flag,
                self.path.display()
            ))
        };
        let Some(file) = &self.file else {
            let mut w = BufWriter::new(std::io::stdout().lock());
            // A closed stdout (`| head`) ends the output quietly.
            let _ = fill(&mut w).and_then(|()| w.flush());
            return Ok(());
        };
        file.set_len(0).map_err(fail)?;
        let mut w = BufWriter::new(file);
        fill(&mut w).map_err(fail)?;
        w.flush().map_err(fail)?;
        Ok(())
    }
}

/// Creates (if needed) the directory of a `--stl-dir`-style flag and checks it is one.
pub fn ensure_dir(flag: &str, dir: &Path) -> Result<(), Failure> {
    if dir.exists() && !dir.is_dir() {
        return Err(Failure::usage(format!(
            "{flag} {} exists and is not a directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| Failure::usage(format!("cannot create {flag} {}: {e}", dir.display())))
}

/// A writer that counts what passes through it.
struct Counter<'a> {
    inner: &'a mut dyn Write,
    count: &'a mut u64,
}

impl Write for Counter<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        *self.count += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}
