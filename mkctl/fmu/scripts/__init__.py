"""The pythonfmu slave scripts packed into the FMUs by :mod:`mkctl.fmu.build` (each becomes an FMU's top-level
module ``mckibben_knee`` or ``mckibben_actuator``). They import pythonfmu; nothing else in mkctl imports them."""
