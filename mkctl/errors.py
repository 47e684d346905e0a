"""Exceptions raised by mkctl.

Every error a user can cause derives from :class:`MkctlError`, so that the command line (and the FMU
wrappers) can turn it into a one-line message instead of a traceback.
"""


class MkctlError(Exception):
    """Base class of every error a user of mkctl can cause."""


class ParameterError(MkctlError, ValueError):
    """A parameter value the model cannot represent (negative mass, unknown name, ...)."""


class DomainError(MkctlError, ValueError):
    """A state or input outside the model's domain (an actuator length outside 0 < L < b, ...)."""


class MeasurementFileError(MkctlError, ValueError):
    """A measurement file that does not follow the format of model-spec section 5."""
