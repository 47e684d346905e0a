"""Isotonic pressure sweep of the actuator FMU under a hanging load (Fig. 5 of the paper).

    python scenarios/isotonic_sweep.py --help

A thin runnable wrapper: the scenario lives in :mod:`mkctl.scenarios.isotonic_sweep` (also ``python -m mkctl.scenarios.isotonic_sweep``,
which needs no checkout).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a checkout without pip install: find mkctl

from mkctl.scenarios.isotonic_sweep import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
