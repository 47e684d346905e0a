"""The physics layer: every equation of the seed paper and model-spec sections 2-4, and nothing else.

- :mod:`~mkctl.physics.params`: Table I, Table II and the effects, as immutable parameter sets with units.
- :mod:`~mkctl.physics.actuator`: model 1 (Eq. 7), model 2 (Eq. 13), their derivatives, and the effects.
- :mod:`~mkctl.physics.knee`: the knee's geometry, ground force (Eq. 14-16) and state equations (Eq. 17).
- :mod:`~mkctl.physics.stability`: a1, a2, h (Eq. 18-23), the equilibrium set and the Routh-Hurwitz verdict.
- :mod:`~mkctl.physics.integrate`, :mod:`~mkctl.physics.simulate`, :mod:`~mkctl.physics.isotonic`: time
  simulation.

Modules here import only numpy, scipy and each other: the analysis, io, fmu and cli layers sit above.
"""
