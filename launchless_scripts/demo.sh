#!/usr/bin/env bash
# THE demo command (README): set-up + build (setup.sh), then the demo in demo_steps.sh, in the project env.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
timeout 4000 bash "$HERE/setup.sh"
. "$HERE/env.sh"
if [ -f "$HERE/demo_steps.sh" ]; then
  timeout 1800 bash "$HERE/demo_steps.sh"
else
  echo "demo.sh: no demo yet ($HERE/demo_steps.sh is missing)"
fi
