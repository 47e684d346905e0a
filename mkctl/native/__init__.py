"""The compiled core: C generated from the library's own equations, built once per machine, loaded with ctypes.

- :mod:`mkctl.native.codegen` traces the physics functions on sympy symbols and writes C (needs sympy);
- :mod:`mkctl.native.build` finds the C compiler, caches the generated source and the shared library;
- :mod:`mkctl.native.compiled` loads it and runs whole knee records in one call.

:func:`mkctl.physics.simulate.simulate_knee` and :func:`~mkctl.physics.simulate.knee_states` use it when it is
available and fall back to the Python path otherwise (no compiler, ``MKCTL_NATIVE=0``). See docs/native.md.
"""
from pathlib import Path

#: The C template around the generated equations: the integrator, the record loop, the API.
TEMPLATE = Path(__file__).with_name("core_template.c")
