//! Reading a spec file (`codegen::input`, shared by the `mpc!` macro and `mpcc`): a regular file of at
//! most 1 MiB of UTF-8; a FIFO, a device or a directory is refused from its metadata, before it is opened.

use codegen::input::{read_file, ReadError, SPEC_SIZE_LIMIT};
use std::path::PathBuf;

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("codegen-input-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_regular_file_is_read() {
    let path = scratch("regular").join("spec.toml");
    let paper = include_str!("../../specs/paper.toml");
    std::fs::write(&path, paper).unwrap();
    assert_eq!(read_file(&path).unwrap(), paper);
}

#[test]
fn special_files_are_refused_before_they_are_opened() {
    let dir = scratch("special");
    let err = read_file(&dir).unwrap_err();
    assert!(matches!(err, ReadError::NotAFile("a directory")), "{err}");
    assert_eq!(err.to_string(), "it is a directory, not a regular file");
    // Opening /dev/zero would succeed and reading it would never end.
    let err = read_file(std::path::Path::new("/dev/zero")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "it is a character device, not a regular file"
    );
    // Opening a FIFO for reading blocks until a writer comes: this test would hang if it were opened.
    let fifo = dir.join("fifo");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let err = read_file(&fifo).unwrap_err();
        assert_eq!(err.to_string(), "it is a FIFO, not a regular file");
    }
}

#[test]
fn files_past_the_limit_or_not_utf8_are_refused() {
    let dir = scratch("limit");
    let large = dir.join("large.toml");
    std::fs::write(&large, vec![b'#'; SPEC_SIZE_LIMIT as usize + 1]).unwrap();
    assert!(matches!(read_file(&large), Err(ReadError::TooLarge)));
    let at_limit = dir.join("at-limit.toml");
    std::fs::write(&at_limit, vec![b'#'; SPEC_SIZE_LIMIT as usize]).unwrap();
    assert_eq!(
        read_file(&at_limit).unwrap().len(),
        SPEC_SIZE_LIMIT as usize
    );
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, [0xff, 0xfe, 0x00]).unwrap();
    assert!(matches!(read_file(&binary), Err(ReadError::NotUtf8(_))));
}
