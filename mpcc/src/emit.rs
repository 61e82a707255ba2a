//! `mpcc emit`: the module's name, and writing it: never over the spec, only what changed to a regular
//! file, straight through to anything else (`/dev/stdout`).

use std::fs;
use std::io::{self, Read, Write};
use std::path::Path;

/// A module name from the spec's file stem: `specs/paper-faithful.toml` gives `paper_faithful`.
/// Characters that cannot be in an identifier become `_`; a leading digit or a keyword gets a `_`
/// prepended or appended.
pub(crate) fn module_name(spec: &Path) -> String {
    let stem = spec
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut name: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if name.is_empty() || name.chars().all(|c| c == '_') {
        return "controller".into();
    }
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        name.insert(0, '_');
    }
    if KEYWORDS.contains(&name.as_str()) {
        name.push('_');
    }
    name
}

/// Rust's strict and reserved keywords (2021 edition), which cannot name a module.
const KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub",
    "ref", "return", "self", "Self", "static", "struct", "super", "trait", "true", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "gen", "macro",
    "override", "priv", "try", "typeof", "unsized", "virtual", "yield",
];

/// Whether `output` is the file `spec` (the same path, or another name of it: `./`, `..`, a symbolic or
/// hard link), so that `mpcc emit SPEC -o SPEC` is refused before it overwrites the spec. On unix the
/// device and inode numbers decide; elsewhere the canonical paths. A path that does not exist is not the
/// spec.
pub(crate) fn same_file(spec: &Path, output: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (fs::metadata(spec), fs::metadata(output)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (fs::canonicalize(spec), fs::canonicalize(output)) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    }
}

/// Writes the module to `-o path`. A regular file (or a new one) is written only if its content changed
/// ([`write_file_if_changed`]); anything else, such as `/dev/stdout`, a terminal or a FIFO, is written
/// straight through, without reading it first: reading `/dev/stdout` waits for input that never comes
/// and reading `/dev/full` never ends. As on standard output, a reader that went away (`-o /dev/stdout |
/// head`) ends the output quietly.
pub(crate) fn write(path: &Path, content: &str) -> io::Result<()> {
    match fs::metadata(path) {
        Ok(meta) if !meta.is_file() => {
            let mut file = fs::OpenOptions::new().write(true).open(path)?;
            match file.write_all(content.as_bytes()) {
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(()),
                result => result,
            }
        }
        _ => write_file_if_changed(path, content).map(|_| ()),
    }
}

/// Writes `content` to `path` unless the file already holds exactly that, so that a build that depends
/// on the file is not redone for nothing (prost-build's `write_file_if_changed`). Returns whether it wrote.
/// The old content is read only when its length is the new one's, and then no further.
pub(crate) fn write_file_if_changed(path: &Path, content: &str) -> io::Result<bool> {
    if unchanged(path, content.as_bytes()) {
        return Ok(false);
    }
    fs::write(path, content)?;
    Ok(true)
}

/// Whether the regular file `path` holds exactly `content`; any failure to tell means no.
fn unchanged(path: &Path, content: &[u8]) -> bool {
    let Ok(file) = fs::File::open(path) else {
        return false;
    };
    if !file
        .metadata()
        .is_ok_and(|m| m.is_file() && m.len() == content.len() as u64)
    {
        return false;
    }
    let mut old = Vec::with_capacity(content.len());
    file.take(content.len() as u64 + 1)
        .read_to_end(&mut old)
        .is_ok_and(|_| old == content)
}

#[cfg(test)]
mod tests {
    use super::module_name;
    use std::path::Path;

    #[test]
    fn module_names_from_file_stems() {
        let name = |p: &str| module_name(Path::new(p));
        assert_eq!(name("specs/paper.toml"), "paper");
        assert_eq!(name("specs/paper-faithful.toml"), "paper_faithful");
        assert_eq!(name("2d.quad.toml"), "_2d_quad");
        assert_eq!(name("type.toml"), "type_");
        assert_eq!(name("drönë.toml"), "dr_n_");
        assert_eq!(name("---.toml"), "controller");
    }
}
