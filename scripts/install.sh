#!/usr/bin/env bash
# Install LLM-Land into .venv at the repository root (pinned by constraints.txt).
#   bash scripts/install.sh          # runtime: every service and the llmland CLI
#   bash scripts/install.sh --test   # plus test tools (pytest, hypothesis, osqp, schemathesis, ruff, mypy)
#                                    # and the docker-compose v1 client to validate compose.yaml
# llama-cpp-python builds from source the first time (~5 min on 2 cores) as a portable wheel
# (scripts/build_llama.sh), kept in ~/.cache/llmland/wheels keyed by its build flags.
# The install ends with a smoke check that loads the default GGUF and evaluates a few tokens.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

with_test=0
for arg in "$@"; do
  case "$arg" in
    --test) with_test=1 ;;
    *) echo "unknown option: $arg" >&2; exit 2 ;;
  esac
done

PYTHON="${PYTHON:-$(command -v python3.11 || command -v python3)}"
"$PYTHON" -c 'import sys; assert sys.version_info[:2] == (3, 11), f"Python 3.11 needed, found {sys.version}"'

[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
export PIP_DISABLE_PIP_VERSION_CHECK=1
.venv/bin/python -m pip install -q "pip==26.3"

# The LLM runtime first, as a portable wheel from our own flag-keyed cache (see the script):
# the install below then finds llama-cpp-python satisfied and never builds a host-specific one.
bash scripts/build_llama.sh .venv/bin/python

extras=""
[ "$with_test" = 1 ] && extras="[test]"
.venv/bin/pip install -q -c constraints.txt \
  -e shared/schemas -e services/sim -e services/planner -e services/vle -e services/reasoner -e ".${extras}"

if [ "$with_test" = 1 ] && ! command -v docker-compose >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing the docker-compose client (validates compose.yaml in the tests)" >&2
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq docker-compose >/dev/null) \
      || echo "warning: docker-compose could not be installed; the compose test will fail" >&2
  else
    echo "warning: docker-compose missing and not root: install it to run the compose test" >&2
  fi
fi
if ! .venv/bin/python -m llmland_reasoner.smoke; then
  echo "install failed: the LLM runtime cannot run the default model on this machine (see above)" >&2
  exit 1
fi
echo "LLM-Land installed in .venv ($(.venv/bin/python --version))" >&2
