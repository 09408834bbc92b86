#!/usr/bin/env bash
# Build and install llama-cpp-python as a *portable* wheel (runs on any x86-64 CPU with AVX2,
# AVX-512 and AMX machines included), kept in a wheel cache keyed by version, Python tag,
# architecture and the exact CMake flags.
#
#   bash scripts/build_llama.sh [PYTHON]      # PYTHON: the venv's interpreter (default .venv/bin/python)
#
# Why not a plain `pip install llama-cpp-python`: it compiles with GGML_NATIVE=ON, i.e. for the
# CPU of the machine that builds it, and pip's own wheel cache is keyed by version only, so a
# wheel built on one machine is silently reused on another. On AMX Xeons such a native build
# segfaults in ggml's AMX matrix multiply at the first evaluation. Here the flags are fixed,
# pip's cache is bypassed (--no-cache-dir) and our cache folder name carries a hash of them.
#
# Settings (environment):
#   LLMLAND_LLAMA_CMAKE_ARGS  override the CMake flags (a different cache entry is made)
#   LLMLAND_WHEEL_CACHE       where built wheels are kept (default ~/.cache/llmland/wheels)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PY="${1:-.venv/bin/python}"
VERSION="$(sed -n 's/^llama_cpp_python==//p' constraints.txt)"
[ -n "$VERSION" ] || { echo "llama_cpp_python is not pinned in constraints.txt" >&2; exit 2; }

case "$(uname -m)" in
  x86_64 | amd64)
    # Haswell-level x86-64 (AVX2, FMA, F16C, BMI2): no AVX-512 or AMX code paths compiled in.
    DEFAULT_ARGS="-DGGML_NATIVE=OFF -DGGML_AVX=ON -DGGML_AVX2=ON -DGGML_FMA=ON -DGGML_F16C=ON -DGGML_BMI2=ON"
    ;;
  *)
    DEFAULT_ARGS="-DGGML_NATIVE=OFF"
    ;;
esac
ARGS="${LLMLAND_LLAMA_CMAKE_ARGS:-$DEFAULT_ARGS}"
PYTAG="$("$PY" -c 'import sys; print(f"cp{sys.version_info[0]}{sys.version_info[1]}")')"
KEY="$(printf '%s|%s|%s|%s' "$VERSION" "$PYTAG" "$(uname -m)" "$ARGS" | sha256sum | cut -c1-12)"
CACHE="${LLMLAND_WHEEL_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/llmland/wheels}/llama-cpp-python-$VERSION-$PYTAG-$KEY"

installed_key="$("$PY" - <<'EOF' 2>/dev/null || true
import json, importlib.util, pathlib
spec = importlib.util.find_spec("llama_cpp")
if spec and spec.origin:
    marker = pathlib.Path(spec.origin).parent / "_llmland_build.json"
    if marker.is_file():
        print(json.loads(marker.read_text())["key"])
EOF
)"
if [ "$installed_key" = "$KEY" ]; then
  echo "llama-cpp-python $VERSION (portable build $KEY) already installed" >&2
  exit 0
fi

wheel="$(ls "$CACHE"/llama_cpp_python-"$VERSION"-*.whl 2>/dev/null | head -n1 || true)"
if [ -z "$wheel" ]; then
  echo "building llama-cpp-python $VERSION with: $ARGS (a few minutes on 2 cores; once per flag set)" >&2
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  CMAKE_ARGS="$ARGS" FORCE_CMAKE=1 "$PY" -m pip wheel -q --no-cache-dir --no-deps --no-binary llama-cpp-python \
    "llama-cpp-python==$VERSION" -w "$tmp"
  mkdir -p "$CACHE"
  mv "$tmp"/llama_cpp_python-*.whl "$CACHE"/
  wheel="$(ls "$CACHE"/llama_cpp_python-"$VERSION"-*.whl | head -n1)"
fi
"$PY" -m pip install -q --no-deps --force-reinstall "$wheel"
"$PY" - "$KEY" "$ARGS" "$wheel" <<'EOF'
import json, importlib.util, pathlib, sys
spec = importlib.util.find_spec("llama_cpp")
marker = pathlib.Path(spec.origin).parent / "_llmland_build.json"
marker.write_text(json.dumps({"key": sys.argv[1], "cmake_args": sys.argv[2], "wheel": sys.argv[3]}, indent=2))
EOF
echo "installed $(basename "$wheel") (build $KEY)" >&2
