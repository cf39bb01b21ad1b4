#!/usr/bin/env bash
# Sets up softshadows and runs its demo; the pictures and tables land in ${1:-demo}.
#
# Set-up (scripts/_setup.sh): on Debian/Ubuntu, libllvm19 for Mitsuba's fast llvm_ad_rgb variant,
# installed when it is missing and this script may (root, or passwordless sudo); otherwise the
# demo still runs, its reference on Mitsuba's slower scalar_rgb variant, after a note with the
# command that gets the fast one. A missing Rust toolchain stops it with the rustup line. Then
# softshadows[evaluation,models] is built from this checkout into the virtual environment
# .venv-demo (SOFTSHADOWS_DEMO_VENV), whose `softshadows demo` writes the results.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${SOFTSHADOWS_DEMO_VENV:-$repo/.venv-demo}"
cd "$repo"

SS_NAME=scripts/demo.sh
# shellcheck source=scripts/_setup.sh
. "$repo/scripts/_setup.sh"
ss_setup --optional libllvm19
if [ "${#SS_MISSING_OPTIONAL[@]}" -gt 0 ]; then
  ss_note "libllvm19 is not installed, so the Mitsuba reference will run on the scalar_rgb variant: the same" \
    "result, several times slower (minutes). For the fast llvm_ad_rgb variant, run once: $(ss_apt_command libllvm19)"
fi

[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check ".[evaluation,models]"
"$venv/bin/softshadows" demo --out "${1:-demo}"
