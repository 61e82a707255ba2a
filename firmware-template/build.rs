//! Puts the linker scripts where the linker finds them (`-Tlink.x` in .cargo/config.toml), and
//! relinks when they change.

use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    for script in ["memory.x", "link.x"] {
        fs::copy(script, out.join(script)).unwrap_or_else(|e| panic!("copying {script}: {e}"));
        println!("cargo:rerun-if-changed={script}");
    }
    println!("cargo:rustc-link-search={}", out.display());
}
