# The README's two commands are `make mission` and `make test`; both create .venv on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup mission test lint bench-core slow ray

$(STAMP): pyproject.toml scripts/setup.sh
	bash scripts/setup.sh
	touch $(STAMP)

setup: $(STAMP)

mission: $(STAMP)
	MUJOCO_GL=egl $(BIN)/semexp-bt run trees/object_search.yaml --scene road --seed 0 --relevance lexical --json runs/road-0.json

test: $(STAMP)
	MUJOCO_GL=egl $(BIN)/python -m pytest -q

slow: $(STAMP)
	MUJOCO_GL=egl $(BIN)/python -m pytest -q -m slow

# Ray is optional: this installs the cluster extra into .venv, then runs the sweeps on a local Ray cluster.
ray: $(STAMP)
	$(BIN)/pip install -q -e '.[cluster]'
	MUJOCO_GL=egl $(BIN)/python -m pytest -q -m ray

bench-core: $(STAMP)
	$(BIN)/semexp-bt bench core --json runs/bench-core.json
