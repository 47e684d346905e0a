"""``mkctl linearize``, ``mkctl rootlocus`` and ``mkctl step``: the linear view of the knee (:mod:`mkctl.analysis.control`).

Common options: the posture (``--alpha`` deg or ``--X`` m, default alpha = 60 deg), the flexor pressure
(``--pf`` kPa, default 100), the damping (``--c`` N s/m; where a damped knee is needed and no c is given,
the closed-form c for ``--zeta``, default 0.3), the lag (``--tau`` s), any parameter (``--set NAME=VALUE``,
SI) and the folder for the PNGs (``--out``, checked before any work). Pressures are gauge pressures in kPa:
below 0 is refused (a muscle under vacuum does not pull), above 10 MPa gets a note.

``--mechanism NAME|FILE.py`` (model-spec 3b) analyses another mechanism (:mod:`mkctl.analysis.mechanism_control`):
its rest under ``--pressure KPA`` (one per muscle, default 300 each) in place of the knee's posture options
(``--alpha``, ``--X``, ``--pf``, ``--fmu``), its own parameters with ``--set NAME=VALUE`` like the muscle's; the
same text and pictures, in the mechanism's coordinate and unit (mm or deg).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..analysis import control_defaults
from ..physics.params import RATED_PRESSURE
from ..physics.simulate import DEFAULT_ALPHA, DEFAULT_PF
from .options import UsageError, add_params_option, base_params, output_folder, parse_assignments


class _Lazy:
    """A module of :mod:`mkctl.analysis`, imported on first use: python-control takes seconds to import, and
    ``mkctl --help`` or another subcommand should not wait for it."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, name):
        from ..analysis import air_poles, control

        return getattr({"control": control, "air_poles": air_poles}[self._name], name)


mc = _Lazy("control")
air_poles = _Lazy("air_poles")

#: The knee FMU the commands use unless --fmu names one: where ``python build_fmu.py`` writes it, in the folder
#: the command runs in (a command-line default; the library takes the path explicitly).
CLI_DEFAULT_FMU = Path("dist") / "McKibbenKnee.fmu"

#: Above this gauge pressure [Pa] a note says the result is far outside what a McKibben muscle takes: many
#: times its rating (the defaults already need about three times it, so the note is kept for the extreme).
PLAUSIBLE_PRESSURE = 10 * RATED_PRESSURE
#: Largest gauge pressure an option takes [kPa]: 100 MPa, as a measurement file (mkctl.io.measurements.LARGEST).
LARGEST_KPA = 1e5
#: Largest damping ratio --zeta takes (critical damping is 1).
LARGEST_ZETA = 100.0
#: Largest height gain --gain takes [Pa/m]: a 1 mm error would command 1000 MPa.
LARGEST_GAIN = 1e12
#: The integral times --ti takes [s].
SHORTEST_TI, LONGEST_TI = 1e-6, 1e4
#: Smallest pressure step --small and --large take [kPa] (1 Pa: below it the response is lost in rounding).
SMALLEST_STEP_KPA = 1e-3
#: Longest step response --duration takes [s].
LONGEST_RESPONSE = 1000.0
#: A mechanism's default pressure per muscle [kPa] (--mechanism without --pressure).
MECHANISM_PRESSURE_KPA = 300.0


def _add_common(parser, needs_damping: bool) -> None:
    posture = parser.add_mutually_exclusive_group()
    posture.add_argument("--alpha", type=float, metavar="DEG", help="kneecap angle of the posture (default 60)")
    posture.add_argument("--X", type=float, metavar="M", help="hip height of the posture instead of --alpha")
    parser.add_argument("--pf", type=float, default=DEFAULT_PF / 1e3, metavar="KPA",
                        help="flexor gauge pressure, >= 0 (default %(default)g)")
    parser.add_argument("--c", type=float, metavar="NS_PER_M",
                        help="viscous damping of each actuator (default: "
                             + ("the c that gives --zeta)" if needs_damping else "0, the paper's model 2)"))
    parser.add_argument("--zeta", type=float, default=control_defaults.DEFAULT_ZETA,
                        help="damping ratio for the closed-form c (default %(default)g)")
    parser.add_argument("--tau", type=float, metavar="S", help="pressure lag time constant (default 0: no lag)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="any parameter in SI units, e.g. --set m=2.5 (repeatable)")
    add_params_option(parser)
    parser.add_argument("--out", type=Path, default=Path("control_plots"), help="folder for the PNGs "
                        "(default %(default)s)")
    parser.add_argument("--mechanism", metavar="NAME|FILE.py", default=None,
                        help="analyse another mechanism (hanging_mass, pulley_joint, knee or a mechanism file, "
                             "model-spec 3b) at its rest under --pressure; default: the paper's knee at --alpha")
    parser.add_argument("--pressure", action="append", default=[], metavar="KPA",
                        help="with --mechanism: each muscle's gauge pressure [kPa], one per muscle (comma-separated "
                             f"or repeated; default {MECHANISM_PRESSURE_KPA:g} each)")


def _add_fmu(parser) -> None:
    parser.add_argument("--fmu", type=Path, default=None,
                        help=f"knee FMU (default {CLI_DEFAULT_FMU} in the working folder, skipped with a note if it is not built; "
                             "a path given here must be an FMU)")
    parser.add_argument("--no-fmu", action="store_true", help="leave the FMU out")


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "linearize": "operating point, linear model, poles and the damping for zeta",
    "rootlocus": "root loci against c, tau or the height-control gain",
    "step": "pressure-step responses: linear, nonlinear and FMU",
}


def register(subparsers) -> None:
    """Add ``linearize``, ``rootlocus`` and ``step`` to the ``mkctl`` parser."""
    p = subparsers.add_parser("linearize", help=COMMANDS["linearize"],
                              description="Find the rest state at a posture, linearize there (analytic, "
                                          "python-control's linearize, and the FMU), print A, B, the poles, "
                                          "Eq. 19 and the damping c for a damping ratio; save a pole map.")
    _add_common(p, needs_damping=False)
    _add_fmu(p)
    p.set_defaults(func=run_linearize)

    p = subparsers.add_parser("rootlocus", help=COMMANDS["rootlocus"],
                              description="Root locus against the damping c (exact velocity feedback), a sweep "
                                          "of the lag tau (open and closed loop), or the gain of a height "
                                          "controller through pe_cmd with and without the lag.")
    p.add_argument("--vary", choices=("c", "tau", "gain", "C_fill", "V_dead", "band"),
                   default="gain",
                   help="what varies (default gain); C_fill, V_dead or band: the air's valve, "
                        "dead volume or regulator band, with the pressures as states (model-spec "
                        "4d, the air switched on)")
    _add_common(p, needs_damping=True)
    p.add_argument("--gain", type=float, metavar="PA_PER_M",
                   help="only with --vary tau: the height gain K > 0 of the closed loop swept against tau "
                        "(default: the critical gain at --tau, or at 0.05 s); --vary gain scans K itself")
    p.add_argument("--ti", type=float, metavar="S", help="integral time: PI instead of P height control")
    p.set_defaults(func=run_rootlocus)

    p = subparsers.add_parser("step", help=COMMANDS["step"],
                              description="Responses of the hip height to a step of pe_cmd, small and large, "
                                          "from the linear model, the nonlinear model and the FMU, with rise "
                                          "time, overshoot and settling time.")
    _add_common(p, needs_damping=True)
    p.add_argument("--small", type=float, default=1.0, metavar="KPA",
                   help="small step of pe_cmd, non-zero (default %(default)g)")
    p.add_argument("--large", type=float, default=100.0, metavar="KPA",
                   help="large step of pe_cmd, non-zero; pe must stay >= 0 (default %(default)g)")
    p.add_argument("--duration", type=float, default=2.0, metavar="S",
                   help="length of each simulated response, > 0.1 s (the step comes at 0.1 s; default %(default)g)")
    p.add_argument("--dt", type=float, default=1e-3, metavar="S", help="output interval (default %(default)g)")
    _add_fmu(p)
    p.set_defaults(func=run_step)


# --- shared set-up ---------------------------------------------------------------------------------

def _setup(args, needs_damping: bool):
    """The operating point with c and tau applied, from the common options (checked first, with --out)."""
    output_folder(args.out, "--out")
    if not math.isfinite(args.pf) or args.pf < 0:
        raise UsageError(f"--pf {args.pf:g}: the flexor pressure is a gauge pressure and must be >= 0 kPa "
                         "(a muscle below atmospheric pressure does not pull)")
    if not args.pf <= LARGEST_KPA:
        raise UsageError(f"--pf {args.pf:g}: outside [0, {LARGEST_KPA:g}] kPa (a hundred times what a muscle takes)")
    if not (math.isfinite(args.zeta) and 0 <= args.zeta <= LARGEST_ZETA):
        raise UsageError(f"--zeta {args.zeta:g}: the damping ratio must lie in [0, {LARGEST_ZETA:g}]")
    overrides = parse_assignments(args.set)
    params = base_params(args).replace(**{k: v for k, v in overrides.items() if k not in ("c", "tau")})
    alpha = math.radians(args.alpha) if args.alpha is not None else (None if args.X is not None else DEFAULT_ALPHA)
    op = mc.operating_point(alpha, X=args.X, Pf=args.pf * 1e3, params=params)
    c = args.c if args.c is not None else overrides.get("c")
    if c is None:
        c = mc.damping_for_zeta(args.zeta, op) if needs_damping else 0.0
    tau = args.tau if args.tau is not None else overrides.get("tau", 0.0)
    for name, value in (("pf", op.Pf), ("pe", op.Pe)):
        if value > PLAUSIBLE_PRESSURE:
            print(f"note: {name} = {value / 1e6:.4g} MPa is far above what a McKibben muscle takes (rated about "
                  f"{RATED_PRESSURE / 1e6:g} MPa); the model has no limit, so the results below are the model's, "
                  "not a real muscle's")
    return op.with_params(c=c, tau=tau)


def _fmu_path(args):
    """The FMU to use: None with --no-fmu or when the default one is not built (with a note); an --fmu given
    explicitly must exist and be an FMU."""
    if args.no_fmu:
        return None
    if args.fmu is None:
        default = CLI_DEFAULT_FMU.resolve()  # explicit from here on: the library gets an absolute path
        if not default.is_file():
            print(f"note: FMU {CLI_DEFAULT_FMU} not found (python build_fmu.py builds it); FMU part skipped")
            return None
        return default
    from ..analysis.fmu_probe import check_knee_fmu

    return check_knee_fmu(args.fmu)


def _fmt_poles(eig) -> str:
    return ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" if abs(z.imag) > 1e-12 else f"{z.real:.4g}"
                     for z in np.sort_complex(np.asarray(eig)))


def _describe(op) -> str:
    return (f"alpha = {math.degrees(op.alpha):.4g} deg, X = {op.X:.6f} m, pe = {op.Pe / 1e3:.3f} kPa, "
            f"pf = {op.Pf / 1e3:g} kPa, c = {op.params.c:.4g} N s/m, tau = {op.params.tau:g} s")


def _scaled_error(sys, ref, op) -> float:
    """max |difference| / max |reference| of [A B] in the units of mc.LINEARIZE_SCALE."""
    if sys.nstates != ref.nstates:  # a dead time's Pade states: the other linearization has no delay
        ref = mc.analytic_linearization(op.with_params(delay=0.0))
    sx = np.array([mc.LINEARIZE_SCALE[s] for s in ref.state_labels])
    su = np.array([mc.LINEARIZE_SCALE[s] for s in mc.INPUT_NAMES])
    def scaled(s):
        return np.hstack([s.A * sx[None, :] / sx[:, None], s.B * su[None, :] / sx[:, None]])
    return float(np.abs(scaled(sys) - scaled(ref)).max() / np.abs(scaled(ref)).max())


# --- subcommands ------------------------------------------------------------------------------------

def run_linearize(args) -> int:
    if args.mechanism is not None:
        return _mechanism_linearize(args)
    op = _setup(args, needs_damping=False)
    fmu = _fmu_path(args)
    p = op.params
    if fmu is not None and _air_on(p):
        print("note: the default FMUs do not carry the air (the native knee does when built with --air, "
              "docs/fmu.md); FMU part skipped")
        fmu = None
    lin = mc.analytic_linearization(op)
    a2, a1 = lin.A[1, 0] + 0.0, lin.A[1, 1] + 0.0  # + 0.0: print 0, not -0
    print(f"operating point (python-control find_operating_point): {_describe(op)}")
    print(f"Eq. 18: a2 = {a2:.6g} 1/s^2 (Eq. 20 {'holds' if a2 < 0 else 'fails'}), "
          f"a1 = {a1:.6g} 1/s (Eq. 19 {'holds' if a1 < 0 else 'fails'})")
    np.set_printoptions(precision=6, linewidth=120)
    print(f"states {lin.state_labels}, inputs {lin.input_labels}")
    print("A =\n" + str(lin.A) + "\nB =\n" + str(lin.B))
    poles = lin.poles()
    print(f"poles: {_fmt_poles(poles)}")
    cases = {f"c = {p.c:.4g} N s/m" + (f", tau = {p.tau:g} s" if p.tau else ""): poles}
    if a2 < 0:
        zeta = mc.damping_ratio(a1, a2) + 0.0
        print(f"natural frequency w_n = {math.sqrt(-a2):.5g} rad/s, damping ratio zeta = {zeta:.4g}")
        c_zeta = mc.damping_for_zeta(args.zeta, op)
        damped = mc.analytic_linearization(op.with_params(c=c_zeta)).poles()
        print(f"damping for zeta = {args.zeta:g}: c = {c_zeta:.6g} N s/m -> poles {_fmt_poles(damped)}")
        cases[f"c = {c_zeta:.4g} N s/m (zeta = {args.zeta:g})"] = damped
        if p.c != 0:
            undamped = mc.analytic_linearization(op.with_params(c=0.0)).poles()
            cases["c = 0 (model 2 alone)"] = undamped
    else:
        print("a2 >= 0: the posture is not held by a restoring force; no damping makes it stable")
    numerical = mc.numerical_linearization(op)
    print(f"python-control linearize vs analytic: relative error {_scaled_error(numerical, lin, op):.2g} "
          "(scaled [A B]" + ("; without the dead time's Pade states, which python-control's has not)"
                             if numerical.nstates != lin.nstates else ")"))
    if _air_on(p):
        print("note: with the air the regulators sit at u = 0, where the valve's slope jumps: "
              "the analytic linearization takes the filling side, python-control's forward step "
              "(+1 Pa) the exhausting one")
    if fmu is not None:
        fmu_lin = mc.fmu_linearization(op, fmu)
        print(f"FMU linearization (flow-map Jacobian, logm) vs analytic: relative error "
              f"{_scaled_error(fmu_lin, lin, op):.2g}; poles {_fmt_poles(fmu_lin.poles())}")
    path = mc.plot_poles(cases, f"Poles at alpha = {math.degrees(op.alpha):.4g} deg, pf = {op.Pf / 1e3:g} kPa",
                         args.out / "poles.png")
    print(f"wrote {path}")
    return 0


def run_rootlocus(args) -> int:
    if args.mechanism is not None:
        return _mechanism_rootlocus(args)
    if args.gain is not None and args.vary != "tau":
        raise UsageError(f"--gain applies only to --vary tau (with --vary {args.vary} "
                         + ("the gain itself is scanned)" if args.vary == "gain" else "there is no height loop)"))
    if args.ti is not None and not (math.isfinite(args.ti) and SHORTEST_TI <= args.ti <= LONGEST_TI):
        raise UsageError(f"--ti {args.ti:g}: the integral time must lie in [{SHORTEST_TI:g}, {LONGEST_TI:g}] s")
    op = _setup(args, needs_damping=True)
    print(f"operating point: {_describe(op)}")
    out = args.out
    if args.vary in air_poles.AIR_SWEEPS:
        path = _air_rootlocus(args, op)
    elif args.vary == "c":
        c_zeta1 = mc.damping_for_zeta(1.0, op)
        c_values = np.linspace(0.0, 1.5 * c_zeta1, 400)
        path = mc.plot_damping_locus(op, c_values, op.params.c, out / "rootlocus_c.png")
        print(f"c for zeta = {args.zeta:g}: {mc.damping_for_zeta(args.zeta, op):.6g} N s/m; critical damping "
              f"(zeta = 1): {c_zeta1:.6g} N s/m")
    elif args.vary == "tau":
        tau_ref = op.params.tau or control_defaults.DEFAULT_TAU
        gain = args.gain
        if gain is None:
            gain = mc.critical_gain(mc.height_loop(op.with_params(tau=tau_ref), args.ti))
        if gain == 0 and args.gain is None:
            raise UsageError(f"the height loop at tau = {tau_ref:g} s is unstable at every gain (c = "
                             f"{op.params.c:g} N s/m: no damping): give --c > 0 or --gain")
        if not (0 < gain <= LARGEST_GAIN):
            raise UsageError(f"--gain {gain:g}: the height gain must be a positive number of Pa/m, at most {LARGEST_GAIN:g}")
        taus = np.geomspace(1e-3, 1.0, 200)
        path = mc.plot_lag_sweep(op, taus, gain, args.ti, out / "rootlocus_tau.png")
        print(f"height gain K = {gain:.4g} Pa/m")
        for tau in (0.01, 0.03, 0.1, 0.3):
            loop = mc.height_loop(op.with_params(tau=tau), args.ti)
            print(f"  tau = {tau:g} s: closed-loop poles {_fmt_poles(mc.closed_loop_poles(loop, gain))}; "
                  f"critical gain {mc.critical_gain(loop):.4g} Pa/m")
    else:
        tau = op.params.tau or control_defaults.DEFAULT_TAU
        kc_lag = mc.critical_gain(mc.height_loop(op.with_params(tau=tau), args.ti))
        top = 3 * kc_lag if math.isfinite(kc_lag) and kc_lag > 0 else 1e8  # 0: unstable at every gain
        gains = np.concatenate([[0.0], np.geomspace(top * 1e-4, top, 800)])
        path, summary = mc.plot_gain_locus(op, gains, args.ti, tau, out / "rootlocus_gain.png")
        for label, kc in summary.items():
            text = f"{kc:.6g} Pa/m" if math.isfinite(kc) and kc > 0 else \
                "none (stable for every gain)" if not math.isfinite(kc) else "0 (unstable at every gain: no damping)"
            print(f"critical gain, {label}: {text}")
    print(f"wrote {path}")
    return 0


def _air_on(params) -> bool:
    from ..physics import actuator

    return actuator.air_is_on(params)


def _air_values(name):
    """The values ``--vary C_fill|V_dead|band`` sweeps: its range (from 0 and three decades below
    its upper bound where the range starts at 0)."""
    _, (low, high) = air_poles.AIR_SWEEPS[name]
    if low > 0:
        return np.geomspace(low, high, 240)
    return np.concatenate([[0.0], np.geomspace(high * 1e-3, high, 240)])


def _air_rootlocus(args, op):
    """``--vary C_fill|V_dead|band``: the knee's poles with the air's pressure states as one of
    its values sweeps the spec's range, the pressures-held and sealed limits marked (model-spec
    4d)."""
    sweep = air_poles.air_pole_sweep(op, args.vary, _air_values(args.vary))
    title = (f"Poles with the air against {args.vary}, alpha = {math.degrees(op.alpha):.4g} deg, "
             f"pf = {op.Pf / 1e3:g} kPa, c = {op.params.c:.4g} N s/m")
    return _print_air_sweep(sweep, op.params, title, args.out)


def _print_air_sweep(sweep, params, title, out):
    """Print an air pole sweep's limits and a few of its rows; draw it."""
    name, unit, values = sweep.name, sweep.unit, sweep.values
    air = params  # the air's values (at their typical values unless set; the sweep switches it on)
    print(f"the air on (model-spec 4d): C_fill = {air.C_fill:g} m^3/(s Pa), V_dead = "
          f"{air.V_dead:g} m^3, band = {air.band:g} Pa, P_supply = {air.P_supply:g} Pa, "
          f"k_poly = {air.k_poly:g}")
    print(f"pressures held (Eq. 18): a2 = {sweep.a2_held:.6g} 1/s^2, "
          f"poles {_fmt_poles(sweep.held)}")
    print(f"valves closed (sealed muscles, air springs): a2 = {sweep.a2_sealed:.6g} 1/s^2 "
          f"({sweep.a2_sealed / sweep.a2_held:.3g} times), poles {_fmt_poles(sweep.sealed)}")
    for i in np.unique(np.linspace(0, values.size - 1, 5).round().astype(int)):
        print(f"  {name} = {values[i]:.4g} {unit}: poles {_fmt_poles(sweep.poles[i])}")
    return air_poles.plot_air_poles(sweep, title, out / f"rootlocus_{name}.png")


def run_step(args) -> int:
    t_step = control_defaults.STEP_TIME
    if args.mechanism is not None:
        return _mechanism_step(args)
    if not (math.isfinite(args.duration) and t_step < args.duration <= LONGEST_RESPONSE):
        raise UsageError(f"--duration {args.duration:g}: the response must last longer than the step time "
                         f"{t_step:g} s and at most {LONGEST_RESPONSE:g} s")
    if not (math.isfinite(args.dt) and 0 < args.dt < args.duration - t_step):
        raise UsageError(f"--dt {args.dt:g}: the output interval must be positive and shorter than the response "
                         f"after the step ({args.duration - t_step:g} s)")
    for option, kpa in (("--small", args.small), ("--large", args.large)):
        if not (math.isfinite(kpa) and SMALLEST_STEP_KPA <= abs(kpa) <= LARGEST_KPA):
            raise UsageError(f"{option} {kpa:g}: the pressure step must be a non-zero number of kPa, at least "
                             f"{SMALLEST_STEP_KPA:g} and at most {LARGEST_KPA:g} either way")
    op = _setup(args, needs_damping=True)
    for option, kpa in (("--small", args.small), ("--large", args.large)):
        if op.Pe + kpa * 1e3 < 0:
            raise UsageError(f"{option} {kpa:g}: the step takes the extensor pressure from {op.Pe / 1e3:.4g} to "
                             f"{op.Pe / 1e3 + kpa:.4g} kPa, below 0 (gauge pressure: a muscle cannot push)")
    print(f"operating point: {_describe(op)}")
    fmu = _fmu_path(args)
    for label, kpa in (("small", args.small), ("large", args.large)):
        result = mc.step_responses(op, kpa * 1e3, duration=args.duration, t_step=t_step, dt=args.dt, fmu=fmu)
        print(f"{label} step of pe_cmd by {kpa:+g} kPa:")
        if result["end_stop"]:
            print(f"  note: the nonlinear response hit the {result['end_stop']}: from there on it shows the stop, "
                  "not the muscles, and the linear model does not apply")
        for name, info in result["info"].items():
            print(f"  {name:9s}: {mc.describe_response(info)}, final X - X_op = {1e3 * result[name][-1]:+.4g} mm")
        ref = np.abs(result["nonlinear"]).max()
        others = [n for n in ("linear", "fmu") if result[n] is not None]
        if ref > 0:
            print("  max difference from the nonlinear model, relative to its peak: " + ", ".join(
                f"{n} {np.abs(result[n] - result['nonlinear']).max() / ref:.3g}" for n in others))
        else:
            print("  the nonlinear model does not move: no relative difference to show")
        path = mc.plot_step(result, op, args.out / f"step_{label}.png")
        print(f"  wrote {path}")
    return 0


# --- any mechanism (--mechanism) ------------------------------------------------------------------------

def _mechanism_setup(args, needs_damping: bool):
    """The mechanism's operating point with c and tau applied, from the common options (checked first)."""
    from ..analysis import mechanism_control as mm
    from ..analysis.mechanism_files import mechanism
    from .options import split_items

    output_folder(args.out, "--out")
    knee_only = [name for name, given in (("--alpha", args.alpha is not None), ("--X", args.X is not None),
                                          ("--pf", args.pf != DEFAULT_PF / 1e3),
                                          ("--fmu", getattr(args, "fmu", None) is not None)) if given]
    if knee_only:
        raise UsageError(f"{knee_only[0]} belongs to the knee; with --mechanism give each muscle's --pressure")
    if not (math.isfinite(args.zeta) and 0 <= args.zeta <= LARGEST_ZETA):
        raise UsageError(f"--zeta {args.zeta:g}: the damping ratio must lie in [0, {LARGEST_ZETA:g}]")
    mech = mechanism(args.mechanism)
    own, muscle_items = {}, []
    for item in args.set:
        name, _, text = item.partition("=")
        if name.strip() in mech.parameter_names:
            try:
                own[name.strip()] = float(text)
            except ValueError:
                raise UsageError(f"--set {name.strip()}: {text.strip()!r} is not a number") from None
        else:
            muscle_items.append(item)
    overrides = parse_assignments(muscle_items)
    params = base_params(args).replace(**{k: v for k, v in overrides.items() if k not in ("c", "tau")})
    texts = split_items(args.pressure) or [str(MECHANISM_PRESSURE_KPA)] * len(mech.muscles)
    pressures = []
    for text in texts:
        try:
            kpa = float(text)
        except ValueError:
            raise UsageError(f"--pressure {text}: not a number of kPa") from None
        if not (math.isfinite(kpa) and 0 <= kpa <= LARGEST_KPA):
            raise UsageError(f"--pressure {text}: outside [0, {LARGEST_KPA:g}] kPa (a gauge pressure)")
        pressures.append(kpa * 1e3)
    if len(pressures) != len(mech.muscles):
        raise UsageError(f"--pressure: {mech.name} has {len(mech.muscles)} muscle(s) ({', '.join(mech.muscles)}); "
                         f"got {len(pressures)} pressure(s)")
    op = mm.operating_point(mech, pressures, mech.bind(params, **own))
    tau = args.tau if args.tau is not None else overrides.get("tau", 0.0)
    op = op.with_params(c=0.0, tau=tau)
    c = args.c if args.c is not None else overrides.get("c")
    if c is None:
        c = mm.damping_for_zeta(args.zeta, op) if needs_damping else 0.0
    return op.with_params(c=c)


def _mechanism_linearize(args) -> int:
    from ..analysis import mechanism_control as mm

    op = _mechanism_setup(args, needs_damping=False)
    unit, factor = mm.display_unit(op.mechanism)
    rest = op.stability()
    a1, a2 = rest.a1 + 0.0, rest.a2 + 0.0
    print(f"operating point: {op.describe()}")
    print(f"Eq. 18: a2 = {a2:.6g} 1/s^2 (Eq. 20 {'holds' if a2 < 0 else 'fails'}), "
          f"a1 = {a1:.6g} 1/s (Eq. 19 {'holds' if a1 < 0 else 'fails'}): {rest.verdict}")
    system = op.linear_system()
    np.set_printoptions(precision=6, linewidth=120)
    print(f"states {system.state_labels}, inputs {system.input_labels} (python-control state space)")
    print("A =\n" + str(system.A) + "\nB =\n" + str(system.B))
    poles = system.poles()
    print(f"poles: {_fmt_poles(poles)}")
    muscle_c = op.params.c
    cases = {f"c = {muscle_c:.4g} N s/m" + (f", tau = {op.params.tau:g} s" if op.params.tau else ""): poles}
    if a2 < 0:
        zeta = mc.damping_ratio(a1, a2) + 0.0
        print(f"natural frequency w_n = {math.sqrt(-a2):.5g} rad/s, damping ratio zeta = {zeta:.4g}")
        c_zeta = mm.damping_for_zeta(args.zeta, op)
        damped = op.with_params(c=c_zeta).linear_system().poles()
        print(f"damping for zeta = {args.zeta:g}: c = {c_zeta:.6g} N s/m -> poles {_fmt_poles(damped)}")
        cases[f"c = {c_zeta:.4g} N s/m (zeta = {args.zeta:g})"] = damped
        if muscle_c != 0:
            cases["c = 0"] = op.with_params(c=0.0).linear_system().poles()
    else:
        print("a2 >= 0: the rest is not held by a restoring force; no damping makes it stable")
    print(f"static gain: {factor * 1e3 * float(np.real(_dcgain(system)[0, 0])):.6g} {unit} per kPa of "
          f"{op.mechanism.muscles[0]}")
    path = mc.plot_poles(cases, f"{op.mechanism.name}: poles at {op.mechanism.coordinate} = "
                                f"{mm.shown(op.q * factor, 4)} {unit}", args.out / "poles.png")
    print(f"wrote {path}")
    return 0


def _dcgain(system):
    import control

    return np.atleast_2d(control.dcgain(system))


def _mechanism_rootlocus(args) -> int:
    from ..analysis import mechanism_control as mm

    if args.ti is not None or args.gain is not None:
        raise UsageError("--ti and --gain belong to the knee's height loop; with --mechanism --vary gain scans the "
                         "gain of u1 = K (q_ref - q) itself")
    op = _mechanism_setup(args, needs_damping=True)
    unit, factor = mm.display_unit(op.mechanism)
    print(f"operating point: {op.describe()}")
    if args.vary in air_poles.AIR_SWEEPS:
        sweep = mm.air_pole_sweep(op, args.vary, _air_values(args.vary))
        path = _print_air_sweep(sweep, op.params, f"Poles with the air against {args.vary}: "
                                f"{op.describe()}", args.out)
    elif args.vary == "c":
        c_one = mm.damping_for_zeta(1.0, op)
        values = np.linspace(0.0, 1.5 * max(c_one, 1e-9), 300)
        path = mm.plot_locus(op, values, mm.locus(op, "c", values), "c", "N s/m", args.out / "rootlocus_c.png",
                             marked=op.params.c)
        print(f"c for zeta = {args.zeta:g}: {mm.damping_for_zeta(args.zeta, op):.6g} N s/m; critical damping "
              f"(zeta = 1): {c_one:.6g} N s/m")
    elif args.vary == "tau":
        values = np.geomspace(1e-3, 1.0, 200)
        path = mm.plot_locus(op, values, mm.locus(op, "tau", values), "tau", "s", args.out / "rootlocus_tau.png")
        for tau in (0.01, 0.03, 0.1, 0.3):
            print(f"  tau = {tau:g} s: poles {_fmt_poles(op.with_params(tau=tau).linear_system().poles())}")
    else:
        # as the knee's: the loop with the record's lag, or with the default lag where it has none
        lagged = op if op.params.tau > 0 else op.with_params(tau=control_defaults.DEFAULT_TAU)
        kc = mm.critical_gain(lagged)
        top = 3 * kc if math.isfinite(kc) and kc > 0 else 1e8
        gains = np.concatenate([[0.0], np.geomspace(top * 1e-4, top, 400)])
        per = "Pa/m" if op.mechanism.unit == "m" else "Pa/rad"
        path = mm.plot_locus(lagged, gains, mm.gain_locus(lagged, gains), "K", per,
                             args.out / "rootlocus_gain.png")
        coordinate = op.mechanism.coordinate
        for label, case in (("without lag", op.with_params(tau=0.0)), (f"tau = {lagged.params.tau:g} s", lagged)):
            k = mm.critical_gain(case)
            text = (f"{k:.6g} {per}" if math.isfinite(k) and k > 0 else "none (stable for every gain)"
                    if not math.isfinite(k) else "0 (unstable at every gain: no damping)")
            print(f"critical gain of u1 = K ({coordinate}_ref - {coordinate}), {label}: {text}")
    print(f"wrote {path}")
    return 0


def _mechanism_step(args) -> int:
    from ..analysis import mechanism_control as mm

    t_step = control_defaults.STEP_TIME
    if not (math.isfinite(args.duration) and t_step < args.duration <= LONGEST_RESPONSE):
        raise UsageError(f"--duration {args.duration:g}: the response must last longer than the step time "
                         f"{t_step:g} s and at most {LONGEST_RESPONSE:g} s")
    if not (math.isfinite(args.dt) and 0 < args.dt < args.duration - t_step):
        raise UsageError(f"--dt {args.dt:g}: the output interval must be positive and shorter than the response "
                         f"after the step ({args.duration - t_step:g} s)")
    op = _mechanism_setup(args, needs_damping=True)
    unit, factor = mm.display_unit(op.mechanism)
    print(f"operating point: {op.describe()}")
    for label, kpa in (("small", args.small), ("large", args.large)):
        if not (math.isfinite(kpa) and SMALLEST_STEP_KPA <= abs(kpa) <= LARGEST_KPA):
            raise UsageError(f"--{label} {kpa:g}: the pressure step must be a non-zero number of kPa, at least "
                             f"{SMALLEST_STEP_KPA:g} and at most {LARGEST_KPA:g} either way")
        result = mm.step_responses(op, kpa * 1e3, duration=args.duration, t_step=t_step, dt=args.dt)
        print(f"{label} step of {op.mechanism.muscles[0]}'s command by {kpa:+g} kPa:")
        if result.end_stop:
            print(f"  note: the nonlinear response hit {result.end_stop}: the linear model does not apply there")
        for name in ("nonlinear", "linear"):
            print(f"  {name:9s}: {mc.describe_response(result.info[name])}, final "
                  f"{op.mechanism.coordinate} - op = {factor * result[name][-1]:+.4g} {unit}")
        peak = np.abs(result.nonlinear).max()
        if peak > 0:
            print(f"  max difference linear vs nonlinear, relative to its peak: "
                  f"{np.abs(result.linear - result.nonlinear).max() / peak:.3g}")
        path = mm.plot_step(result, op, args.out / f"step_{label}.png")
        print(f"  wrote {path}")
    return 0
