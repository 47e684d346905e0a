"""Recovery from a push: the leg, holding 60 deg, is pushed down and released.

    python scenarios/push_recovery.py --help

A thin runnable wrapper: the scenario lives in :mod:`mkctl.scenarios.push_recovery` (also ``python -m mkctl.scenarios.push_recovery``,
which needs no checkout).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a checkout without pip install: find mkctl

from mkctl.scenarios.push_recovery import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
