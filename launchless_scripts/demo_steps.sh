#!/usr/bin/env bash
# Demo content, run by demo.sh inside the project environment (env.sh sourced). Placeholder for now.
set -euo pipefail
cat <<MSG
Demo (placeholder). The full demo will:
  1. generate C/C++ headers for the example message definitions with ln_core's ln_generate,
  2. start ln_manager and LN publishers/services (C++ and Python),
  3. bridge them to ROS 2 Jazzy with ln_ros2_bridge and show them from rclpy.
The full LN -> ROS 2 demo lands with the bridge issue.
Environment now: ln_generate=$(command -v ln_generate || echo 'not built'), python=$(command -v python),
  LN 2.9 reference venv: ${LN_CORE_LN29_VENV:-unset}
MSG
