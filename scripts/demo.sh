#!/usr/bin/env bash
# Sets up softshadows and runs its demo; the pictures and tables land in ${1:-demo}.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install -q --disable-pip-version-check ".[models]"
softshadows demo --out "${1:-demo}"
