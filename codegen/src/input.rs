//! Reading a spec file, for the two front ends that read one (the `mpc!` macro's `= "path"` form and
//! `mpcc`): a regular file of at most [`SPEC_SIZE_LIMIT`] bytes of UTF-8.
//!
//! A path that is not a regular file is refused from its metadata, before it is opened: opening a FIFO
//! for reading blocks until a writer appears (a build would hang in the macro), and a device such as
//! `/dev/zero` never ends. Every read goes through `Read::take(SPEC_SIZE_LIMIT + 1)` ([`read_limited`],
//! which `mpcc` also uses for standard input), so that no source can make a front end read without bound.

use std::error::Error as StdError;
use std::fmt::{self, Display};
use std::fs::{self, FileType};
use std::io::{self, Read};
use std::path::Path;

/// The largest spec read: 1 MiB, about a thousand times the size of the specs in `specs/`. `mpcc`'s
/// `--help` text of SPEC says "at most 1 MiB" (`mpcc/src/test.rs` holds the two together).
pub const SPEC_SIZE_LIMIT: u64 = SPEC_SIZE_LIMIT_MIB << 20;

/// [`SPEC_SIZE_LIMIT`] in MiB, as the error and `--help` name it.
pub const SPEC_SIZE_LIMIT_MIB: u64 = 1;

/// Reads the spec at `path`, which must be a regular file (a symbolic link to one is followed).
pub fn read_file(path: &Path) -> Result<String, ReadError> {
    let meta = fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile(kind(meta.file_type())));
    }
    let file = fs::File::open(path).map_err(ReadError::Io)?;
    // The path may have been replaced between the two looks; what was opened is what counts.
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile(kind(meta.file_type())));
    }
    read_limited(file)
}

/// Reads a spec from `source` (a file, standard input) with the limit of a file: at most
/// `SPEC_SIZE_LIMIT + 1` bytes, one more than the limit telling that the source is over it.
pub fn read_limited(source: impl Read) -> Result<String, ReadError> {
    let mut bytes = Vec::new();
    source
        .take(SPEC_SIZE_LIMIT + 1)
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > SPEC_SIZE_LIMIT {
        return Err(ReadError::TooLarge);
    }
    String::from_utf8(bytes).map_err(|e| ReadError::NotUtf8(e.utf8_error()))
}

/// What a file that is not a regular file is, for the error: "a FIFO", "a directory", ...
fn kind(file_type: FileType) -> &'static str {
    if file_type.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// Why a spec could not be read: `mpcc`'s `Caused by:` line under "cannot read the spec", the macro's
/// error after it.
#[derive(Debug)]
pub enum ReadError {
    /// The operating system's error, shown as it is.
    Io(io::Error),
    /// The path is not a regular file: `kind` is what it is ("a FIFO", "a directory", ...).
    NotAFile(&'static str),
    /// The spec is longer than [`SPEC_SIZE_LIMIT`].
    TooLarge,
    /// The spec is not UTF-8 text.
    NotUtf8(std::str::Utf8Error),
}

impl Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Io(e) => Display::fmt(e, f),
            ReadError::NotAFile(kind) => write!(f, "it is {kind}, not a regular file"),
            ReadError::TooLarge => write!(
                f,
                "it is larger than the limit of {SPEC_SIZE_LIMIT_MIB} MiB ({SPEC_SIZE_LIMIT} bytes)"
            ),
            ReadError::NotUtf8(e) => write!(f, "it is not UTF-8 text: {e}"),
        }
    }
}

impl StdError for ReadError {
    /// An I/O error stands for itself (its own source comes next); the others end the chain.
    fn source(&self) -> Option<&(dyn StdError + 'static)> {
        match self {
            ReadError::Io(e) => e.source(),
            ReadError::NotAFile(_) | ReadError::TooLarge | ReadError::NotUtf8(_) => None,
        }
    }
}
