//! The emitted code of every shipped spec is checked in under `generated-examples/generated/`, so that a
//! change to the generator shows in review as a diff of real code. This test runs `mpcc emit` on each
//! `specs/*.toml` and fails when the checked-in file differs; it rewrites the file first (prost's golden
//! files), so `git diff` shows the change and committing it accepts it.

use std::path::Path;
use std::process::Command;

#[test]
fn generated_examples_match_the_generator() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let generated = workspace.join("generated-examples/generated");
    let mut specs: Vec<_> = std::fs::read_dir(workspace.join("specs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    specs.sort();
    assert!(specs.len() >= 3, "the shipped specs: {specs:?}");

    let mut drifted = Vec::new();
    for spec in &specs {
        let stem = spec.file_stem().unwrap().to_str().unwrap();
        // The path as a user in the workspace root types it: it is the only path in the output.
        let shown = format!("specs/{stem}.toml");
        let o = Command::new(env!("CARGO_BIN_EXE_mpcc"))
            .args(["emit", &shown])
            .current_dir(workspace)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "mpcc emit {shown}:\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let now = String::from_utf8(o.stdout).unwrap();
        assert!(
            !now.contains(&*workspace.to_string_lossy()),
            "the emitted text of {shown} holds an absolute path"
        );
        let file = generated.join(format!("{stem}.rs"));
        if std::fs::read_to_string(&file).ok().as_deref() != Some(&now) {
            std::fs::write(&file, &now).unwrap();
            drifted.push(file.strip_prefix(workspace).unwrap().display().to_string());
        }
    }
    let stale: Vec<_> = std::fs::read_dir(&generated)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .filter(|p| {
            let stem = p.file_stem().unwrap().to_str().unwrap();
            !specs.iter().any(|s| s.file_stem().unwrap() == stem)
        })
        .collect();
    assert!(
        stale.is_empty(),
        "generated files without a spec in specs/: {stale:?}"
    );
    assert!(
        drifted.is_empty(),
        "the generator's output changed; the files are rewritten, review `git diff` and commit them: {drifted:?}"
    );
}
