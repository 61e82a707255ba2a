#!/usr/bin/env bash
# How long `cargo build` takes for a crate whose only content is one `mpc!` controller, for a sweep of
# horizons: specs/paper.toml with only `horizon` changed (and `[codegen] emission` if given). The
# dependencies (mpc-macros, codegen, nalgebra...) are built once first; each timed build then compiles
# the one crate: the macro's lowering and emission, and rustc on the generated module.
#
#   scripts/compile-times.sh [--profile dev|release] [--emission NAME] [HORIZON...]
#
# HORIZONs default to 5 15 30 60 100. Prints a Markdown table: N, the emission `auto` chose (or the
# forced one), wall seconds of `cargo build`, and the size of the generated module's source.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
profile=release
emission=""
horizons=()
while [ $# -gt 0 ]; do
    case "$1" in
        --profile) profile=$2; shift 2 ;;
        --emission) emission=$2; shift 2 ;;
        -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        -*) echo "compile-times.sh: unknown option $1" >&2; exit 2 ;;
        *) horizons+=("$1"); shift ;;
    esac
done
[ ${#horizons[@]} -gt 0 ] || horizons=(5 15 30 60 100)
flag=()
[ "$profile" = release ] && flag=(--release)

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/src"
cat > "$tmp/Cargo.toml" <<EOF
[package]
name = "compile-time-probe"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
mpc-macros = { path = "$root/mpc-macros" }

[workspace]
EOF
spec() {
    sed -E "s/^horizon *=.*/horizon = $1/" "$root/specs/paper.toml" > "$tmp/spec.toml"
    if [ -n "$emission" ]; then
        sed -i -E "s/^\[codegen\]/[codegen]\nemission = \"$emission\"/" "$tmp/spec.toml"
    fi
}
cat > "$tmp/src/lib.rs" <<'EOF'
#![no_std]
mpc_macros::mpc!(pub mod controller = "spec.toml");
EOF
export CARGO_TARGET_DIR="$tmp/target"
spec 5
cargo build -q "${flag[@]}" --manifest-path "$tmp/Cargo.toml" 2>/dev/null

echo "| N | emission | cargo build ($profile), s | generated module, KiB |"
echo "| --- | --- | --- | --- |"
for n in "${horizons[@]}"; do
    spec "$n"
    touch "$tmp/src/lib.rs"
    start=$(date +%s.%N)
    cargo build -q "${flag[@]}" --manifest-path "$tmp/Cargo.toml"
    end=$(date +%s.%N)
    chosen=$(cargo run -q --manifest-path "$root/Cargo.toml" -p mpcc -- check --json "$tmp/spec.toml" \
        | grep -o '"emission": *"[a-z_]*"' | head -1 | cut -d'"' -f4 || true)
    kib=$(cargo run -q --manifest-path "$root/Cargo.toml" -p mpcc -- emit "$tmp/spec.toml" | wc -c)
    printf '| %s | %s | %.1f | %d |\n' "$n" "$chosen" "$(python3 -c "print($end - $start)")" "$((kib / 1024))"
done
