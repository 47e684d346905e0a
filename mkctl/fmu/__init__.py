"""The FMU layer: the pythonfmu slave base (:mod:`~mkctl.fmu.slave`) and the slaves
(:mod:`~mkctl.fmu.models`: the knee, the actuator, any mechanism, stepped by
:mod:`~mkctl.fmu.mechanism`), importing pythonfmu; the build (:mod:`~mkctl.fmu.build`,
``python -m mkctl.fmu.build``). Nothing here is imported by ``import mkctl``."""
