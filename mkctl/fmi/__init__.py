"""What a host sees of the FMUs (model-spec section 7), declared once, as data, below both FMU kinds: every
variable of the knee and the actuator (:mod:`~mkctl.fmi.interface`) and their FMI units
(:mod:`~mkctl.fmi.units`). The pythonfmu slaves (:mod:`mkctl.fmu`) register these variables; the native FMUs
(:mod:`mkctl.native.fmu`) write them into their modelDescription.xml and C. Imports neither pythonfmu nor fmpy."""
