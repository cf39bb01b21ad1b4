#!/usr/bin/env bash
# The GPU backend on a real GPU: on a machine with an NVIDIA GPU and its Vulkan driver, runs the
# GPU parity tests (every shader against its CPU half: the pytest tests marked gpu and, where
# cargo is here, the core's tests/gpu.rs) and bench/gpu.py for every GPU method at 1024x1024
# receivers, and writes a small report.
#
#   scripts/gpu_check.sh [--out DIR] [--size N] [--repeat K]
#
# DIR (default gpu-check/) receives report.md (the adapter, nvidia-smi's line, the tests' summary
# lines and the benchmark's table) and the full logs. The Python that runs it is $PYTHON (default
# python3) and must import softshadows with its test extra (pip install ".[test]" from the
# repository, or a wheel built by scripts/test.sh). The adapter is the one backend="gpu" picks
# (wgpu's high-performance adapter): when it is not an NVIDIA GPU the script stops at once with
# exit status 3, naming the adapter it found and what to install (Mesa's lavapipe, a software
# Vulkan driver, is what a machine without a GPU offers; its numbers would compare two CPU
# implementations). SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER=1 runs the check on whatever adapter there
# is (the script's own test does, on lavapipe); SOFTSHADOWS_GPU_CHECK_CARGO=0 leaves out the
# cargo tests.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-python3}"
out="gpu-check"
size=1024
repeat=2
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --repeat) repeat="$2"; shift 2 ;;
    *) echo "scripts/gpu_check.sh: unknown argument $1 (expected --out DIR, --size N, --repeat K)" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
out="$(cd "$out" && pwd)"

if ! "$python" -c "import softshadows" 2>/dev/null; then
  echo "scripts/gpu_check.sh: $python cannot import softshadows; install it first: $python -m pip install \"$repo[test]\"" >&2
  exit 2
fi

# Adapter selection: the adapter backend="gpu" runs on, and whether it is an NVIDIA GPU.
adapter="$("$python" - <<'PY'
import json, softshadows as ss
try:
    print(json.dumps(ss.gpu_info()))
except RuntimeError as error:
    print(json.dumps({"error": str(error)}))
PY
)"
verdict="$("$python" -c '
import json, sys
info = json.loads(sys.argv[1])
if "error" in info:
    print("none: " + info["error"])
elif "nvidia" in (info["name"] + " " + info["driver"]).lower() and info["device_type"] != "cpu":
    print("nvidia")
else:
    print("other: " + info["name"] + " (" + info["device_type"] + ", driver " + info["driver"] + ")")
' "$adapter")"
if [ "$verdict" != nvidia ] && [ "${SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER:-0}" != 1 ]; then
  cat >&2 <<EOF
scripts/gpu_check.sh: no NVIDIA GPU adapter; found ${verdict#*: }.
This check measures the wgpu backend on a real GPU. Run it on a machine with an NVIDIA GPU and its
Vulkan driver (nvidia-smi lists the GPU; vulkaninfo --summary, from Debian's vulkan-tools, lists it
as a Vulkan device). To run it on this adapter anyway, set SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER=1.
EOF
  exit 3
fi
echo "$adapter" > "$out/adapter.json"

status=0
# Not this script's own test, which would run the script again.
"$python" -m pytest -q -p no:cacheprovider -c "$repo/pyproject.toml" --rootdir "$repo" -m "gpu and not slow" \
  --ignore "$repo/tests/test_gpu_check.py" "$repo/tests" > "$out/pytest.log" 2>&1 || status=1
cargo_line="left out (no cargo, or SOFTSHADOWS_GPU_CHECK_CARGO=0)"
if [ "${SOFTSHADOWS_GPU_CHECK_CARGO:-1}" != 0 ] && command -v cargo >/dev/null; then
  (cd "$repo" && cargo test -q --release -p softshadows-core --test gpu) > "$out/cargo.log" 2>&1 || status=1
  cargo_line="$(grep -E '^test result' "$out/cargo.log" | tail -1 || echo "did not run: see cargo.log")"
fi
"$python" "$repo/bench/gpu.py" --size "$size" --repeat "$repeat" > "$out/bench.log" 2>&1 || status=1

{
  echo "# GPU check, $(date -u +%Y-%m-%dT%H:%MZ)"
  echo
  echo "- adapter: $("$python" -c 'import json, sys; i = json.loads(sys.argv[1]); print(", ".join(f"{k} {v}" for k, v in i.items()))' "$adapter")"
  if command -v nvidia-smi >/dev/null; then
    echo "- nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | head -1)"
  fi
  echo "- pytest (tests marked gpu): $(tail -1 "$out/pytest.log")"
  echo "- cargo (rust/core/tests/gpu.rs): $cargo_line"
  echo "- verdict: $([ "$status" = 0 ] && echo "every step passed" || echo "a step FAILED: see its log")"
  echo
  echo "## bench/gpu.py --size $size --repeat $repeat"
  echo
  echo '```'
  cat "$out/bench.log"
  echo '```'
} > "$out/report.md"
cat "$out/report.md"
exit "$status"
