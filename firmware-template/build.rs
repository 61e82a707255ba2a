//! Picks the board from the build target, and puts its linker scripts where the linker finds
//! them (`-Tlink.x` in .cargo/config.toml); relinks when they change.
//!
//! | target | board | scripts |
//! | --- | --- | --- |
//! | `armv7a-none-eabihf` | `zynq` (Zynq-7000, Cortex-A9) | `boards/zynq/{memory.x, link.x}` |
//! | `thumbv7em-none-eabihf` | `stm32f405` (Cortex-M4F) | `boards/stm32f405/memory.x`; `link.x` is cortex-m-rt's |

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
        let known: Vec<_> = BOARDS.iter().map(|(t, _, _)| *t).collect();
        panic!("firmware-template has no board for target {target} (known: {known:?})");
    };
    println!("cargo::rustc-cfg=board=\"{board}\"");
    // The generated lane kernels use NEON intrinsics under `cfg(mpc_neon)` (the A9 has NEON; the M4
    // has none). `MPC_NEON=0` builds the portable scalar path instead, to measure the difference.
    println!("cargo::rustc-check-cfg=cfg(mpc_neon)");
    println!("cargo::rerun-if-env-changed=MPC_NEON");
    if board == "zynq" && env::var("MPC_NEON").as_deref() != Ok("0") {
        println!("cargo::rustc-cfg=mpc_neon");
    }
    for script in scripts {
        let src = format!("boards/{board}/{script}");
        fs::copy(&src, out.join(script)).unwrap_or_else(|e| panic!("copying {src}: {e}"));
        println!("cargo::rerun-if-changed={src}");
    }
    println!("cargo::rustc-link-search={}", out.display());
}
