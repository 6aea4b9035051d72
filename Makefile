# The README's two commands are `make mission` and `make test`; both create .venv on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The ROS 2 Jazzy wheels live in their own environment laid over .venv (scripts/setup_ros2.sh, docs/ros2.md).
ROS2_VENV := .venv-ros2
ROS2_STAMP := $(ROS2_VENV)/.installed

.PHONY: setup mission test lint bench-core slow ray viewer-setup viewer-test ros2-env bench-ros2

$(STAMP): pyproject.toml scripts/setup.sh
	bash scripts/setup.sh
	touch $(STAMP)

setup: $(STAMP)

# A mission that runs to an outcome is a finished demo, found or not (`semexp-bt run` exits 1 when the robot
# did not find the object; its one-line summary says so); an error (2) or a halted robot (3) fails make.
mission: $(STAMP)
	MUJOCO_GL=egl $(BIN)/semexp-bt run trees/object_search.yaml --scene road --seed 0 --json runs/road-0.json; \
	status=$$?; [ $$status -le 1 ] || exit $$status

$(ROS2_STAMP): $(STAMP) pyproject.toml scripts/setup_ros2.sh
	bash scripts/setup_ros2.sh
	touch $(ROS2_STAMP)

ros2-env: $(ROS2_STAMP)

# The ROS 2 tests skip in .venv (no rclpy) and run in .venv-ros2, on loopback only (scripts/ros2_isolated.sh).
test: $(STAMP) $(ROS2_STAMP)
	MUJOCO_GL=egl $(BIN)/python -m pytest -q
	MUJOCO_GL=egl bash scripts/ros2_isolated.sh $(ROS2_VENV)/bin/python -m pytest -q tests/test_ros2_*.py

bench-ros2: $(ROS2_STAMP)
	MUJOCO_GL=egl bash scripts/ros2_isolated.sh $(ROS2_VENV)/bin/python scripts/bench_ros2.py --json runs/bench-ros2.json

slow: $(STAMP)
	MUJOCO_GL=egl $(BIN)/python -m pytest -q -m slow

# Ray is optional: this installs the cluster extra into .venv, then runs the sweeps on a local Ray cluster.
ray: $(STAMP)
	$(BIN)/pip install -q -e '.[cluster]'
	MUJOCO_GL=egl $(BIN)/python -m pytest -q -m ray

bench-core: $(STAMP)
	$(BIN)/semexp-bt bench core --json runs/bench-core.json

# The browser view (docs/viewer.md): the viewer extra, Playwright, and Debian's Chromium (installed with
# apt-get when missing and run as root, as CI is); then the tests behind the viewer and browser markers.
viewer-setup: $(STAMP)
	$(BIN)/pip install -q -e '.[viewer,viewer-test]'
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; } || \
		{ echo "viewer-setup: install Debian's chromium (apt-get install chromium)"; exit 1; }

# The view's tests; the last line saves the view of a mission over ROS 2 and follows a live one in Chromium
# (the ROS 2 environment, loopback only).
viewer-test: viewer-setup $(ROS2_STAMP)
	MUJOCO_GL=egl $(BIN)/python -m pytest -q -m 'viewer or browser'
	MUJOCO_GL=egl bash scripts/ros2_isolated.sh $(ROS2_VENV)/bin/python -m pytest -q -m 'viewer or browser' tests/test_ros2_mission.py
