#!/usr/bin/env bash
# Records what `mpcc` prints for every shipped, test, emission, bench and firmware spec, so that a refactor
# of codegen can be checked byte for byte (issue 32, item 4):
#
#     cargo build --release -p mpcc
#     scripts/emit-baseline.sh /tmp/before          # on the commit before the change
#     scripts/emit-baseline.sh /tmp/after           # after it
#     diff -r /tmp/before /tmp/after && echo identical
#
# For each spec it runs `mpcc emit SPEC`, `mpcc check SPEC` and `mpcc check --json SPEC` and writes
# OUTDIR/<spec path, / as __>.<emit|check|json>: stdout, then stderr and the exit code after a marker
# line, so a refused spec's diagnostics are compared too. MPCC (default target/release/mpcc) and JOBS
# (default 2) may be set; the specs run JOBS at a time, the certified ones take tens of seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/emit-baseline.sh OUTDIR}
mpcc=${MPCC:-target/release/mpcc}
jobs=${JOBS:-2}
[ -x "$mpcc" ] || { echo "no $mpcc: run cargo build --release -p mpcc" >&2; exit 2; }
mkdir -p "$out"

specs() {
    ls specs/*.toml tests/specs/*.toml tests/specs/mixed/*.toml tests/specs/emission/*.toml \
        tests/benches/specs/*.toml tests/fuzz-corpus/*.toml firmware-template/specs/*.toml
    find codegen/tests tests/tests/firmware -name '*.toml' ! -name Cargo.toml
}

run_one() {
    spec=$1
    name=$(echo "$spec" | sed 's|/|__|g')
    for mode in emit check json; do
        case $mode in
            emit) args=(emit "$spec") ;;
            check) args=(check "$spec") ;;
            json) args=(check --json "$spec") ;;
        esac
        file="$OUT/$name.$mode"
        code=0
        "$MPCC" "${args[@]}" >"$file" 2>"$file.stderr" || code=$?
        { echo "=== stderr"; cat "$file.stderr"; echo "=== exit $code"; } >>"$file"
        rm "$file.stderr"
    done
    echo "$spec"
}
export -f run_one
export OUT=$out MPCC=$mpcc

specs | sort -u | xargs -P "$jobs" -I{} bash -c 'run_one "$@"' _ {}
echo "$(specs | sort -u | wc -l) specs recorded in $out"
