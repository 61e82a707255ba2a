#!/usr/bin/env bash
# Builds firmware-template with a controller spec baked in, runs it on the emulated board and exits
# with the firmware's own status (0: the closed loop flew and passed its checks).
#
#   scripts/firmware.sh [--board zynq|netduinoplus2] [--cycles N] [--linear [--start X0] [--reference R]] [--build-only] [--elf-out PATH] [SPEC]
#
# Boards: zynq (default; Zynq-7000, Cortex-A9, QEMU xilinx-zynq-a9, target armv7a-none-eabihf) and
# netduinoplus2 (alias stm32f405; Cortex-M4F, QEMU netduinoplus2, target thumbv7em-none-eabihf).
# SPEC defaults to specs/paper.toml, which the template's `mpc!` reads directly. Any other spec is
# copied to firmware-template/spec-override/spec.toml and built with the `spec-override` feature:
# `mpc!` takes a literal path, and its `include_str!` makes cargo rebuild when that file changes.
# --cycles N flies the first N control cycles of the reference flight instead of all 8671 (built in:
# FIRMWARE_CYCLES). --linear flies the spec's own linear model under its state-feedback controller
# instead of the drone (the `linear` feature, firmware-template/src/linear.rs: from rest to state 2 = 1,
# 100 cycles unless --cycles); it is on by itself when SPEC's model is `type = "linear"`. For a SPEC
# with a [kalman] (e.g. specs/paper.toml with --linear) the controller measures C x through its filter;
# for a SPEC with `[mpc] outputs` the reference is of the tracked outputs, the first at 1.
# --start X0 and --reference R (comma-separated numbers, NX and NR of them; built in: FIRMWARE_START,
# FIRMWARE_REFERENCE) start the linear flight at X0 and hold the reference at R: with --cycles 1 the
# flight is one cold solve there, e.g. a certificate's heaviest cold case (`mpcc check --json`,
# `sampled.cold_witness`; tests/tests/firmware/witness.rs).
# --elf-out copies the built ELF to PATH. One invocation at a time builds (a lock file in the
# template's target/), since all share the template's build directory and spec-override file.
# Missing tools (qemu-system-arm, nightly's rust-src) are installed when possible.
#
# Environment: FIRMWARE_TIMEOUT (seconds for the emulated run, default 600).
set -euo pipefail

usage() { sed -n '2,26p' "$0" | sed 's/^# \{0,1\}//'; }

root=$(cd "$(dirname "$0")/.." && pwd)
template="$root/firmware-template"
board=zynq
build_only=0
elf_out=""
spec=""
cycles=""
linear=0
start=""
reference=""
while [ $# -gt 0 ]; do
    case "$1" in
        --board) [ $# -ge 2 ] || { usage >&2; exit 2; }; board=$2; shift 2 ;;
        --board=*) board=${1#*=}; shift ;;
        --build-only) build_only=1; shift ;;
        --cycles) [ $# -ge 2 ] || { usage >&2; exit 2; }; cycles=$2; shift 2 ;;
        --cycles=*) cycles=${1#*=}; shift ;;
        --linear) linear=1; shift ;;
        --start) [ $# -ge 2 ] || { usage >&2; exit 2; }; start=$2; shift 2 ;;
        --start=*) start=${1#*=}; shift ;;
        --reference) [ $# -ge 2 ] || { usage >&2; exit 2; }; reference=$2; shift 2 ;;
        --reference=*) reference=${1#*=}; shift ;;
        --elf-out) [ $# -ge 2 ] || { usage >&2; exit 2; }; elf_out=$(realpath -m "$2"); shift 2 ;;
        -h|--help) usage; exit 0 ;;
        -*) echo "firmware.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
        *) [ -z "$spec" ] || { echo "firmware.sh: one SPEC only" >&2; exit 2; }; spec=$1; shift ;;
    esac
done

# The target picks the board module (firmware-template/build.rs); the runner for each target is in
# firmware-template/.cargo/config.toml.
case "$board" in
    zynq) target=armv7a-none-eabihf ;;
    netduinoplus2|stm32f405) target=thumbv7em-none-eabihf ;;
    *) echo "firmware.sh: unknown board '$board' (supported: zynq, netduinoplus2)" >&2; exit 2 ;;
esac
qemu=qemu-system-arm

install_missing() {
    if ! command -v "$qemu" >/dev/null 2>&1; then
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "firmware.sh: installing $qemu" >&2
            apt-get update -qq >&2 && apt-get install -y -qq qemu-system-arm >&2
        else
            echo "firmware.sh: $qemu is missing: apt-get install qemu-system-arm" >&2
            exit 2
        fi
    fi
    if ! rustup component list --toolchain nightly --installed 2>/dev/null | grep -q '^rust-src'; then
        echo "firmware.sh: adding rust-src to the nightly toolchain (core is rebuilt for the target)" >&2
        rustup component add rust-src --toolchain nightly >&2
    fi
}
install_missing

mkdir -p "$template/target"
exec 9>"$template/target/.firmware.lock"
flock 9

features=()
if [ -n "$spec" ]; then
    [ -f "$spec" ] || { echo "firmware.sh: no such spec: $spec" >&2; exit 2; }
    mkdir -p "$template/spec-override"
    # Copy only on change: a new mtime alone would rebuild the firmware.
    cmp -s "$spec" "$template/spec-override/spec.toml" || cp "$spec" "$template/spec-override/spec.toml"
    features=(--features spec-override)
    # A linear model: the plant the firmware flies is the spec's own (src/linear.rs).
    grep -Eq '^[[:space:]]*type[[:space:]]*=[[:space:]]*"linear"' "$spec" && linear=1
fi
if [ "$linear" != 1 ] && [ -n "$start$reference" ]; then
    echo "firmware.sh: --start and --reference are the linear flight's (--linear)" >&2; exit 2
fi
if [ "$linear" = 1 ]; then
    [ -n "$spec" ] || { echo "firmware.sh: --linear needs a SPEC with a linear model" >&2; exit 2; }
    features=(--features spec-override,linear)
    # Behind a filter the controller measures C x (firmware-template/src/linear.rs).
    grep -Eq '^[[:space:]]*\[kalman\]' "$spec" && features=(--features spec-override,linear-filter)
    # With tracked outputs the reference is of C_z x (the `linear-outputs` feature).
    grep -Eq '^[[:space:]]*outputs[[:space:]]*=' "$spec" && features=("${features[0]}" "${features[1]},linear-outputs")
fi

cd "$template"
# The outer toolchain (RUSTUP_TOOLCHAIN, exported by rustup to children) would override the
# template's rust-toolchain.toml, and outer RUSTFLAGS would replace its target flags.
cargo_=(env -u RUSTUP_TOOLCHAIN -u RUSTFLAGS -u CARGO_TARGET_DIR -u CARGO_BUILD_TARGET -u FIRMWARE_CYCLES
    -u FIRMWARE_START -u FIRMWARE_REFERENCE)
[ -z "$cycles" ] || cargo_+=("FIRMWARE_CYCLES=$cycles")
[ -z "$start" ] || cargo_+=("FIRMWARE_START=$start")
[ -z "$reference" ] || cargo_+=("FIRMWARE_REFERENCE=$reference")
cargo_+=(cargo +nightly)
"${cargo_[@]}" build --release --target "$target" "${features[@]}"
[ -z "$elf_out" ] || cp "target/$target/release/firmware" "$elf_out"
[ "$build_only" = 1 ] && exit 0
status=0
timeout "${FIRMWARE_TIMEOUT:-600}" "${cargo_[@]}" run --release -q --target "$target" "${features[@]}" || status=$?
[ "$status" = 124 ] && echo "firmware.sh: the firmware did not finish within ${FIRMWARE_TIMEOUT:-600} s" >&2
exit "$status"
