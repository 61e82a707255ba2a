#!/usr/bin/env bash
# The worst cold case of each problem's sampled certificate, replayed on an emulated board, against the
# build's estimate of a cold solve (docs/methods.md, "The worst case on the boards").
#
#   scripts/witness.sh [--board zynq|netduinoplus2] [PROBLEM ...]   # default: paper paper-limits quadcopter hover
#
# For each problem, the active set's copy of its spec that peers/ builds for the board
# (`cargo run --example copy`; f32 on the STM32F405), `mpcc dump-qp --witness` of it into
# peers/witness/<board>/ (one step: the state and constant reference of the sample's worst cold case),
# and `mpcc check --json` of it (on the Zynq with `target = "cortex-a9"` added, the copy's own
# elsewhere) for the estimate. Then peers/firmware/run.sh replays the dumps, each solve a cold one (a
# fresh controller), and a table (scripts/witness_table.py) compares the instructions measured with the
# estimate: the solver's cycles at the cold cap (COLD_ITERATIONS changes) plus the rest of the step, over
# the target's cycles per instruction.
# Needs what peers/firmware/run.sh needs.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
board=zynq
problems=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --board) board="$2"; shift 2 ;;
        *) problems+=("$1"); shift ;;
    esac
done
[[ ${#problems[@]} -gt 0 ]] || problems=(paper paper-limits quadcopter hover)
out="$root/peers/witness/$board"
mkdir -p "$out"
cargo build -q --release -p mpcc --manifest-path "$root/Cargo.toml"
mpcc="$root/target/release/mpcc"
for p in "${problems[@]}"; do
    (cd "$root/peers" && cargo run -q --release --example copy -- "$p" "$board") > "$out/$p.toml"
    check="$out/$p.toml"
    if [[ $board == zynq ]]; then
        check="$out/$p-a9.toml"
        python3 - "$out/$p.toml" "$check" <<'PY'
import sys
text = open(sys.argv[1]).read()
if "\n[codegen]\n" in text:
    text = text.replace("\n[codegen]\n", '\n[codegen]\ntarget = "cortex-a9"\n', 1)
else:
    text += '\n[codegen]\ntarget = "cortex-a9"\n'
open(sys.argv[2], "w").write(text)
PY
    fi
    "$mpcc" dump-qp --witness "$out/$p.toml" -o "$out/$p.json"
    "$mpcc" check --json "$check" > "$out/$p.check.json"
done

# The image holds the generated active set alone.
"$root/peers/firmware/run.sh" --board "$board" --solver active_set --data "$out" "${problems[@]}" \
    | tee "$out/replay.txt"
python3 "$root/scripts/witness_table.py" "$out" "$root/peers/firmware/target/peers-$board.solves" "${problems[@]}"
