//! Errors for people, progress, and safe output files.

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// A one-line failure message naming the file and the problem, and who is
/// responsible for it (which sets the exit status).
#[derive(Debug)]
pub struct Failure {
    message: String,
    kind: qm::ErrorKind,
}

impl Failure {
    /// A failure the caller's arguments are responsible for.
    pub fn parameter(message: String) -> Self {
        Failure {
            message,
            kind: qm::ErrorKind::Parameter,
        }
    }

    /// A failure of the file system or the network.
    pub fn file(message: String) -> Self {
        Failure {
            message,
            kind: qm::ErrorKind::File,
        }
    }

    /// The problem `error` with `path`. Mesh file errors name their file
    /// already.
    pub fn about(path: &Path, error: impl Into<AnyError>) -> Self {
        let AnyError {
            message,
            named,
            kind,
        } = error.into();
        let message = if named {
            message
        } else {
            format!("{}: {message}", path.display())
        };
        Failure { message, kind }
    }

    /// The exit status: 1 for the data or a file (bad input, a file that
    /// cannot be read or written), 2 for the arguments (as for a usage
    /// error), 3 for a limit the caller may raise, 4 for a bug of qm.
    pub fn exit_code(&self) -> u8 {
        match self.kind {
            qm::ErrorKind::Parameter => 2,
            qm::ErrorKind::Limit => 3,
            qm::ErrorKind::Bug => 4,
            _ => 1,
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// An error's message, whether it names its file already, and who is
/// responsible for it.
pub struct AnyError {
    message: String,
    named: bool,
    kind: qm::ErrorKind,
}

impl From<qm::Error> for AnyError {
    fn from(e: qm::Error) -> Self {
        let hint = match &e {
            qm::Error::Param(qm::param::Error::Remesh {
                failure: qm::param::RemeshFailure::Folds { .. },
                ..
            }) => " (--accept-folds writes it anyway)",
            qm::Error::Param(qm::param::Error::Remesh {
                failure: qm::param::RemeshFailure::TooFar { .. },
                ..
            }) => " (--min-remesh-psnr 0 writes it anyway)",
            qm::Error::Codec(qm::codec::Error::Memory { .. })
            | qm::Error::Param(qm::param::Error::Memory { .. }) => " (--max-memory raises it)",
            _ => "",
        };
        AnyError {
            message: format!("{e}{hint}"),
            named: matches!(e, qm::Error::Mesh(_)),
            kind: e.kind(),
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
        AnyError {
            message: e.to_string(),
            named: false,
            kind: qm::ErrorKind::File,
        }
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
        return Err(Failure::parameter(format!(
            "{}: output would overwrite the input",
            output.display()
        )));
    }
    let folder = match output.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(Failure::file(format!(
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
        .map_err(|e| Failure::file(format!("{}: {e}", path.display())))
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

    pub fn step(&self, message: impl Into<std::borrow::Cow<'static, str>>) {
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
