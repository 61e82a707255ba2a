#!/usr/bin/env bash
# Instructions per control cycle, code/data size and stack of the firmware for a sweep of MPC
# horizons: specs/paper.toml with only `horizon` changed, each built and flown on the emulated board
# with scripts/firmware.sh. Prints a Markdown table (the one in BENCHMARKS.md).
#
#   scripts/firmware-horizons.sh [--board zynq|netduinoplus2] [--spec SPEC] [--scalar f32|f64]
#                                [--emission auto|unrolled|table|lanes|matrix_free] [--csv FILE] [HORIZON...]
#
# HORIZONs default to 5 10 15 20 25 30. `--scalar` and `--emission` rewrite `[codegen]`; MPC_NEON=0 in
# the environment builds the A9 firmware without its NEON kernels. `--csv` also appends
# `board,scalar,emission,neon,N,instructions,text,rodata` rows to FILE (for the plot in BENCHMARKS.md). The temporary specs live in a temporary folder; the table
# names the base spec. Instructions = mean timer ticks per cycle × the board's instructions per tick
# under `-icount shift=0` (10 on the Zynq's global timer, 1 on the STM32F405's TIM2).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
board=zynq
base="$root/specs/paper.toml"
horizons=()
scalar=""
emission=""
csv=""
while [ $# -gt 0 ]; do
    case "$1" in
        --board) board=$2; shift 2 ;;
        --board=*) board=${1#*=}; shift ;;
        --spec) base=$2; shift 2 ;;
        --scalar) scalar=$2; shift 2 ;;
        --emission) emission=$2; shift 2 ;;
        --csv) csv=$(realpath -m "$2"); shift 2 ;;
        -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        -*) echo "firmware-horizons.sh: unknown option $1" >&2; exit 2 ;;
        *) horizons+=("$1"); shift ;;
    esac
done
[ ${#horizons[@]} -gt 0 ] || horizons=(5 10 15 20 25 30)
case "$board" in
    zynq) per_tick=10 ;;
    netduinoplus2|stm32f405) per_tick=1 ;;
    *) echo "firmware-horizons.sh: unknown board '$board'" >&2; exit 2 ;;
esac
grep -Eq '^horizon *=' "$base" || { echo "firmware-horizons.sh: no 'horizon =' line in $base" >&2; exit 2; }
size=$(command -v llvm-size || ls /usr/bin/llvm-size-* 2>/dev/null | sort -V | tail -1)
[ -n "$size" ] || { echo "firmware-horizons.sh: llvm-size is missing (apt-get install llvm)" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { grep -o "\"$1\":[0-9]*" "$tmp/out" | tail -1 | cut -d: -f2; }
section() { "$size" -A -d "$tmp/elf" | awk -v s="$1" '$1 == s { print $2 }' | grep . || echo 0; }

echo "| N | ticks per cycle (min / mean / max) | instructions per cycle | .text B | .rodata B | .data + .bss B | stack B (run / control cycle) |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for n in "${horizons[@]}"; do
    sed -E "s/^horizon *=.*/horizon = $n/" "$base" > "$tmp/spec-n$n.toml"
    if [ -n "$scalar" ]; then
        sed -i -E "s/^scalar *=.*/scalar = \"$scalar\"/" "$tmp/spec-n$n.toml"
    fi
    if [ -n "$emission" ]; then
        sed -i -E "s/^\[codegen\]/[codegen]\nemission = \"$emission\"/" "$tmp/spec-n$n.toml"
    fi
    status=0
    bash "$root/scripts/firmware.sh" --board "$board" --elf-out "$tmp/elf" "$tmp/spec-n$n.toml" \
        > "$tmp/out" 2> "$tmp/err" || status=$?
    if [ "$status" != 0 ] || ! grep -q '^RESULT .*"ok":true' "$tmp/out"; then
        echo "firmware-horizons.sh: horizon $n failed (status $status)" >&2
        tail -20 "$tmp/err" "$tmp/out" >&2
        exit 1
    fi
    mean=$(field ticks_mean)
    echo "| $n | $(field ticks_min) / $mean / $(field ticks_max) | $((mean * per_tick)) |" \
         "$(section .text) | $(section .rodata) | $(( $(section .data) + $(section .bss) )) |" \
         "$(field stack_bytes) / $(field cycle_stack_bytes) |"
    if [ -n "$csv" ]; then
        chosen=$(cargo run -q --manifest-path "$root/Cargo.toml" -p mpcc -- check --json "$tmp/spec-n$n.toml" \
            | grep -o '"emission": *"[a-z_]*"' | head -1 | cut -d'"' -f4 || true)
        echo "$board,$(grep -o '"scalar":"[a-z0-9]*"' "$tmp/out" | cut -d'"' -f4),$chosen,${MPC_NEON:-1},$n,$((mean * per_tick)),$(section .text),$(section .rodata)" >> "$csv"
    fi
done
