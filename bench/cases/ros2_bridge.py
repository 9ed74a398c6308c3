"""The LN -> ROS 2 bridge benchmark lives with the bridge (ln_ros2_bridge/bench)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "ln_ros2_bridge" / "bench"))
from bridge_case import ORDER, TITLE, run  # noqa: F401
