#!/usr/bin/env bash
# rustc's time and memory on emitted modules, the calibration of codegen::budget's rustc model (docs/methods.md,
# "Budgets"): the paper's spec at horizons 30 and 100 (tables), and dense `linear` plants with a
# time-varying filter, nx = 12 and 24 (unrolled code; a fixed-seed generator below). For each it prints the
# emitted source's bytes, `mpcc check`'s predicted rustc time and memory, and rustc's measured ones
# (`/usr/bin/time`, `rustc -C opt-level=3` on the module alone). nx = 24 takes about two minutes.
#
#   scripts/rustc-cost.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
command -v /usr/bin/time >/dev/null || { echo "rustc-cost.sh: needs /usr/bin/time (apt-get install time)" >&2; exit 2; }
(cd "$root" && cargo build -q -p mpcc)
mpcc="$root/target/debug/mpcc"

for n in 30 100; do
    sed "s/horizon = 15/horizon = $n/" "$root/specs/paper.toml" > "$work/paper-n$n.toml"
done
python3 - "$work" <<'PY'
import random, sys
work = sys.argv[1]
random.seed(1)
for n in [12, 24]:
    m, p = 4, 4
    A = [[(0.9 if i == j else 0) + random.uniform(-0.02, 0.02) for j in range(n)] for i in range(n)]
    B = [[random.uniform(-0.1, 0.1) for j in range(m)] for i in range(n)]
    C = [[1.0 if j == i else random.uniform(-0.05, 0.05) for j in range(n)] for i in range(p)]
    fmt = lambda M: '[' + ', '.join('[' + ', '.join('%.4f' % v for v in r) + ']' for r in M) + ']'
    diag = lambda k, v: '[' + ', '.join('[' + ', '.join(('%g' % v) if i == j else '0' for j in range(k)) + ']' for i in range(k)) + ']'
    open(f'{work}/dense-nx{n}.toml', 'w').write(f'''[model]
type = "linear"
dt = 0.1
a = {fmt(A)}
b = {fmt(B)}
c = {fmt(C)}
[mpc]
horizon = 10
iterations = 20
q = {[1] * n}
r = {[0.1] * m}
u_min = {[-1] * m}
u_max = {[1] * m}
[kalman]
q = {diag(n, 0.01)}
r = {diag(p, 0.04)}
''')
PY

echo "| module | source, bytes | predicted rustc | measured rustc |"
echo "| --- | --- | --- | --- |"
for spec in paper-n30 paper-n100 dense-nx12 dense-nx24; do
    "$mpcc" emit "$work/$spec.toml" > "$work/$spec.rs"
    printf '#![no_std]\ninclude!("%s.rs");\n' "$spec" > "$work/lib-$spec.rs"
    predicted=$("$mpcc" check "$work/$spec.toml" | awk -F'  +' '/rustc on the module: time/ {t=$3} /rustc on the module: memory/ {m=$3} END {print t ", " m}')
    measured=$(cd "$work" && /usr/bin/time -f "%e s, %M KB" rustc --edition 2021 --crate-type lib -C opt-level=3 \
        "lib-$spec.rs" -o "$work/lib-$spec.rlib" 2>&1 | tail -1)
    echo "| $spec | $(wc -c < "$work/$spec.rs") | $predicted | $measured |"
done
