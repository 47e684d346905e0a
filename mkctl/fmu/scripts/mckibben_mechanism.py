"""Every mechanism FMU's script: pythonfmu packs it as the FMU's top-level module
``mckibben_mechanism``.

The slave lives in :mod:`mkctl.fmu.models`; this file only names it. Which mechanism, and the model
name McKibben<Name>, come from the FMU's resources (:data:`mkctl.fmu.slave.BUILD_FILE`), so that
nothing of a user's mechanism file is ever written into Python. The last line: see mckibben_knee.py
(pythonfmu 0.7 releases a reference to this namespace that it never took).
"""
from mkctl.fmu.models import McKibbenMechanism  # noqa: F401  (the slave class pythonfmu looks for)
from mkctl.fmu.slave import keep_namespace

keep_namespace(globals())
