//! `mpcc emit`: the module's name, and writing only what changed.

use std::io;
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

/// Writes `content` to `path` unless the file already holds exactly that, so that a build that depends
/// on the file is not redone for nothing (prost-build's `write_file_if_changed`). Returns whether it wrote.
pub(crate) fn write_file_if_changed(path: &Path, content: &str) -> io::Result<bool> {
    if let Ok(old) = std::fs::read(path) {
        if old == content.as_bytes() {
            return Ok(false);
        }
    }
    std::fs::write(path, content)?;
    Ok(true)
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
