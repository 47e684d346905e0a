"""The pythonfmu slave scripts packed into the FMUs by :mod:`mkctl.fmu.build` (each becomes an FMU's top-level
module ``mckibben_knee`` or ``mckibben_actuator``): one import of a slave class each."""
