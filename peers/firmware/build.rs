//! As firmware-template's build.rs: picks the board from the target and puts that board's linker
//! scripts (read from ../../firmware-template/boards/) where the linker finds them.

use std::{env, fs, path::PathBuf};

const BOARDS: [(&str, &str, &[&str]); 2] = [
    ("armv7a-none-eabihf", "zynq", &["memory.x", "link.x"]),
    ("thumbv7em-none-eabihf", "stm32f405", &["memory.x"]),
];

fn main() {
    let target = env::var("TARGET").expect("cargo sets TARGET");
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo::rustc-check-cfg=cfg(board, values(\"zynq\", \"stm32f405\"))");
    let Some(&(_, board, scripts)) = BOARDS.iter().find(|(t, _, _)| *t == target) else {
        panic!("peers-firmware has no board for target {target}");
    };
    println!("cargo::rustc-cfg=board=\"{board}\"");
    for script in scripts {
        let src = format!("../../firmware-template/boards/{board}/{script}");
        fs::copy(&src, out.join(script)).unwrap_or_else(|e| panic!("copying {src}: {e}"));
        println!("cargo::rerun-if-changed={src}");
    }
    println!("cargo::rustc-link-search={}", out.display());
}
