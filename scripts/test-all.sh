#!/usr/bin/env bash
# The whole test suite (the README's test command; .ci/run calls it): the Rust workspace, then
# the Python package built as a wheel from python/ (pyo3 + maturin, abi3), installed into a
# virtual environment under target/, and its pytest suite, which compares the module with the
# `aerorect` binary the first step built. Needs cargo and python3 (>= 3.9) with pip; pip
# fetches maturin, numpy, pytest, rasterio and dask[distributed] on the first run.
# Extra arguments go to pytest (e.g. -k distributed).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
cargo test --workspace --release
cargo build --release -q -p aerorect-cli
venv="$root/target/pyenv"
if [[ ! -x "$venv/bin/python" ]]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q pytest numpy rasterio "dask[distributed]" fsspec
# The wheel, built from this tree in the workspace's own target folder: python/ is a workspace
# member and crates/workspace-hack gives it the features the tests resolved, so maturin compiles
# only pyo3's crates and the extension module again, not the whole tree.
rm -rf "$root/target/wheels"
started=$(date +%s)
CARGO_TARGET_DIR="$root/target" "$venv/bin/pip" wheel -q --no-deps -w "$root/target/wheels" ./python
echo "wheel: $(basename "$root"/target/wheels/aerorect-*.whl) built in $(( $(date +%s) - started )) s"
"$venv/bin/pip" install -q --force-reinstall --no-deps "$root"/target/wheels/aerorect-*.whl
# From target/ so that python/aerorect (the sources, without the native module) is not imported.
cd "$root/target"
AERORECT_BIN="$root/target/release/aerorect" "$venv/bin/python" -m pytest -q -p no:cacheprovider \
    -W ignore::rasterio.errors.NotGeoreferencedWarning "$root/python/tests" "$@"
