"""Drive a knee FMU (model-spec section 7) with fmpy: step responses and a linearization of the FMU itself.

This is how a user with a modified FMU gets its linear model without access to its equations: the FMU's
hip dynamics are probed only through its interface (the parameter ``X0``, the inputs ``pe_cmd``, ``pf_cmd``,
the outputs ``X, V, Pe, Pf``, and fmi2GetFMUstate / fmi2SetFMUstate).

Linearization from the flow map
-------------------------------
The FMU integrates ``dx/dt = f(x, u)`` over a communication step ``dt``: ``x' = phi(x, u)``. Around an
equilibrium (x0, u0) with u held over the step, the exact Jacobian of that map is

    [[Phi, Gamma], [0, I]] = expm([[A, B], [0, 0]] dt),

with A, B the Jacobians of f (the variational equation has constant coefficients at an equilibrium). So
the continuous A, B follow exactly from a finite-difference Jacobian of one FMU step by a matrix
logarithm, ``[[A, B], [0, 0]] = logm([[Phi, Gamma], [0, I]]) / dt`` (principal branch: |eig(A)| dt < pi).

The states X, V, Pe, Pf cannot be set directly, so the perturbed states are prepared through the interface
and read back from the outputs (the state is fully observed):

- X: a fresh instance with ``X0 = X0_op +- hX`` (at rest);
- V: the same instance, restored to its start with fmi2SetFMUstate and run for a preparation time with u0
  (two times, ``t_prep`` and ``0.37 t_prep``): the leg has started to move and has a velocity;
- Pe, Pf (pressure lag only): the lag starts at P(0) = P_cmd(0), so the commands at initialization are
  ``u0 +- hP`` and are set back to u0 for the step;
- inputs: from the equilibrium state, restored with fmi2SetFMUstate, one step with ``u0 +- hP``.

Every sample is a pair of (perturbed state and input, state after one step), with the perturbations in
symmetric +- pairs so that the quadratic terms cancel; ``[Phi, Gamma]`` is their least-squares fit.

This module deliberately imports nothing from mkctl (only numpy, scipy and fmpy): it can then be loaded by
file path in a fresh process, where the FMU uses its own packed copy of mkctl, not ours.
"""
from __future__ import annotations

import math
import shutil
import sys
import zipfile
from pathlib import Path

import numpy as np
from scipy.linalg import logm

try:  # part of the mkctl package: errors are MkctlErrors (one line in the CLI)
    from ..errors import MkctlError as _Base
except ImportError:  # loaded standalone by file path (test subprocess)
    _Base = RuntimeError

#: The knee FMU's signals used here.
INPUTS = ("pe_cmd", "pf_cmd")
STATE_OUTPUTS = ("X", "V", "Pe", "Pf")


class FMUAnalysisError(_Base):
    """The FMU could not be loaded, refused a step, or did not expose what the analysis needs."""


def check_fmu(path) -> Path:
    """``path`` as a Path if it is an FMU file (a zip archive holding ``modelDescription.xml``).

    Raises :class:`FMUAnalysisError` with one line that says what it is instead: missing, a folder, not a
    zip archive, or a zip archive without a model description.
    """
    path = Path(path)
    if not path.exists():
        raise FMUAnalysisError(f"FMU file {path} not found (build it with: python build_fmu.py)")
    if path.is_dir():
        raise FMUAnalysisError(f"FMU {path} is a folder, not an FMU file")
    try:
        if not zipfile.is_zipfile(path):
            raise FMUAnalysisError(f"{path} is not an FMU (not a zip archive)")
        with zipfile.ZipFile(path) as archive:
            if "modelDescription.xml" not in archive.namelist():
                raise FMUAnalysisError(f"{path} is not an FMU (the zip archive has no modelDescription.xml)")
    except (OSError, zipfile.BadZipFile) as error:
        raise FMUAnalysisError(f"{path} cannot be read as an FMU: {error}") from None
    return path


def _model_description(path):
    """fmpy's model description of the checked FMU at path; a broken one raises FMUAnalysisError."""
    from fmpy import read_model_description

    path = check_fmu(path)
    try:
        return read_model_description(str(path))
    except Exception as error:  # noqa: BLE001 - fmpy raises many kinds for a broken description
        raise FMUAnalysisError(f"{path} is not a valid FMU: {error}") from None


def check_knee_fmu(path) -> Path:
    """``path`` as a Path if it is a knee FMU (spec section 7: inputs pe_cmd, pf_cmd; outputs X, V, Pe, Pf;
    parameter X0); else :class:`FMUAnalysisError` with one line naming the model it holds instead (an actuator FMU
    given where the knee is needed)."""
    path = check_fmu(path)
    md = _model_description(path)
    names = {v.name for v in md.modelVariables}
    missing = [name for name in (*INPUTS, *STATE_OUTPUTS, "X0") if name not in names]
    if missing:
        raise FMUAnalysisError(f"{path} is not a knee FMU: it holds the model {md.modelName!r}, which lacks the "
                               f"variable(s) {', '.join(missing)} of the knee (model-spec section 7)")
    return path


class KneeFMU:
    """One instance of a knee FMU driven step by step with fmpy's FMU2Slave (context manager).

    Parameters: path to the .fmu; start_values: parameter values by name (unknown names are ignored, so a
    full :meth:`mkctl.physics.params.Params.as_dict` can be passed); inputs: (pe_cmd, pf_cmd) [Pa] at initialization;
    tolerance: passed to fmi2SetupExperiment.
    """

    def __init__(self, path, start_values: dict, inputs, tolerance: float | None = None, unzipdir=None):
        from fmpy import extract

        path = Path(path)
        self.md = _model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        missing = [name for name in (*INPUTS, *STATE_OUTPUTS, "X0") if name not in self.vr]
        if missing:
            raise FMUAnalysisError(f"FMU {path.name} lacks the variable(s) {', '.join(missing)}")
        self._own_dir = unzipdir is None  # extracted here: removed again in close()
        self._unzipdir = unzipdir or extract(str(path))
        self._states = []
        self.fmu = instantiate(self.md, self._unzipdir, "probe")
        self.time = 0.0
        try:
            self.fmu.setupExperiment(tolerance=tolerance, startTime=0.0)
            for name, value in start_values.items():
                if name in self.vr and value is not None:
                    self._set(name, value)
            self.set_inputs(inputs)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        except Exception as error:
            self.close()
            raise FMUAnalysisError(f"FMU {path.name} failed to initialize: {error}") from error

    def _set(self, name, value):
        vr = [self.vr[name]]
        kind = self.types[name]
        if kind == "Integer":
            self.fmu.setInteger(vr, [int(value)])
        elif kind == "Boolean":
            self.fmu.setBoolean(vr, [bool(value)])
        else:
            self.fmu.setReal(vr, [float(value)])

    def set_inputs(self, inputs) -> None:
        self.fmu.setReal([self.vr[n] for n in INPUTS], [float(v) for v in inputs])

    def read(self, names=STATE_OUTPUTS) -> np.ndarray:
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def step(self, dt: float) -> None:
        try:
            self.fmu.doStep(self.time, dt)
        except Exception as error:  # fmpy raises on fmi2Discard/fmi2Error
            raise FMUAnalysisError(f"FMU refused the step from t = {self.time:g} s over {dt:g} s: {error}") from error
        self.time += dt

    def get_state(self):
        """A saved FMU state (fmi2GetFMUstate) with the time; freed in close()."""
        state = self.fmu.getFMUstate()
        self._states.append(state)
        return state, self.time

    def set_state(self, saved) -> None:
        self.fmu.setFMUstate(saved[0])
        self.time = saved[1]

    def close(self) -> None:
        try:
            for state in self._states:
                self.fmu.freeFMUstate(state)
            self.fmu.terminate()
        except Exception:  # noqa: BLE001 - a failed instance may refuse terminate; freeing it is what matters
            pass
        free_instance(self.fmu)
        if self._own_dir:
            remove_extraction(self._unzipdir)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: Defaults of :func:`flow_map_jacobian`, measured on the knee FMU at alpha = 60 deg against the analytic
#: Jacobian: the error grows as hX^2 (a2 changes tenfold between alpha = 60 and 70 deg, about 13 mm of X) and,
#: for much smaller hX, as 1/hX (the FMU's integrator tolerances); hX = 3e-5 m, dt = 0.02 s gives ~1e-5.
DT, HX, HP, T_PREP = 0.02, 3e-5, 1e3, 0.1


def free_instance(fmu) -> None:
    """fmi2FreeInstance without unloading the binary, for an instance made by :func:`instantiate`.

    fmpy's ``freeInstance`` also unloads the shared library (dlclose). For a pythonfmu FMU, whose binary embeds
    the host's Python, that makes the host abort at exit now and then ("corrupted double-linked list", seen
    here in about half of the runs, with simulate_fmu as well); keeping the library loaded avoids it.
    """
    fmu.fmi2FreeInstance(fmu.component)


def prefer_installed_pythonfmu() -> None:
    """Import the installed pythonfmu, if there is one, before a pythonfmu FMU loads in this process: its slave
    script then uses it, not the copy packed in the FMU's resources, whose folder is deleted after the run (a
    later ``import pythonfmu`` would find that deleted copy first on ``sys.path``)."""
    try:
        import pythonfmu  # noqa: F401
    except ImportError:  # a host with fmpy only: the FMU brings its own
        pass


def remove_extraction(unzipdir) -> None:
    """Delete an FMU's extraction folder, and the ``sys.path`` entries a pythonfmu FMU run in this process added
    inside it (a later import would look there first)."""
    root = str(Path(unzipdir).resolve())
    shutil.rmtree(unzipdir, ignore_errors=True)
    sys.path[:] = [entry for entry in sys.path if not (entry and str(Path(entry).resolve()).startswith(root))]


def instantiate(md, unzipdir, name: str = "run", callbacks=None, logging_on: bool = False):
    """A co-simulation instance (fmpy's FMU2Slave, instantiated) of the FMU described by md, extracted in unzipdir.

    callbacks: fmi2CallbackFunctions (fmpy's default logger when None), referenced by the caller as long as the
    instance lives; logging_on: fmi2's loggingOn. Free it with :func:`free_instance`, not ``freeInstance``.
    fmpy raises a plain Exception when fmi2Instantiate returns NULL.
    """
    from fmpy.fmi2 import FMU2Slave

    prefer_installed_pythonfmu()
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
    return fmu


def flow_map_jacobian(path, start_values: dict, X0: float, inputs, lag: bool, dt: float = DT,
                      hX: float = HX, hP: float = HP, t_prep: float = T_PREP, tolerance: float | None = None):
    """Least-squares Jacobian [Phi, Gamma] of one FMU step of length dt [s] at the equilibrium (X0, inputs).

    Parameters: start_values: the FMU's parameters (X0 is set here); X0: equilibrium hip height [m];
    inputs: (pe_cmd, pf_cmd) [Pa] that hold it; lag: whether the FMU has the pressure states (tau > 0);
    hX [m], hP [Pa]: perturbation sizes; t_prep [s]: the longer of the two preparation runs that create a
    velocity (the other is 0.37 t_prep, so that the velocity cannot vanish at both, whatever the knee's period);
    dt [s]: the step whose map is differentiated (keep |eig(A)| dt well below pi).
    Returns (Phi, Gamma, x0) with x0 the equilibrium state read from the FMU.
    """
    from fmpy import extract

    check_fmu(path)
    n = 4 if lag else 2
    u0 = np.array(inputs, dtype=float)
    unzipdir = extract(str(path))
    samples = []  # (state before, input, state after)

    def instance(X_start, u_start):
        return KneeFMU(path, {**start_values, "X0": X_start}, u_start, tolerance, unzipdir)

    def after_step(fmu, u):
        fmu.set_inputs(u)
        fmu.step(dt)
        return fmu.read()[:n]

    try:
        x0, x0_next = _collect(instance, after_step, samples, u0, X0, n, lag, hX, hP, t_prep)
    finally:
        remove_extraction(unzipdir)
    dz = np.array([np.concatenate([x - x0, u - u0]) for x, u, _ in samples])
    dy = np.array([y - x0_next for _, _, y in samples])
    # scale columns so that the fit weighs states (m, m/s) and pressures (Pa) alike
    scale = np.abs(dz).max(axis=0)
    M_scaled, *_ = np.linalg.lstsq(dz / scale, dy, rcond=None)
    M = (M_scaled / scale[:, None]).T  # dy = M dz
    return M[:, :n], M[:, n:], x0


def _collect(instance, after_step, samples, u0, X0, n, lag, hX, hP, t_prep):
    """Fill samples with the perturbed runs of :func:`flow_map_jacobian`; return the equilibrium and its image."""
    with instance(X0, u0) as fmu:  # the equilibrium, and the input columns
        x0 = fmu.read()[:n]
        rest = fmu.get_state()
        x0_next = after_step(fmu, u0)
        for j in range(2):
            for sign in (1, -1):
                fmu.set_state(rest)
                u = u0.copy()
                u[j] += sign * hP
                samples.append((x0, u, after_step(fmu, u)))
    for sign in (1, -1):  # X at rest, then a state with a velocity prepared from it
        with instance(X0 + sign * hX, u0) as fmu:
            start = fmu.read()[:n]
            saved = fmu.get_state()
            samples.append((start, u0, after_step(fmu, u0)))
            for duration in (0.37 * t_prep, t_prep):
                fmu.set_state(saved)
                fmu.step(duration)
                prepared = fmu.read()[:n]
                samples.append((prepared, u0, after_step(fmu, u0)))
        if lag:  # pressure states: the lag starts at the command given at initialization
            for j in range(2):
                u_start = u0.copy()
                u_start[j] += sign * hP
                with instance(X0, u_start) as fmu:
                    start = fmu.read()[:n]
                    samples.append((start, u0, after_step(fmu, u0)))
    return x0, x0_next


def linearize_fmu(path, start_values: dict, X0: float, inputs, lag: bool, dt: float = DT, hX: float = HX,
                  hP: float = HP, t_prep: float = T_PREP, max_halvings: int = 12):
    """Continuous (A, B, dt) of the FMU at the equilibrium (X0, inputs), from :func:`flow_map_jacobian` + logm.

    The matrix logarithm has a principal branch only while |eig(A)| dt < pi, and a fast knee (a small mass, a
    stiff posture) would alias silently. So dt is halved until the eigenvalues from dt and dt/2 agree
    (within 1 % of the largest); the estimate from the longer of the two is returned, with its dt.
    """
    def estimate(step):
        Phi, Gamma, _ = flow_map_jacobian(path, start_values, X0, inputs, lag, step, hX, hP, t_prep)
        return continuous_from_flow_map(Phi, Gamma, step)

    A, B = estimate(dt)
    for _ in range(max_halvings):
        A_half, B_half = estimate(dt / 2)
        eig, eig_half = np.sort_complex(np.linalg.eigvals(A)), np.sort_complex(np.linalg.eigvals(A_half))
        if np.abs(eig - eig_half).max() <= 1e-2 * np.abs(eig_half).max():
            return A, B, dt
        A, B, dt = A_half, B_half, dt / 2
    raise FMUAnalysisError(f"the FMU's linearization did not settle down to dt = {dt:g} s")


def continuous_from_flow_map(Phi, Gamma, dt: float):
    """(A, B) from one step's (Phi, Gamma) by ``logm([[Phi, Gamma], [0, I]]) / dt`` (see the module docstring)."""
    n, m = Gamma.shape
    aug = np.zeros((n + m, n + m))
    aug[:n, :n], aug[:n, n:], aug[n:, n:] = Phi, Gamma, np.eye(m)
    log = logm(aug) / dt
    if np.abs(np.imag(log)).max() > 1e-6 * max(1.0, np.abs(log).max()):
        return np.full((n, n), np.nan), np.full((n, m), np.nan)  # no real logarithm: dt too long
    log = np.real(log)
    return log[:n, :n], log[:n, n:]


def fmu_step_response(path, start_values: dict, inputs0, inputs1, t_step: float, duration: float,
                      output_interval: float, outputs=("X",)):
    """Simulate the FMU with fmpy's ``simulate_fmu``: inputs0 [Pa] until t_step [s], then inputs1, until duration.

    The FMU starts at rest at ``start_values["X0"]`` with its lag (if any) at inputs0. Returns a dict of
    arrays: "time" and each name in outputs. Raises :class:`FMUAnalysisError` if the run stops early.
    """
    from fmpy import extract, simulate_fmu

    path = check_knee_fmu(path)
    md = _model_description(path)
    known = {v.name for v in md.modelVariables if v.causality == "parameter"}
    values = {k: v for k, v in start_values.items() if k in known and v is not None}
    dtype = [("time", float), ("pe_cmd", float), ("pf_cmd", float)]
    # a repeated time is fmpy's way to write a step: the first row holds up to t_step, the second after it
    signal = np.array([(0.0, *inputs0), (t_step, *inputs0), (t_step, *inputs1), (duration, *inputs1)], dtype=dtype)
    unzipdir = extract(str(path))
    fmu = instantiate(md, unzipdir)  # our own instance, freed without unloading the binary
    try:
        result = simulate_fmu(str(path), start_time=0.0, stop_time=duration, output_interval=output_interval,
                              start_values=values, input=signal, output=list(outputs), model_description=md,
                              fmu_instance=fmu)
    except Exception as error:  # fmpy raises on fmi2Error/fmi2Discard
        raise FMUAnalysisError(f"the FMU failed: {error}") from error
    finally:
        free_instance(fmu)
        remove_extraction(unzipdir)
    if not math.isclose(result["time"][-1], duration, rel_tol=0, abs_tol=output_interval / 2):
        raise FMUAnalysisError(f"the FMU stopped at t = {result['time'][-1]:g} s before {duration:g} s")
    return {"time": np.asarray(result["time"], dtype=float), **{k: np.asarray(result[k], dtype=float) for k in outputs}}
