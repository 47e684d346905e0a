"""mkctl: McKibben pneumatic artificial muscles and the knee they drive.

The library is the one home of every equation; the FMUs, the analyses, the diagnosis and the scenarios
call it. Modules, from the bottom up:

- :mod:`mkctl.physics.params`: Table I, Table II and the effects, as immutable parameter sets with units.
- :mod:`mkctl.physics.actuator`: model 1 (Eq. 7), model 2 (Eq. 13), their derivatives, and the effects.
- :mod:`mkctl.physics.knee`: the knee's geometry, ground force (Eq. 14-16) and state equations (Eq. 17).
- :mod:`mkctl.physics.stability`: a1, a2, h (Eq. 18-23), the equilibrium set and the Routh-Hurwitz verdict.
- :mod:`mkctl.physics.integrate`, :mod:`mkctl.physics.simulate`, :mod:`mkctl.physics.isotonic`: time simulation.

Importing mkctl changes nothing anywhere: the compiled cores are plug-ins the physics finds through the
package's entry points (:mod:`mkctl.physics.backend`), not providers handed in here.
"""
from .errors import DomainError, MeasurementFileError, MkctlError, ParameterError
from .io.muscle import read_muscle, write_muscle
from .physics.params import DEFAULT, PARAMETER_NAMES, TABLE_I, TABLE_II, Params

__version__ = "0.1.0"

__all__ = ["DEFAULT", "PARAMETER_NAMES", "TABLE_I", "TABLE_II", "Params", "read_muscle", "write_muscle", "DomainError",
           "MeasurementFileError", "MkctlError", "ParameterError", "__version__"]
