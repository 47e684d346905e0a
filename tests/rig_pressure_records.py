"""Pressure records as a real rig writes them, made by the independent pneumatic simulator (issue 28).

Nothing here comes from mkctl: the air is tests/independent_pneumatics.py (its own ISO 6358 flow, volume, mass
and energy balance), and the record is what a lab's logger writes (model-spec section 5c): a 20 mm muscle on a
switching valve from a 620 kPa supply, sampled at about 80 Hz with a jittery clock (10-15 ms steps), the pressure
quantised to 0.76 kPa with a little sensor noise, and the valve acting a dead time after the logged command (the
valve's and the tubing's). These are the records the issue measured on a real 20 mm Festo muscle; the hidden values
are this module's, so that a test can check what a diagnosis reads from them.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import independent_pneumatics as air

#: A 20 mm muscle, 400 mm long at rest: braid angle 22 degrees at L0 (b = L0 / cos, n = b sin / (pi D0)).
L0 = 0.400
D0 = 0.020
THETA0 = math.radians(22.0)
B = L0 / math.cos(THETA0)
N = B * math.sin(THETA0) / (math.pi * D0)

#: The rig's air (SI): a solenoid valve about 0.3 L/(s bar), a supply at 620 kPa, 8 mL of tubing.
RIG = {"C_fill": 3e-9, "C_exhaust": 0.0, "P_supply": 620e3, "band": 2e4, "b_cr": 0.25, "m_sub": 0.9,
       "k_poly": 1.2, "V_dead": 8e-6, "T_air": 293.15, "C_leak": 0.0, "tau_heat": 0.0}
DEAD_TIME = 0.015  #: s, from the logged valve command to the valve's opening
RESOLUTION = 760.0  #: Pa, the pressure sensor's quantum
NOISE = 250.0  #: Pa, the sensor's white noise before quantisation


def jittered_times(duration: float, rng, low: float = 0.010, high: float = 0.015) -> np.ndarray:
    """Sample times of a logger whose steps wander between low and high [s]."""
    steps = rng.uniform(low, high, size=int(duration / low) + 2)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    return times[times <= duration]


def valve_schedule(times, switches) -> np.ndarray:
    """The logged valve command at each sample: switches = [(time, opening), ...], 0 before the first."""
    u = np.zeros_like(times)
    for at, value in switches:
        u[times >= at] = value
    return u


def simulate(times, logged, rig: dict, *, P_start: float = 0.0, dead_time: float = DEAD_TIME,
             length: float = L0) -> np.ndarray:
    """The true gauge pressure [Pa] at the sample times: the valve acts dead_time after each logged switch.

    The acting valve opening is piecewise constant with its switches at (logged switch + dead time), which need
    not fall on a sample: the simulation runs on the union of both time grids and returns the sample times.
    """
    changes = np.flatnonzero(np.diff(logged)) + 1
    acting_times = times[changes] + dead_time
    grid = np.union1d(times, acting_times[acting_times < times[-1]])
    acting = np.zeros_like(grid)
    acting[:] = logged[0]
    for at, value in zip(acting_times, logged[changes]):
        acting[grid >= at - 1e-12] = value
    pressure, _, _ = air.simulate(grid, "opening", acting, rig, B, N, P_start, length=length)
    return np.interp(times, grid, pressure)


def measured(pressure, rng, noise: float = NOISE, resolution: float = RESOLUTION) -> np.ndarray:
    """What the sensor reports: the pressure plus white noise, quantised."""
    return np.round((pressure + rng.normal(0.0, noise, size=pressure.shape)) / resolution) * resolution


def write_record(path: Path, times, logged, p_measured, *, supply: float, length: float = L0,
                 extra: dict | None = None) -> Path:
    """A model-spec 5c record: metadata (the muscle, the supply), then time_s, valve, p_kPa."""
    lines = ["# experiment = pressure", f"# L0 = {L0}", f"# D0 = {D0}", f"# b = {B:.6f}", f"# n = {N:.6f}",
             f"# length_mm = {length * 1e3:.3f}", f"# supply_kPa = {supply / 1e3:g}"]
    lines += [f"# {key} = {value}" for key, value in (extra or {}).items()]
    lines.append("time_s,valve,p_kPa")
    lines += [f"{t:.4f},{u:g},{p / 1e3 + 0.0:.2f}" for t, u, p in zip(times, logged, p_measured)]
    path.write_text("\n".join(lines) + "\n")
    return path


def fill_and_exhaust(path: Path, seed: int = 0, rig: dict | None = None, dead_time: float = DEAD_TIME) -> dict:
    """A fill from the supply and an exhaust to the atmosphere of the clamped muscle, as a lab records it."""
    rng = np.random.default_rng(seed)
    rig = dict(RIG, **(rig or {}))
    times = jittered_times(3.0, rng)
    logged = valve_schedule(times, [(0.2, 1.0), (1.6, -1.0)])
    truth = simulate(times, logged, rig, dead_time=dead_time)
    write_record(path, times, logged, measured(truth, rng), supply=rig["P_supply"])
    return {"time": times, "valve": logged, "pressure": truth, "rig": rig, "dead_time": dead_time}


def leak_down(path: Path, seed: int = 0, C_leak: float = 5e-12, tau_heat: float = 0.4,
              duration: float = 60.0) -> dict:
    """A fast fill (the valve open 0.6 s), then the valve closed: the air cools and leaks away."""
    rng = np.random.default_rng(seed)
    rig = dict(RIG, C_leak=C_leak, tau_heat=tau_heat)
    times = jittered_times(duration, rng)
    logged = valve_schedule(times, [(0.2, 1.0), (0.8, 0.0)])
    truth = simulate(times, logged, rig)
    write_record(path, times, logged, measured(truth, rng), supply=rig["P_supply"])
    return {"time": times, "valve": logged, "pressure": truth, "rig": rig}
