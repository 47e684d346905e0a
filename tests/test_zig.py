"""The compiled core built by ziglang (pip's C toolchain, ``MKCTL_CC=zig``) against the system
compiler's.

Both libraries are compiled from the same generated C with the same flags; these tests load both and
compare what they compute on a set of inputs (right-hand sides, outputs, actuator terms, whole knee
records with every structural variant, the damped isotonic test) to 1e-12. They also check the cache
keeps the two libraries apart (the compiler and its version are in the name and the record), and the
toolchain switch's errors. Without ziglang (or without a system compiler) they skip with the reason,
and fail instead under ``MKCTL_REQUIRE_TOOLCHAINS=1`` (CI: it promises both).
"""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from mkctl.errors import MkctlError
from mkctl.native import build, compiled, toolchain
from mkctl.native.variants import ALL_VARIANTS, Variant
from mkctl.physics import knee
from mkctl.physics.params import Params
from mkctl.physics.simulate import KNEE_OUTPUTS, KneeSimulator, default_commands
from toolchain_helpers import require_zig

TOLERANCE = 1e-12


@pytest.fixture(scope="module")
def libraries(tmp_path_factory):
    """{"system" | "zig": Core} with every variant, built into a fresh cache by each toolchain."""
    require_zig("ziglang core to compare with the system compiler's")
    cache = tmp_path_factory.mktemp("cache")
    saved = {k: os.environ.get(k) for k in (build.ENV_CACHE, toolchain.ENV_CHOICE)}
    cores, paths = {}, {}
    try:
        os.environ[build.ENV_CACHE] = str(cache)
        for choice in ("system", "zig"):
            os.environ[toolchain.ENV_CHOICE] = choice
            paths[choice] = build.build_library(ALL_VARIANTS)
            cores[choice] = compiled.Core(paths[choice])
    finally:
        for k, v in saved.items():
            os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v)
    return cores, paths


#: One parameter set per structure the variants branch on, with the always-compiled effects on.
CASES = [Params(), Params(c=40.0, Fc=2.0), Params(tau=0.03, c=20.0), Params(model=1, c=10.0),
         Params(slack=1, c=10.0), Params(model=1, tau=0.02, slack=1, c=5.0, Fc=1.0)]


def _close(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = max(1.0, float(np.abs(b).max()))
    np.testing.assert_allclose(a, b, rtol=TOLERANCE, atol=TOLERANCE * scale)


def test_the_cache_keeps_each_toolchain_s_library_and_records_its_compiler(libraries):
    _, paths = libraries
    assert paths["system"] != paths["zig"] and paths["system"].parent == paths["zig"].parent
    records = {k: json.loads(p.with_name(p.name + ".json").read_text()) for k, p in paths.items()}
    assert f"{toolchain.ZIG_PACKAGE} " in records["zig"]["compiler"], records["zig"]
    assert "ziglang" not in records["system"]["compiler"]
    # the same generated C
    assert records["zig"]["source_sha256"] == records["system"]["source_sha256"]
    assert records["zig"]["cflags"] == records["system"]["cflags"] == list(build.CFLAGS)
    # two compilers: two different binaries
    assert paths["system"].read_bytes() != paths["zig"].read_bytes()


def test_zig_s_core_gives_the_system_compiler_s_results(libraries):
    cores, _ = libraries
    rng = np.random.default_rng(31)
    for params in CASES:
        assert any(Variant.of(params) == v for v in ALL_VARIANTS)
        stops = knee.stop_positions(params)
        pe0, pf0 = default_commands(params)
        sim = KneeSimulator(params)
        n_state = sim.state.size
        states = np.tile(sim.state, (40, 1))
        states[:, 0] = rng.uniform(stops[0], stops[1], 40)
        states[:, 1] = rng.normal(0.0, 0.5, 40)
        if n_state > 2:  # the lagged pressures
            states[:, 2:] *= rng.uniform(0.8, 1.2, (40, n_state - 2))
        pe, pf = pe0 * rng.uniform(0.7, 1.3, 40), pf0 * rng.uniform(0.7, 1.3, 40)
        lengths, pressures = rng.uniform(0.15, 0.19, 8), rng.uniform(1e5, 5e5, 8)
        rates = rng.normal(0.0, 0.05, 8)
        results = {}
        for name, core in cores.items():
            rhs = [core.knee_rhs(params, y, a, b, stops) for y, a, b in zip(states, pe, pf)]
            assert all(r is not None for r in rhs), name
            tension = [core.actuator("tension", params, *x) for x in zip(lengths, pressures, rates)]
            results[name] = (np.array(rhs), core.knee_outputs_many(params, states, pe, pf),
                             np.array(tension))
        for a, b in zip(results["zig"], results["system"]):
            _close(a, b)


def _record(core, params):
    t = np.arange(1500) * 1e-3
    pe0, pf0 = default_commands(params)
    pe = np.where((t >= 0.1) & (t < 0.9), pe0 * 1.06, pe0)
    pf = np.full(t.size, pf0)
    sim = KneeSimulator(params)
    states = np.empty((t.size, sim.state.size))
    outputs = np.empty((t.size, len(KNEE_OUTPUTS)))
    done = core.run_record(sim, t, pe, pf, None, states, outputs)
    assert done == t.size - 1
    return states, outputs


@pytest.mark.parametrize("case", range(len(CASES)))
def test_a_whole_knee_record_is_the_same_with_either_compiler(libraries, case):
    cores, _ = libraries
    params = CASES[case]
    system, zig = _record(cores["system"], params), _record(cores["zig"], params)
    assert np.ptp(system[0][:, 0]) > 1e-3  # the knee moved
    for a, b in zip(zig, system):
        _close(a, b)


def test_the_damped_isotonic_test_is_the_same_with_either_compiler(libraries):
    cores, _ = libraries
    params = Params(c=40.0, Fc=2.0)
    t = np.arange(2000) * 1e-3
    pressure = np.where(t > 0.2, 4e5, 2e5)
    load = np.full(t.size, 100.0)
    lengths = [cores[k].isotonic_damped(params, t, pressure, load, 0.17, True)
               for k in ("system", "zig")]
    assert lengths[0] is not None and np.ptp(lengths[0]) > 1e-4
    _close(lengths[1], lengths[0])


def test_the_toolchain_switch(monkeypatch):
    monkeypatch.setenv(toolchain.ENV_CHOICE, "gcc-please")
    with pytest.raises(MkctlError,
                       match=r"^MKCTL_CC must be one of auto, system, zig, got 'gcc-please'$"):
        build.find_compiler()
    monkeypatch.setenv(toolchain.ENV_CHOICE, "zig")
    monkeypatch.setattr(toolchain, "zig_installed", lambda: False)
    assert build.find_compiler() is None
    with pytest.raises(build.BuildUnavailable,
                       match=r"MKCTL_CC=zig but the ziglang package is not installed "
                             r"\(pip install mkctl\[native\]\)"):
        build.build_library((Variant.of(Params()),))
    monkeypatch.setattr(toolchain, "zig_installed", lambda: True)
    assert toolchain.is_zig(build.find_compiler())
    # auto: the system compiler first, else ziglang; a $CC named but missing means none
    monkeypatch.delenv(toolchain.ENV_CHOICE)
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", "/nonexistent")
    assert toolchain.is_zig(build.find_compiler())
    monkeypatch.setenv("CC", "/nonexistent/cc")
    assert build.find_compiler() is None
