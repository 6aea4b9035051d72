#!/usr/bin/env bash
# Creates .venv at the repo root and installs semexp-bt with its test tools.
# torch goes in first, pinned, so that pip takes the CPU build instead of the multi-GB CUDA one.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q "torch==2.13.0"
# The models extra too: the model adapters' tests run openai, jsonschema and transformers for real.
.venv/bin/python -m pip install -q -e ".[dev,models]"
