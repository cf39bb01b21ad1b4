#!/usr/bin/env bash
# Bounded fuzzing of softshadows-core: builds every cargo-fuzz target of rust/fuzz once, then runs
# each for SECONDS_PER_TARGET seconds (default 10) starting from its committed corpus
# (rust/fuzz/corpus/<target>/). Prints one line per target with the executions done; exits
# non-zero when any target crashes (panic, failed output check, timeout or out-of-memory), after
# printing the end of its log. Crashing inputs are kept in rust/fuzz/artifacts/<target>/ (ignored
# by git); replay one with `rust/fuzz/target/<host>/release/<target> <file>`.
#
# Needs the nightly toolchain and cargo-fuzz (`cargo install --locked cargo-fuzz`).
# Usage: bash scripts/fuzz.sh [SECONDS_PER_TARGET]
set -euo pipefail
cd "$(dirname "$0")/.."

secs="${1:-10}"
fuzz_dir=rust/fuzz

# No sanitizer: the only unsafe code on the fuzzed paths is the SIMD dispatch of the packet tracer
# and of stsv's perforated pass (each call checked for its CPU features), and ASan would halve the
# executions.
# Debug assertions (overflow checks included) are on, as cargo-fuzz builds by default.
cargo +nightly fuzz build --fuzz-dir "$fuzz_dir" --sanitizer none
host="$(rustc +nightly -vV | sed -n 's/^host: //p')"
bin_dir="$fuzz_dir/target/$host/release"

# New inputs go to a temporary first corpus; the committed corpus is only read (libFuzzer writes
# to its first corpus directory alone), so CI leaves the working tree as it was.
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

status=0
for target in $(cargo +nightly fuzz list --fuzz-dir "$fuzz_dir"); do
  corpus=("$work/$target")
  mkdir -p "$work/$target" "$fuzz_dir/artifacts/$target"
  if [ -d "$fuzz_dir/corpus/$target" ]; then
    corpus+=("$fuzz_dir/corpus/$target")
  fi
  log="$work/$target.log"
  if "$bin_dir/$target" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$fuzz_dir/artifacts/$target/" "${corpus[@]}" >"$log" 2>&1; then
    runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")"
    printf '%-16s ok     %8s executions in %ss\n' "$target" "${runs:-?}" "$secs"
  else
    printf '%-16s FAILED (log below)\n' "$target"
    # The panic message and libFuzzer's summary; replay the artifact for the backtrace.
    grep -A3 -m1 'panicked at' "$log" || true
    grep -E '^(==[0-9]+== ERROR|SUMMARY|artifact_prefix|Base64|stat::number_of_executed_units)' "$log" || tail -n 20 "$log"
    status=1
  fi
done
exit "$status"
