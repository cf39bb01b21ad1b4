#!/usr/bin/env bash
# Sets up and runs every test against the installed wheel, not the source tree: the Rust core's
# cargo tests; then a release wheel built by maturin, installed with its test extra into a fresh
# virtual environment, and the pytest suite run from a folder outside the repository (the default
# run excludes tests marked slow; add `-m slow` to this script's arguments for those).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${SOFTSHADOWS_TEST_VENV:-$repo/.venv-test}"
cd "$repo"

cargo test -q --release -p softshadows-core

python3 -m pip install -q --disable-pip-version-check "maturin>=1.7,<2"
rm -rf dist
python3 -m maturin build --release --quiet -o dist
python3 -m venv --clear "$venv"
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
