//! Errors for people, progress, and safe output files.

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// A one-line failure message naming the file and the problem.
#[derive(Debug)]
pub struct Failure(String);

impl Failure {
    pub fn new(message: String) -> Self {
        Failure(message)
    }

    /// The problem `error` with `path`. Mesh file errors name their file
    /// already.
    pub fn about(path: &Path, error: impl Into<AnyError>) -> Self {
        match error.into() {
            AnyError::Named(e) => Failure(e),
            AnyError::Plain(e) => Failure(format!("{}: {e}", path.display())),
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// An error whose message does or does not name its file already.
pub enum AnyError {
    Named(String),
    Plain(String),
}

impl From<qm::Error> for AnyError {
    fn from(e: qm::Error) -> Self {
        match &e {
            qm::Error::Mesh(m) => AnyError::Named(m.to_string()),
            qm::Error::Param(qm::param::Error::Remesh {
                failure: qm::param::RemeshFailure::Folds { .. },
                ..
            }) => AnyError::Plain(format!("{e} (--accept-folds writes it anyway)")),
            qm::Error::Param(qm::param::Error::Remesh {
                failure: qm::param::RemeshFailure::TooFar { .. },
                ..
            }) => AnyError::Plain(format!("{e} (--min-remesh-psnr 0 writes it anyway)")),
            qm::Error::Codec(qm::codec::Error::Memory { .. })
            | qm::Error::Param(qm::param::Error::Memory { .. }) => {
                AnyError::Plain(format!("{e} (--max-memory raises it)"))
            }
            _ => AnyError::Plain(e.to_string()),
        }
    }
}

impl From<qm::codec::Error> for AnyError {
    fn from(e: qm::codec::Error) -> Self {
        qm::Error::from(e).into()
    }
}

impl From<std::io::Error> for AnyError {
    fn from(e: std::io::Error) -> Self {
        AnyError::Plain(e.to_string())
    }
}

/// `input` with its extension replaced.
pub fn default_output(input: &Path, extension: &str) -> PathBuf {
    input.with_extension(extension)
}

/// Checks an output path before any work: it must not name the input
/// file, and its folder must exist (else the error would come only after
/// the work, naming a temporary file).
pub fn check_output(input: &Path, output: &Path) -> Result<(), Failure> {
    let same = match (input.canonicalize(), output.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => input == output,
    };
    if same {
        return Err(Failure(format!(
            "{}: output would overwrite the input",
            output.display()
        )));
    }
    let folder = match output.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(Failure(format!(
            "{}: the output folder {} does not exist",
            output.display(),
            folder.display()
        )));
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same folder, so
/// that `path` is either untouched or complete (and gets the usual mode of a
/// new file, not the temporary file's owner-only one).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    qm::io::write_atomic(path, |file| file.write_all(bytes))
        .map_err(|e| Failure(format!("{}: {e}", path.display())))
}

/// A spinner naming the current step; silent with `--quiet` or when stderr
/// is not a terminal.
pub struct Progress(Option<ProgressBar>);

impl Progress {
    pub fn new(quiet: bool) -> Self {
        if quiet {
            return Progress(None);
        }
        let bar = ProgressBar::new_spinner();
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").expect("valid template"),
        );
        bar.enable_steady_tick(Duration::from_millis(100));
        Progress(Some(bar))
    }

    pub fn step(&self, message: &'static str) {
        if let Some(bar) = &self.0 {
            bar.set_message(message);
        }
    }

    /// Runs `f` with the spinner hidden, for printing.
    pub fn suspend(&self, f: impl FnOnce()) {
        match &self.0 {
            Some(bar) => bar.suspend(f),
            None => f(),
        }
    }

    pub fn finish(&self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}
