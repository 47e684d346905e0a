"""One check the effect tests share: a parameter set's compiled core computes what the Python path computes."""
from __future__ import annotations

import numpy as np


def assert_core_matches_python(p) -> dict:
    """The compiled core of ``p`` against the Python path: the knee's right-hand side at one state (1e-11) and a
    0.6 s pressure step through simulate_knee (1e-10 of each output's span). Returns the compiled run."""
    from mkctl.native import compiled
    from mkctl.physics import backend, knee
    from mkctl.physics.simulate import default_commands, simulate_knee
    core = compiled.core_for(p)
    assert core is not None
    pe, pf = default_commands(p)
    state = [float(knee.X_from_alpha(1.0, p)), 0.05, pe * 1.05, pf]
    np.testing.assert_allclose(core.knee_rhs(p, state, pe, pf), knee.knee_derivatives(state, pe, pf, p),
                               rtol=1e-11, atol=1e-9)
    t = np.linspace(0, 0.6, 301)
    pe_cmd = np.where(t < 0.1, pe, pe * 1.04)
    fast = simulate_knee(t, pe_cmd, pf, p)
    previous = backend.install(None)  # the Python path
    try:
        slow = simulate_knee(t, pe_cmd, pf, p)
    finally:
        backend.install(previous)
    for name in ("X", "V", "fe", "F", "a1", "a2"):
        span = np.ptp(slow[name]) + abs(slow[name]).max()
        np.testing.assert_allclose(fast[name], slow[name], rtol=0, atol=1e-10 * span, err_msg=name)
    return {"t": t, "pe_cmd": pe_cmd, "pf": pf, "run": fast, "core": core}
