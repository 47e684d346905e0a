"""The analysis layer: what is computed from the physics.

- :mod:`~mkctl.analysis.paper`: the paper's figures and claims.
- :mod:`~mkctl.analysis.control`: linearization, root loci and step responses with python-control.
- :mod:`~mkctl.analysis.compare`, :mod:`~mkctl.analysis.diagnose`: model against measurement, and which effect
  the model lacks.
- :mod:`~mkctl.analysis.synth`: the virtual test bench that makes measurement files with hidden effects.
"""
