#!/usr/bin/env bash
# Creates .venv-ros2: the ROS 2 Jazzy wheels (rclpy on Fast DDS and the message packages: pyproject's
# `ros2` extra) in their own environment, laid over .venv so that semexp-bt and its dependencies come
# from there. The wheels install a .pth that re-executes every Python start to set LD_LIBRARY_PATH;
# keeping them out of .venv keeps that cost (and that library path) off every other command
# (docs/ros2.md, "Packages", has the measurement).
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x .venv/bin/python ] || bash scripts/setup.sh
base_site=$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
base_python=$(.venv/bin/python -c 'import sys; print(sys._base_executable)')
[ -x .venv-ros2/bin/python ] || "$base_python" -m venv .venv-ros2
ros_site=$(.venv-ros2/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
# addsitedir (not a bare path line) so that .venv's own .pth files (the editable install) apply too.
echo "import site; site.addsitedir('$base_site')" > "$ros_site/_semexp_base_venv.pth"
.venv/bin/python -c 'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["ros2"]))' > .venv-ros2/requirements.txt
.venv-ros2/bin/python -m pip install -q -r .venv-ros2/requirements.txt
# The console command, run by this environment's interpreter.
printf '#!%s\nimport sys\nfrom semexp_bt.cli import main\nsys.exit(main())\n' "$PWD/.venv-ros2/bin/python" > .venv-ros2/bin/semexp-bt
chmod +x .venv-ros2/bin/semexp-bt
.venv-ros2/bin/python -c 'import rclpy, sensor_msgs.msg, nav_msgs.msg, semexp_bt, mujoco'
