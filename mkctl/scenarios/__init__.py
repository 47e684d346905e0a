"""Scenarios that drive the FMUs with fmpy, as a user would: one module each, ``run(argv)`` and ``main(argv)``.

- :mod:`~mkctl.scenarios.pressure_step`: a step of the extensor command from rest at alpha = 60 deg;
- :mod:`~mkctl.scenarios.slow_squat`: a slow squat along the equilibrium set, with the stability verdict;
- :mod:`~mkctl.scenarios.push_recovery`: pushes on the hip and the recovery, against the damping;
- :mod:`~mkctl.scenarios.damping_sweep`: the pressure step for several dampings c;
- :mod:`~mkctl.scenarios.isotonic_sweep`: the actuator FMU under a constant load (the paper's Fig. 5 test).

Run one with ``python -m mkctl.scenarios.NAME --help`` (in a checkout also ``python scenarios/NAME.py``).
What they share is in :mod:`~mkctl.scenarios.common`.
"""

#: The scenario modules, in the order above.
NAMES = ("pressure_step", "slow_squat", "push_recovery", "damping_sweep", "isotonic_sweep")
