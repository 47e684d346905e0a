"""Pressure step from equilibrium: the leg rests at alpha = 60 deg, then the extensor command steps up.

    python scenarios/pressure_step.py --help

A thin runnable wrapper: the scenario lives in :mod:`mkctl.scenarios.pressure_step` (also ``python -m mkctl.scenarios.pressure_step``,
which needs no checkout).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a checkout without pip install: find mkctl

from mkctl.scenarios.pressure_step import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
