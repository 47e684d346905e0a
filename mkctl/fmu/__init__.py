"""The FMU layer: the pythonfmu slave base (:mod:`~mkctl.fmu.slave`) and the two slaves (:mod:`~mkctl.fmu.models`),
both importing pythonfmu; the build (:mod:`~mkctl.fmu.build`, ``python -m mkctl.fmu.build``). Nothing here is imported by ``import mkctl``."""
