#!/usr/bin/env bash
# Sets up and runs every test: the Rust core's cargo tests, then the installed package's pytest
# suite (the default run excludes tests marked slow; run `python -m pytest -m slow` for those).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install -q --disable-pip-version-check ".[test]"
cargo test -q --release -p softshadows-core
python3 -m pytest -q
