#!/usr/bin/env bash
# Sets up and runs every test against the installed wheel, not the source tree: the Rust core's
# cargo tests; then a release wheel built by maturin, installed with its test extra (which holds
# the evaluation extra) into a fresh virtual environment, and the pytest suite run from a folder
# outside the repository (the default run excludes tests marked slow; add `-m slow` to this
# script's arguments for those).
#
# Set-up first (scripts/_setup.sh): on Debian/Ubuntu the system packages the tests need, libllvm19
# (Mitsuba's llvm_ad_rgb variant) and mesa-vulkan-drivers (a Vulkan adapter for the GPU tests),
# are installed when missing, as root or with passwordless sudo; otherwise the script stops at
# once with the one command to run. A missing Rust toolchain stops it with the rustup line.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${SOFTSHADOWS_TEST_VENV:-$repo/.venv-test}"
cd "$repo"

SS_NAME=scripts/test.sh
# shellcheck source=scripts/_setup.sh
. "$repo/scripts/_setup.sh"
ss_setup libllvm19 mesa-vulkan-drivers

cargo test -q --release -p softshadows-core
# The core without its GPU half compiles, and every GPU method refuses backend="gpu" cleanly.
cargo test -q --release -p softshadows-core --no-default-features --test no_gpu
# The core's documentation, read with its private items, builds without a warning (no broken link).
RUSTDOCFLAGS="-D warnings" cargo doc -q --no-deps -p softshadows-core --document-private-items

# maturin goes into the test environment too: the system Python may refuse pip (PEP 668).
python3 -m venv --clear "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.7,<2"
rm -rf dist
"$venv/bin/python" -m maturin build --release --quiet -o dist
"$venv/bin/python" -m pip install -q --disable-pip-version-check "$(ls dist/softshadows-*.whl)[test]"

outside="$(mktemp -d)"
trap 'rm -rf "$outside"' EXIT
cd "$outside"
"$venv/bin/python" - "$repo" <<'PY'
import pathlib, sys, softshadows
where = pathlib.Path(softshadows.__file__).resolve()
assert pathlib.Path(sys.argv[1], "python") not in where.parents, f"softshadows imported from the source tree: {where}"
print(f"testing the installed wheel: {where.parent}")
PY
"$venv/bin/python" -m pytest -q -c "$repo/pyproject.toml" --rootdir "$repo" -p no:cacheprovider "$@" "$repo/tests"
