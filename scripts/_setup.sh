# shellcheck shell=bash
# The set-up shared by scripts/demo.sh and scripts/test.sh (sourced, not run).
#
#   SS_NAME=scripts/x.sh; . scripts/_setup.sh; ss_setup [--optional PKG]... [PKG]...
#
# On Debian/Ubuntu, ss_setup installs the named system packages that are missing (checked with
# `dpkg -s`), with apt-get, when it can: as root, or with passwordless sudo (`sudo -n true`).
# When it cannot, a missing required PKG stops the script at once with the one command to run
# (`sudo apt-get install -y PKG...`); a missing optional one is left in SS_MISSING_OPTIONAL for
# the script to explain. To the named packages it adds what building softshadows needs, when that
# is missing: a C linker for rustc (build-essential), python3 -m venv (python3-venv), and curl
# when Rust itself is missing (for the rustup line). A missing Rust toolchain (cargo, rustc)
# stops the script with the rustup install line; rustup's default folder ~/.cargo/bin is tried
# first, for a shell started before rustup put it on PATH. Python must be >= 3.10.
#
# SOFTSHADOWS_NO_INSTALL=1 never installs anything: the script then stops (or notes) with the
# command to run, as for a user without root. Off Debian/Ubuntu (no dpkg or apt-get) the packages
# are not checked; a note names them.

SS_NAME="${SS_NAME:-$(basename "${BASH_SOURCE[1]:-$0}")}"
SS_MISSING_OPTIONAL=()
SS_AS=()
SS_APT_UPDATED=0

#: The rustup install line, the one command to run when Rust is missing.
SS_RUSTUP="curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y"

ss_note() {
  printf '%s: %s\n' "$SS_NAME" "$*" >&2
}

# The packages among "$@" that dpkg does not list as installed, one a line.
ss_missing_packages() {
  local pkg status
  for pkg in "$@"; do
    status="$(dpkg -s "$pkg" 2>/dev/null || true)"
    case "$status" in
      *"Status: install ok installed"*) ;;
      *) printf '%s\n' "$pkg" ;;
    esac
  done
}

# Succeeds when this script may install system packages, setting SS_AS to the prefix (none as
# root, `sudo -n` with passwordless sudo).
ss_can_install() {
  SS_AS=()
  [ "${SOFTSHADOWS_NO_INSTALL:-0}" = 1 ] && return 1
  if [ "$(id -u)" = 0 ]; then
    return 0
  fi
  if command -v sudo >/dev/null 2>&1 && sudo -n true >/dev/null 2>&1; then
    SS_AS=(sudo -n)
    return 0
  fi
  return 1
}

# The command a user runs to install "$@" (sudo unless root).
ss_apt_command() {
  if [ "$(id -u)" = 0 ]; then
    printf 'apt-get install -y %s\n' "$*"
  else
    printf 'sudo apt-get install -y %s\n' "$*"
  fi
}

# Installs "$@" with apt-get (after ss_can_install); fails as apt-get does.
ss_apt_install() {
  ss_note "installing $* (apt-get)"
  if [ "$SS_APT_UPDATED" = 0 ]; then
    ${SS_AS[@]+"${SS_AS[@]}"} env DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null || return 1
    SS_APT_UPDATED=1
  fi
  ${SS_AS[@]+"${SS_AS[@]}"} env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

# Stops the script: what is missing, then the commands to run once, then "run it again".
ss_stop() {
  local why="$1"
  shift
  {
    printf '%s: %s. Run once:\n\n' "$SS_NAME" "$why"
    printf '    %s\n' "$@"
    printf '\nthen run %s again.\n' "$SS_NAME"
  } >&2
  exit 1
}

ss_setup() {
  local required=() optional=() missing=() commands=() reasons=() rust=1
  while [ "$#" -gt 0 ]; do
    case "$1" in
      --optional) optional+=("$2"); shift 2 ;;
      *) required+=("$1"); shift ;;
    esac
  done

  local cargo_bin="${CARGO_HOME:-$HOME/.cargo}/bin"
  if ! command -v cargo >/dev/null 2>&1 && [ -x "$cargo_bin/cargo" ]; then
    PATH="$cargo_bin:$PATH"
    export PATH
  fi
  if ! command -v cargo >/dev/null 2>&1 || ! command -v rustc >/dev/null 2>&1; then
    rust=0
  fi

  # What the build needs besides Rust, where it is missing.
  command -v cc >/dev/null 2>&1 || required+=(build-essential)
  if [ "$rust" = 0 ] && ! command -v curl >/dev/null 2>&1; then
    required+=(curl)
  fi
  if ! command -v python3 >/dev/null 2>&1; then
    required+=(python3 python3-venv)
  else
    if ! python3 -c 'import sys; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then
      ss_note "needs Python >= 3.10; python3 is $(python3 -c 'import platform; print(platform.python_version())' 2>/dev/null || echo unknown) ($(command -v python3))"
      exit 1
    fi
    python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || required+=(python3-venv)
  fi

  if command -v dpkg >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
    if [ "${#required[@]}" -gt 0 ]; then
      mapfile -t missing < <(ss_missing_packages "${required[@]}")
    fi
    if [ "${#optional[@]}" -gt 0 ]; then
      mapfile -t SS_MISSING_OPTIONAL < <(ss_missing_packages "${optional[@]}")
    fi
  elif [ "$((${#required[@]} + ${#optional[@]}))" -gt 0 ]; then
    ss_note "not Debian/Ubuntu (no dpkg or apt-get): make sure the equivalents of ${required[*]} ${optional[*]} are installed"
  fi

  if [ "${#missing[@]}" -gt 0 ] && ss_can_install; then
    ss_apt_install "${missing[@]}" || ss_stop "apt-get could not install ${missing[*]}" "$(ss_apt_command "${missing[@]}")"
    missing=()
  fi
  if [ "${#SS_MISSING_OPTIONAL[@]}" -gt 0 ] && ss_can_install; then
    if ss_apt_install "${SS_MISSING_OPTIONAL[@]}"; then
      SS_MISSING_OPTIONAL=()
    else
      ss_note "apt-get could not install ${SS_MISSING_OPTIONAL[*]}; going on without"
    fi
  fi

  if [ "${#missing[@]}" -gt 0 ]; then
    reasons+=("needs the system packages ${missing[*]}, which it installs only as root or with passwordless sudo")
    commands+=("$(ss_apt_command "${missing[@]}")")
  fi
  if [ "$rust" = 0 ]; then
    reasons+=("needs a Rust toolchain (cargo and rustc), to build softshadows' core")
    commands+=("$SS_RUSTUP")
  fi
  if [ "${#commands[@]}" -gt 0 ]; then
    local why
    why="$(printf '%s; ' "${reasons[@]}")"
    ss_stop "${why%; }" "${commands[@]}"
  fi
}
