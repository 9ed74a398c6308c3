"""The ln record benchmark lives with ln_bag (ln_bag/bench)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "ln_bag" / "bench"))
from record_case import ORDER, TITLE, run  # noqa: F401
