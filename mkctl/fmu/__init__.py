"""The FMU layer: the pythonfmu slave base (:mod:`~mkctl.fmu.slave`, imports pythonfmu) and the fmpy probe
(:mod:`~mkctl.fmu.probe`, imports fmpy). Nothing here is imported by ``import mkctl``."""
