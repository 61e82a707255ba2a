#!/usr/bin/env bash
# Fetches DAQP's C sources (MIT, Daniel Arnström) from its PyPI source distribution, pinned by version
# and sha256, into peers/daqp/ (gitignored): csrc/ (src/*.c, include/*.h) and LICENSE.
#
#   scripts/fetch-daqp.sh            # once; peers/ (host) and peers/firmware (QEMU) build from it
#
# Nothing in `cargo test --workspace` needs it: peers/ is outside the workspace.
set -euo pipefail
VERSION=0.11.0
SHA256=2f27baf18d2acca14186498e651b34e0bed455627e777d3fd8ba655e7e40f920
root="$(cd "$(dirname "$0")/.." && pwd)"
dest="$root/peers/daqp"
if [[ -f "$dest/VERSION" && "$(cat "$dest/VERSION")" == "$VERSION $SHA256" ]]; then
    echo "fetch-daqp: $dest already holds daqp $VERSION"
    exit 0
fi
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
archive="$tmp/daqp-$VERSION.tar.gz"
# pip downloads the sdist; preparing its metadata builds it with setuptools, cython and wheel, which pip
# fetches into an isolated environment (PyPI only).
python3 -m pip download --quiet --no-deps --no-binary :all: "daqp==$VERSION" -d "$tmp" ||
    python3 -m pip download --quiet --no-deps --no-build-isolation --no-binary :all: "daqp==$VERSION" -d "$tmp"
echo "$SHA256  $archive" | sha256sum --check --quiet || {
    echo "fetch-daqp: sha256 of daqp-$VERSION.tar.gz differs from the pinned $SHA256" >&2
    exit 1
}
tar -xzf "$archive" -C "$tmp"
rm -rf "$dest"
mkdir -p "$dest"
cp -r "$tmp/daqp-$VERSION/csrc" "$dest/csrc"
cp "$tmp/daqp-$VERSION/LICENSE" "$dest/LICENSE"
echo "$VERSION $SHA256" > "$dest/VERSION"
echo "fetch-daqp: daqp $VERSION ($SHA256) in $dest"
