#!/usr/bin/env bash
# Builds the C firmware (firmware-template/c/: the template's linear mode written in C over a
# controller's C API) for SPEC, links it with arm-none-eabi-gcc and newlib, runs it on the emulated
# board and exits with the firmware's own status (0: the loop flew and passed its checks).
#
#   scripts/c-firmware.sh [--board netduinoplus2|zynq] [--cycles N] [--crate DIR] [--build-only] [--elf-out PATH] SPEC
#
# Boards: netduinoplus2 (default; alias stm32f405; Cortex-M4F, QEMU netduinoplus2, thumbv7em-none-eabihf:
# stm32f405.c and .ld) and zynq (Zynq-7000, Cortex-A9 with NEON, QEMU xilinx-zynq-a9, armv7a-none-eabihf:
# zynq.S, zynq.c and zynq.ld). The controller's C crate is written by `mpcc emit SPEC --c DIR --target
# TRIPLE` into firmware-template/target/c/BOARD/NAME, unless --crate DIR names one already written for that
# target (the tests write theirs with codegen::c_api). Its static library is built as the Rust firmware
# builds the controller: nightly, core rebuilt from rust-src (-Z build-std=core), the board's -C
# target-cpu (on the A9 with NEON and its kernels, `--cfg mpc_neon`), opt-level 3, LTO, one codegen unit. --cycles N flies N cycles instead
# of 100 (scripts/firmware.sh's --cycles in the linear mode). --elf-out copies the ELF to PATH.
#
# Environment: FIRMWARE_TIMEOUT (seconds for the emulated run, default 600), MPCC (a built mpcc to
# run instead of `cargo run -p mpcc`).
set -euo pipefail

usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/.." && pwd)
template="$root/firmware-template"
board=netduinoplus2
build_only=0
elf_out=""
spec=""
cycles=""
crate=""
while [ $# -gt 0 ]; do
    case "$1" in
        --board) [ $# -ge 2 ] || { usage >&2; exit 2; }; board=$2; shift 2 ;;
        --board=*) board=${1#*=}; shift ;;
        --build-only) build_only=1; shift ;;
        --cycles) [ $# -ge 2 ] || { usage >&2; exit 2; }; cycles=$2; shift 2 ;;
        --cycles=*) cycles=${1#*=}; shift ;;
        --crate) [ $# -ge 2 ] || { usage >&2; exit 2; }; crate=$(realpath -m "$2"); shift 2 ;;
        --crate=*) crate=$(realpath -m "${1#*=}"); shift ;;
        --elf-out) [ $# -ge 2 ] || { usage >&2; exit 2; }; elf_out=$(realpath -m "$2"); shift 2 ;;
        -h|--help) usage; exit 0 ;;
        -*) echo "c-firmware.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
        *) [ -z "$spec" ] || { echo "c-firmware.sh: one SPEC only" >&2; exit 2; }; spec=$1; shift ;;
    esac
done
[ -n "$spec" ] || { echo "c-firmware.sh: no SPEC" >&2; usage >&2; exit 2; }
[ -f "$spec" ] || { echo "c-firmware.sh: no such spec: $spec" >&2; exit 2; }
if [ -n "$cycles" ] && ! [[ "$cycles" =~ ^[1-9][0-9]*$ ]]; then
    echo "c-firmware.sh: --cycles takes a positive number, not '$cycles'" >&2
    exit 2
fi
case "$board" in
    netduinoplus2|stm32f405)
        board=netduinoplus2; target=thumbv7em-none-eabihf; machine=netduinoplus2
        cpu=(-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard)
        rustflags="-C target-cpu=cortex-m4"
        sources=("$template/c/stm32f405.c"); script="$template/c/stm32f405.ld" ;;
    zynq)
        target=armv7a-none-eabihf; machine=xilinx-zynq-a9
        cpu=(-mcpu=cortex-a9 -marm -mfpu=neon-vfpv3 -mfloat-abi=hard -DBOARD_ZYNQ)
        rustflags="-C target-cpu=cortex-a9 -C target-feature=+neon,+vfp3 --cfg mpc_neon"
        sources=("$template/c/zynq.S" "$template/c/zynq.c"); script="$template/c/zynq.ld" ;;
    *) echo "c-firmware.sh: unknown board '$board' (supported: netduinoplus2, zynq)" >&2; exit 2 ;;
esac

for tool in arm-none-eabi-gcc qemu-system-arm; do
    command -v "$tool" >/dev/null 2>&1 || {
        echo "c-firmware.sh: $tool is missing: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm" >&2
        exit 2
    }
done
if ! rustup component list --toolchain nightly --installed 2>/dev/null | grep -q '^rust-src'; then
    echo "c-firmware.sh: adding rust-src to the nightly toolchain (core is rebuilt for the target)" >&2
    rustup component add rust-src --toolchain nightly >&2
fi

spec_abs=$(realpath "$spec")
# The spec as RESULT names it: relative to the repository when inside it.
case "$spec_abs" in
    "$root"/*) spec_name=${spec_abs#"$root"/} ;;
    *) spec_name=$spec_abs ;;
esac
clean=(env -u RUSTUP_TOOLCHAIN -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_TARGET_DIR -u CARGO_BUILD_TARGET)
if [ -z "$crate" ]; then
    name=$(basename "$spec_abs" .toml | tr -c 'A-Za-z0-9_\n' '_')
    crate="$template/target/c/$board/$name"
    mkdir -p "$crate"
    if [ -n "${MPCC:-}" ]; then
        "$MPCC" emit "$spec_abs" --c "$crate" --target "$target" >/dev/null
    else
        (cd "$root" && cargo run -q -p mpcc -- emit "$spec_abs" --c "$crate" --target "$target" >/dev/null)
    fi
fi
header=$(find "$crate" -maxdepth 1 -name '*.h' | head -n 1)
[ -n "$header" ] || { echo "c-firmware.sh: no header NAME.h in $crate" >&2; exit 2; }
name=$(basename "$header" .h)
up=$(echo "$name" | tr 'a-z' 'A-Z')

# The static library, with the Rust firmware's code generation (firmware-template/.cargo/config.toml
# and Cargo.toml's release profile; the crate's own profile has opt-level 3, LTO, one codegen unit).
# compiler_builtins without its `mem` feature: memcpy and memset come from newlib.
(cd "$crate" && "${clean[@]}" RUSTFLAGS="$rustflags" \
    cargo +nightly build --release --quiet --target "$target" -Z build-std=core)
lib="$crate/target/$target/release/lib$name.a"
[ -f "$lib" ] || { echo "c-firmware.sh: cargo built no $lib" >&2; exit 1; }

out="$crate/target/c-firmware"
mkdir -p "$out"
cp "$spec_abs" "$out/spec.toml"
elf="$out/firmware.elf"
arm-none-eabi-gcc -std=c11 "${cpu[@]}" -O2 -ffp-contract=off -Wall -Wextra -Werror \
    -ffunction-sections -fdata-sections \
    -I "$crate" -I "$template/c" -Wa,-I,"$out" \
    -DCTL="$name" -DCTL_UP="$up" -DHEADER="\"$name.h\"" -DSPEC_PATH="\"$spec_name\"" \
    ${cycles:+-DCYCLES=$cycles} \
    "$template/c/main.c" "${sources[@]}" "$lib" \
    -T "$script" -nostartfiles --specs=nano.specs --specs=nosys.specs \
    -Wl,--gc-sections -o "$elf"
[ -z "$elf_out" ] || cp "$elf" "$elf_out"
[ "$build_only" = 1 ] && exit 0
status=0
timeout "${FIRMWARE_TIMEOUT:-600}" qemu-system-arm -M "$machine" -nographic -monitor none \
    -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" || status=$?
[ "$status" = 124 ] && echo "c-firmware.sh: the firmware did not finish within ${FIRMWARE_TIMEOUT:-600} s" >&2
exit "$status"
