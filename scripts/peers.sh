#!/usr/bin/env bash
# Peers on the same QPs (issue 19): DAQP against the generated solvers.
#
#   scripts/peers.sh dump                  # mpcc dump-qp of the four specs into peers/data/
#   scripts/peers.sh accuracy              # host: iterations and |U − U*|∞ per solver and problem
#   scripts/peers.sh bench [ARGS]          # host: criterion, per-solve time (ARGS go to criterion)
#   scripts/peers.sh firmware [--board zynq|netduinoplus2] [PROBLEMS]
#                                          # QEMU: instructions, accuracy, stack, sizes per solve
#
# DAQP's sources come from scripts/fetch-daqp.sh (run first; it verifies the archive's sha256).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
cmd="${1:-}"
shift || true

# The closed loops: the start and the constant reference of each spec (those of
# tests/benches/constrained.rs for the constrained ones; the paper's a 3.7 m step like paper-limits).
dump() {
    mkdir -p peers/data
    cargo build -q --release -p mpcc
    local mpcc=target/release/mpcc
    $mpcc dump-qp specs/paper.toml --reference 3,2,1,0,0,0 -o peers/data/paper.json
    $mpcc dump-qp specs/paper-limits.toml --reference 3,2,1,0,0,0 -o peers/data/paper-limits.json
    $mpcc dump-qp specs/quadcopter.toml --reference 0,0,1,0,0,0,0,0,0,0,0,0 -o peers/data/quadcopter.json
    $mpcc dump-qp specs/hover.toml --x0 0,1,0,0.2,0,0,0.1,0,0,0,0,0 \
        --reference 0,0,2,0,0,0,0,0,0,0,0,0 -o peers/data/hover.json
    ls -l peers/data
}

case "$cmd" in
    dump) dump ;;
    accuracy) (cd peers && cargo run -q --release --bin accuracy) ;;
    bench)
        # `scripts/peers.sh bench -- --warm-up-time 1`: one `--` for cargo, not two.
        [[ "${1:-}" != "--" ]] || shift
        (cd peers && cargo bench --bench peers -- "$@")
        ;;
    firmware) exec "$root/peers/firmware/run.sh" "$@" ;;
    *)
        sed -n '2,11p' "$0"
        exit 2
        ;;
esac
