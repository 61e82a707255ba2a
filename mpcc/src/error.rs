//! Operational failures of `mpcc`; mistakes in a spec arrive already rendered, as the macro shows them.

use crate::input::ReadError;
use std::error::Error as StdError;
use std::fmt::{self, Display};
use std::io;
use std::path::PathBuf;

pub(crate) type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug)]
pub(crate) enum Error {
    /// The spec file could not be read.
    Read(PathBuf, ReadError),
    /// The spec could not be read from standard input (SPEC `-`).
    ReadStdin(ReadError),
    /// `-o FILE` names the spec itself (the same path, or another name of the same file): refused
    /// before anything is written.
    SameFile { spec: PathBuf, output: PathBuf },
    /// `-o FILE` could not be written.
    Write(PathBuf, io::Error),
    /// Standard output could not be written.
    Stdout(io::Error),
    /// `emit --c DIR` could not write the C crate (the message says why).
    CTarget(PathBuf, String),
    /// `dump-qp` was given states or a reference it cannot use (the message says which).
    Dump(String),
    /// `check --plot FILE` could not draw (the message says why).
    Plot(PathBuf, String),
    /// The spec has mistakes: `rendered` is every diagnostic drawn against the source by
    /// `codegen::render`, exactly as the macro's error carries them.
    Spec {
        path: PathBuf,
        count: usize,
        rendered: String,
    },
}

impl Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Read(path, _) => write!(f, "cannot read the spec `{}`", path.display()),
            Error::ReadStdin(_) => f.write_str("cannot read the spec from standard input"),
            Error::SameFile { spec, output } => write!(
                f,
                "refusing to write `{}`: it is the same file as the spec `{}`",
                output.display(),
                spec.display()
            ),
            Error::Write(path, _) => write!(f, "cannot write `{}`", path.display()),
            Error::Stdout(_) => f.write_str("cannot write to standard output"),
            Error::Dump(why) => write!(f, "cannot dump the QP: {why}"),
            Error::Plot(file, why) => write!(f, "cannot draw `{}`: {why}", file.display()),
            Error::CTarget(dir, why) => {
                write!(f, "cannot write the C crate `{}`: {why}", dir.display())
            }
            Error::Spec { path, count, .. } => write!(
                f,
                "invalid controller spec `{}`: {count} error{}",
                path.display(),
                if *count == 1 { "" } else { "s" }
            ),
        }
    }
}

impl StdError for Error {
    fn source(&self) -> Option<&(dyn StdError + 'static)> {
        match self {
            Error::Read(_, e) | Error::ReadStdin(e) => Some(e),
            Error::Write(_, e) | Error::Stdout(e) => Some(e),
            Error::SameFile { .. }
            | Error::Spec { .. }
            | Error::Dump(_)
            | Error::CTarget(..)
            | Error::Plot(..) => None,
        }
    }
}

/// What `main` prints for `error`: the rendered diagnostics of a bad spec, then `mpcc: {error}` and the
/// chain of causes (cxxbridge's format).
pub(crate) fn report(error: &Error) -> String {
    let mut out = String::new();
    if let Error::Spec { rendered, .. } = error {
        out.push_str(rendered);
        out.push_str("\n\n");
    }
    out.push_str(&format!("mpcc: {error}\n"));
    let mut cause = error.source();
    if cause.is_some() {
        out.push_str("\nCaused by:\n");
    }
    while let Some(e) = cause {
        out.push_str(&format!("    {e}\n"));
        cause = e.source();
    }
    out
}
