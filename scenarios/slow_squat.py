"""Slow squat: from bent to nearly straight and back, by antagonistic pressure ramps.

    python scenarios/slow_squat.py --help

A thin runnable wrapper: the scenario lives in :mod:`mkctl.scenarios.slow_squat` (also ``python -m mkctl.scenarios.slow_squat``,
which needs no checkout).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a checkout without pip install: find mkctl

from mkctl.scenarios.slow_squat import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
