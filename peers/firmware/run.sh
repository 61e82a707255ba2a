#!/usr/bin/env bash
# The peers replay under QEMU, and the code and data each solver adds to the image.
#
#   peers/firmware/run.sh [--board zynq|netduinoplus2] [--solver ours|daqp|active_set] [--sizes] [--data DIR] [PROBLEM ...]
#
# --data DIR replays the dumps in DIR (absolute, or relative to peers/) instead of peers/data/: the
# certificates' worst cold cases of scripts/witness.sh, say.
# PROBLEMs: paper paper-limits quadcopter hover (default: all). Zynq runs them in one image; the
# STM32F405 one image per problem (its 1 MiB of flash holds one problem's dump). Each run prints
# the firmware's RESULT lines (also appended to target/peers-<board>.results) and a table.
# Solvers: ours (the spec's own method: the IPM, the FGM for paper), active_set (the same spec with
# method = "active_set", peers/build.rs; on the STM32F405 in f32 with target = "cortex-m4f" and a
# clock of 1 GHz, since paper-limits' estimate is 161 % of its period at the board's 168 MHz),
# daqp (in single precision on the STM32F405); all three by default; --solver a,b builds those alone.
# The generated solvers' per-solve instructions go to target/peers-<board>.solves (SOLVES lines, this
# run's only) for peers/examples/macs.rs.
# --solver builds the image with that solver alone (hover's image with both does not fit the
# STM32F405's flash: run it once per solver). --sizes also builds each problem with the generated
# solver alone, DAQP alone and neither, and
# prints the differences of `arm-none-eabi-size -A` (the replay's data is in all three).
# Needs: scripts/fetch-daqp.sh, scripts/peers.sh dump, gcc-arm-none-eabi + libnewlib-arm-none-eabi
# (apt-get; installed here when missing), qemu-system-arm, nightly with rust-src.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here"
board=zynq
sizes=0
solver=()
problems=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --board) board="$2"; shift 2 ;;
        --sizes) sizes=1; shift ;;
        --data) export PEERS_DATA="$2"; shift 2 ;;
        --solver) solver=(--no-default-features --features "$2"); shift 2 ;;
        *) problems+=("$1"); shift ;;
    esac
done
[[ ${#problems[@]} -gt 0 ]] || problems=(paper paper-limits quadcopter hover)
case "$board" in
    zynq) target=armv7a-none-eabihf; machine=xilinx-zynq-a9 ;;
    netduinoplus2) target=thumbv7em-none-eabihf; machine=netduinoplus2 ;;
    *) echo "run.sh: unknown board $board (zynq, netduinoplus2)" >&2; exit 2 ;;
esac
if ! command -v arm-none-eabi-gcc >/dev/null || [[ ! -f /usr/lib/arm-none-eabi/include/stdlib.h ]]; then
    apt-get update -qq && apt-get install -y -qq gcc-arm-none-eabi libnewlib-arm-none-eabi
fi
command -v qemu-system-arm >/dev/null || { apt-get update -qq && apt-get install -y -qq qemu-system-arm; }
[[ -f ../daqp/VERSION ]] || ../../scripts/fetch-daqp.sh
unset RUSTUP_TOOLCHAIN
elf="target/$target/release/peers-firmware"
results="target/peers-$board.results"
mkdir -p target

build() { # PROBLEMS FEATURES... (a failed build stops the script: no stale image is run or sized)
    local list="$1"; shift
    local log="target/peers-build.log"
    if ! PEERS_PROBLEMS="$list" cargo build -q --release --target "$target" "$@" 2>"$log"; then
        cat "$log" >&2
        echo "run.sh: cargo build failed ($list $*)" >&2
        exit 1
    fi
    grep -v 'unstable feature\|not stably supported\|^ *|$\|^ *= note\|generated [0-9]* warning\|^$' "$log" >&2 || true
}

run() { # prints the RESULT lines; exit status the firmware's
    timeout 3600 qemu-system-arm -M "$machine" -nographic -monitor none \
        -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" | tr -d '\r'
}

lines=""
if [[ "$board" == zynq ]]; then
    groups=("$(IFS=,; echo "${problems[*]}")")
else
    groups=("${problems[@]}")
fi
status=0
: > "target/peers-$board.solves"
for g in "${groups[@]}"; do
    build "$g" "${solver[@]}"
    out="$(run)" || status=$?
    grep -v '^SOLVES' <<<"$out" || true
    grep '^RESULT' <<<"$out" >> "$results" || true
    grep '^SOLVES' <<<"$out" >> "target/peers-$board.solves" || true
    lines+="$(grep '^RESULT' <<<"$out" || true)"$'\n'
done
python3 "$here/table.py" <<<"$lines"

if [[ $sizes == 1 ]]; then
    for p in "${problems[@]}"; do
        for variant in none ours active_set daqp; do
            if [[ $variant == none ]]; then build "$p" --no-default-features
            else build "$p" --no-default-features --features "$variant"; fi
            echo "SIZE $board $p $variant $(arm-none-eabi-size -A "$elf" | awk '$1 ~ /^\.(text|rodata|data|bss)$/ {printf "%s=%s ", substr($1,2), $2}')"
        done
    done | tee -a "target/peers-$board.sizes" | python3 "$here/table.py" --sizes
fi
exit $status
