"""Build the FMI 2.0 co-simulation FMUs of model-spec section 7 and check them (the design card's entry point).

    python build_fmu.py [--out DIR] [--no-run] [--params MUSCLE.json] [--effects FILE.py ...]

writes ``DIR/McKibbenKnee.fmu`` and ``DIR/McKibbenActuator.fmu`` (DIR defaults to ``dist`` next to this file),
and with a C compiler their native twins: FMI 2.0 in ``DIR/native/``, FMI 3.0 in ``DIR/fmi3/`` (Linux binaries, and
Windows ones when MinGW-w64 is installed; see docs/fmu.md).
The work is done by :func:`mkctl.fmu.build.build` (also ``python -m mkctl.fmu.build`` from an installed mkctl);
see its docstring and docs/fmu.md.
"""
from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:  # run from a checkout: this folder's mkctl
    sys.path.insert(0, str(HERE))

from mkctl.fmu.build import BuildError, build, main  # noqa: E402,F401  (build and BuildError re-exported)

if __name__ == "__main__":
    sys.exit(main(default_out=HERE / "dist"))
