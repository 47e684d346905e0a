"""The knee FMU's script: pythonfmu packs it as the FMU's top-level module ``mckibben_knee``.

The slave lives in :mod:`mkctl.fmu.models`; this file only names it. pythonfmu 0.7 imports this module, runs
it again at every fmi2Instantiate (in the module's namespace) and then releases a reference to that namespace
that it never took (``Py_DECREF`` on the borrowed result of ``PyModule_GetDict``). The last line takes that
reference, once per run, so that the namespace outlives the instances; the less this file defines, the less each
run allocates (docs/fmu.md, "Memory").
"""
from mkctl.fmu.models import McKibbenKnee  # noqa: F401  (the slave class pythonfmu looks for)
from mkctl.fmu.slave import keep_namespace

keep_namespace(globals())
