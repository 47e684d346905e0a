"""Default settings of the control analysis, apart from :mod:`mkctl.analysis.control` so that the command line can
show them without importing python-control (which takes seconds)."""
from pathlib import Path

#: Damping ratio used where a damped knee is needed and no c is given.
DEFAULT_ZETA = 0.3
#: Pressure lag [s] for the closed-loop comparison when none is given (valves and tubing: tens of ms).
DEFAULT_TAU = 0.05
#: Where the knee FMU is built (``python build_fmu.py``).
DEFAULT_FMU = Path("dist") / "McKibbenKnee.fmu"
#: Time of the pressure-command step in the step responses [s].
STEP_TIME = 0.1
