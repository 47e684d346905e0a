"""Damping sweep: how the viscous damping c changes the response to an extensor pressure step.

    python scenarios/damping_sweep.py --help

A thin runnable wrapper: the scenario lives in :mod:`mkctl.scenarios.damping_sweep` (also ``python -m mkctl.scenarios.damping_sweep``,
which needs no checkout).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a checkout without pip install: find mkctl

from mkctl.scenarios.damping_sweep import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
