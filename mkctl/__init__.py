"""mkctl: McKibben pneumatic artificial muscles and the knee they drive.

The library is the one home of every equation; the FMUs, the analyses, the diagnosis and the scenarios
call it. Modules, from the bottom up:

- :mod:`mkctl.physics.params`: Table I, Table II and the effects, as immutable parameter sets with units.
- :mod:`mkctl.physics.actuator`: model 1 (Eq. 7), model 2 (Eq. 13), their derivatives, and the effects.
- :mod:`mkctl.physics.knee`: the knee's geometry, ground force (Eq. 14-16) and state equations (Eq. 17).
- :mod:`mkctl.physics.stability`: a1, a2, h (Eq. 18-23), the equilibrium set and the Routh-Hurwitz verdict.
- :mod:`mkctl.physics.integrate`, :mod:`mkctl.physics.simulate`, :mod:`mkctl.physics.isotonic`: time simulation.
"""
from .errors import DomainError, MeasurementFileError, MkctlError, ParameterError
from .io.muscle import read_muscle, write_muscle
from .physics import backend as _backend
from .physics.params import DEFAULT, PARAMETER_NAMES, TABLE_I, TABLE_II, Params


def _compiled_core(params):
    """The compiled core (:mod:`mkctl.native`) for params' structure, or None: no compiler, switched off
    (``MKCTL_NATIVE=0``), or mkctl.native absent (a pythonfmu FMU packs only the modules it imports)."""
    try:
        from .native import compiled
    except ImportError:
        return None
    return compiled.core_for(params)


def _mechanism_core(mechanism, params):
    """The compiled core of a mechanism (:mod:`mkctl.native.mechanism_compiled`) for params, or
    None (as :func:`_compiled_core`)."""
    try:
        from .native import mechanism_compiled
    except ImportError:
        return None
    return mechanism_compiled.core_for(mechanism, params)


# the physics layer is handed the compiled cores; it never imports the layer above it
_backend.install(_compiled_core)
_backend.install_mechanism(_mechanism_core)

__version__ = "0.1.0"

__all__ = ["DEFAULT", "PARAMETER_NAMES", "TABLE_I", "TABLE_II", "Params", "read_muscle", "write_muscle", "DomainError",
           "MeasurementFileError", "MkctlError", "ParameterError", "__version__"]
