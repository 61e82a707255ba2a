//! Reading a spec: a regular file or standard input (`-`), at most
//! [`codegen::input::SPEC_SIZE_LIMIT`] bytes of UTF-8.
//! The rules and the reading are `codegen::input`'s, shared with the `mpc!` macro; standard input goes
//! through the same limit.

pub(crate) use codegen::input::{read_file, ReadError};
use std::io;
use std::path::Path;

/// The SPEC argument that means standard input.
pub(crate) fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Reads the spec from standard input, with the same limit as a file.
pub(crate) fn read_stdin() -> Result<String, ReadError> {
    codegen::input::read_limited(io::stdin().lock())
}
