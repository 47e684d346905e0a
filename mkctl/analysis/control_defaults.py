"""Default settings of the control analysis, apart from :mod:`mkctl.analysis.control` so that the command line can
show them without importing python-control (which takes seconds).

There is no default FMU here: a library default relative to the working folder would change meaning with
``os.chdir``. The analyses take the FMU's path explicitly; the ``mkctl`` command has its own default
(``dist/McKibbenKnee.fmu`` in the working folder, where ``python build_fmu.py`` writes it)."""
#: Damping ratio used where a damped knee is needed and no c is given.
DEFAULT_ZETA = 0.3
#: Pressure lag [s] for the closed-loop comparison when none is given (valves and tubing: tens of ms).
DEFAULT_TAU = 0.05
#: Time of the pressure-command step in the step responses [s].
STEP_TIME = 0.1
