"""The cases the diagnosis was tried on, and its score on each: regenerates the table in docs/diagnosis.md.

Each case makes a record with the virtual test bench (:func:`mkctl.analysis.synth.synthesize`: hidden effects,
command shape, output and input noise, coloured noise, offsets, angle output, an encoder's counts, measured
pressures), reads it back as a user's file and diagnoses it. Scores:

- ``right``: the verdict is "diagnosed" (or "nothing missing") with exactly the hidden effects, every value
  within 4 of its reported standard errors of the truth (plus the file's rounding);
- ``right, values off``: the right effects, a value outside that band;
- ``honest``: "undecided", "incomplete" or "not diagnosed" where the record cannot be diagnosed right
  (or is a unit/zero mistake that must not be diagnosed): never confidently wrong;
- ``wrong``: a confident verdict with the wrong effects.

A record with an effect no candidate has (out of the library: a quadratic drag) is ``right`` when the verdict is
"incomplete" (the model still leaves more than the noise: the discovery's turn), ``honest`` when "undecided" or
"not diagnosed", ``wrong`` when it is called "diagnosed" or "nothing missing".

The last cases are issue 32's classes (an effect behind its prerequisite, a tie reported as whole models, input
noise on a quasi-static record), on the seed that showed each (option ``seed``; 1 otherwise). A tie's values are
each alternative's.

Cases marked ``rig`` are made by the independent simulator of the tests (``tests/independent_rig.py``: its own
right-hand side through solve_ivp, coloured output noise of 10 ms, the valves seeing every command 0.1 ms late),
not by mkctl's synth.

Run on demand (several minutes on 2 cores; the cases run in parallel with Dask)::

    PYTHONPATH=. python bench/bench_diagnosis_cases.py            # print the table
    PYTHONPATH=. python bench/bench_diagnosis_cases.py --write    # and write it into docs/diagnosis.md
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

KNEE = {"samples": 1500, "rate": 500.0}
DAMPED = {**KNEE, "known": {"c": 45.0}}  #: a leg with a known damper: it settles between the command steps
RIG = {**KNEE, "rig": True, "known": {"c": 45.0}}  #: the independent rig's knee, damper known (and in the rig)

#: (name, experiment, hidden, options, what a right answer is: "effects" or "not diagnosed")
CASES = [
    ("isotonic, nothing hidden", "isotonic", {}, {}),
    ("isotonic, nothing hidden, 1 kPa pressure noise", "isotonic", {}, {"input_noise": 1.0}),
    ("isotonic, nothing hidden, coloured noise (0.2 s), pressure steps", "isotonic", {},
     {"noise_tau": 0.2, "shape": "steps"}),
    ("isotonic, friction Fc = 1.5 N", "isotonic", {"Fc": 1.5}, {}),
    ("isotonic, friction, 1 kPa pressure noise", "isotonic", {"Fc": 1.5}, {"input_noise": 1.0}),
    ("isotonic, damping c = 200 N s/m", "isotonic", {"c": 200.0}, {}),
    ("isotonic, elasticity (model 1 baseline)", "isotonic", ["elasticity"], {"baseline": "model1"}),
    ("isotonic, elasticity + friction (model 1)", "isotonic", ["elasticity", "coulomb_friction"],
     {"baseline": "model1"}),
    ("knee, nothing hidden", "knee", {}, KNEE),
    ("knee, damping c = 30", "knee", {"c": 30.0}, KNEE),
    ("knee, lag tau = 0.04 s", "knee", {"tau": 0.04}, KNEE),
    ("knee, damping + lag, steps", "knee", {"c": 45.0, "tau": 0.03}, KNEE),
    ("knee, damping + lag, ramps", "knee", {"c": 45.0, "tau": 0.03}, {**KNEE, "shape": "ramps"}),
    ("knee, friction Fc = 2 N (damping known)", "knee", {"Fc": 2.0}, {**KNEE, "known": {"c": 45.0}}),
    ("knee, damping, chirp (commands change every sample)", "knee", {"c": 30.0},
     {"samples": 3000, "rate": 1000.0, "shape": "chirp"}),
    ("knee, damping, angle output beta_deg", "knee", {"c": 30.0}, {**KNEE, "output": "beta_deg"}),
    ("knee, damping + friction, 12-bit joint encoder (beta_deg)", "knee", {"c": 30.0, "Fc": 2.0},
     {**KNEE, "output": "beta_deg", "noise": 0.0005, "resolution": 360 / 2 ** 12}),
    ("knee, damping + lag, measured pressures (0.5 kPa noise)", "knee", {"c": 30.0, "tau": 0.04},
     {**KNEE, "pressures": True, "input_noise": 0.5}),
    ("knee, damping, coloured noise (20 ms)", "knee", {"c": 30.0}, {**KNEE, "noise_tau": 0.02}),
    ("knee, damping, sensor offset 5 mm, --fit-offset", "knee", {"c": 30.0},
     {**KNEE, "offset": 5.0, "fit_offset": True}),
    ("knee, output zeroed at rest", "knee", {"c": 30.0}, {**KNEE, "offset": "zero", "expect": "not diagnosed"}),
    ("knee, output in metres under x_mm", "knee", {"c": 30.0}, {**KNEE, "offset": "metres",
                                                                 "expect": "not diagnosed"}),
    # model-spec section 4b: the effects a real rig has, their neighbours, and one no candidate has
    ("knee, dead time 30 ms (damping known)", "knee", {"delay": 0.03}, DAMPED),
    ("knee, lag tau = 0.08 s, not a dead time nor asymmetric (damping known)", "knee", {"tau": 0.08}, DAMPED),
    ("knee, asymmetric lag 0.08 s filling, 0.13 s exhausting (damping known)", "knee",
     {"tau": 0.08, "tau_exhaust": 0.13}, DAMPED),
    # (no synth knee record with a threshold: synth holds alpha = 60 deg with the baseline's pressure, which a
    # threshold of 50-100 kPa no longer holds: the leg falls onto its end stop; the rig's case below holds it)
    ("knee, pressure friction Fc_p = 5e-6 N/Pa (damping known)", "knee", {"Fc_p": 5e-6}, DAMPED),
    ("isotonic, threshold pressure P0 = 100 kPa", "isotonic", {"P0": 1e5}, {}),
    ("isotonic, pressure friction Fc_p = 5e-6 N/Pa", "isotonic", {"Fc_p": 5e-6}, {}),
    ("isotonic, constant friction, not pressure friction", "isotonic", {"Fc": 2.0}, {}),
    ("knee, dead time, measured pressures (0.5 kPa noise)", "knee", {"delay": 0.03},
     {**DAMPED, "pressures": True, "input_noise": 0.5}),
    ("rig: knee, nothing hidden", "knee", {}, RIG),
    ("rig: knee, dead time 30 ms", "knee", {"delay": 0.03}, RIG),
    ("rig: knee, dead time 30 ms, 1 mm output noise", "knee", {"delay": 0.03}, {**RIG, "noise": 1.0}),
    ("rig: knee, lag tau = 0.08 s", "knee", {"tau": 0.08}, RIG),
    ("rig: knee, asymmetric lag 0.08 s / 0.13 s", "knee", {"tau": 0.08, "tau_exhaust": 0.13}, RIG),
    ("rig: knee, threshold pressure P0 = 100 kPa", "knee", {"P0": 1e5}, RIG),
    ("rig: knee, pressure friction Fc_p = 5e-6 N/Pa", "knee", {"Fc_p": 5e-6}, RIG),
    ("rig: knee, constant friction Fc = 2 N", "knee", {"Fc": 2.0}, RIG),
    ("rig: knee, quadratic drag cq = 2000 N s^2/m^2 (no candidate has it)", "knee", {"cq": 2000.0},
     {**RIG, "expect": "out of library"}),
    # issue 32: an effect behind its prerequisite, a tie reported as whole models, input noise on a
    # quasi-static record
    ("knee, asymmetric lag 0.05 s / 0.15 s + damping 40 (the lag alone takes the damping's share)", "knee",
     {"tau": 0.05, "tau_exhaust": 0.15, "c": 40.0}, {"samples": 3000, "rate": 1000.0, "noise": 0.05, "seed": 0}),
    ("knee, asymmetric lag 0.03 s / 0.08 s, ramps at 200 Hz, 0.3 mm (the lag ties a dead time; damping known)",
     "knee", {"tau": 0.03, "tau_exhaust": 0.08},
     {"samples": 2000, "rate": 200.0, "shape": "ramps", "noise": 0.3, "known": {"c": 40.0}, "seed": 0}),
    ("knee, lag 60 ms + damping 45, ramps at 200 Hz, 0.1 mm (the lag ties a dead time)", "knee",
     {"tau": 0.06, "c": 45.0}, {"samples": 2400, "rate": 200.0, "shape": "ramps", "noise": 0.1, "seed": 0}),
    ("isotonic, nothing hidden, 16 mm muscle, 16 kPa pressure noise, 0.1 mm AR(1) noise (0.5 s)", "isotonic", {},
     {"known": {"D0": 0.016}, "input_noise": 16.0, "noise": 0.1, "noise_tau": 0.5, "seed": 3}),
]


def rig_record(hidden: dict, known: dict, samples: int, rate: float, noise: float = 0.01):
    """A knee record of the independent rig (tests/independent_rig.py) and its truth: (measurement, Params of the
    truth, the hidden effects mkctl knows). The rig's 0.1 ms mismatch is a dead time too: the truth's delay holds
    it when a dead time is hidden."""
    sys.path.insert(0, str(ROOT / "tests"))
    import independent_rig as rig
    from mkctl.physics import effects
    from mkctl.physics.params import Params

    measurement = rig.knee_record({**known, **hidden}, params=Params(**known), samples=samples, rate=rate,
                                  noise=noise * 1e-3)
    known_names = set(Params().as_dict())
    truth_values = {k: v for k, v in hidden.items() if k in known_names}
    if "delay" in truth_values:
        truth_values["delay"] += 1e-4
    truth = Params(**known, **truth_values)
    base = set(Params(**known).effects)
    return measurement, truth, sorted(e for e in truth.effects if e not in base and effects.get(e).fitted)


def run_case(case) -> dict:
    """Synthesize, write, read and diagnose one case; returns its row of the table."""
    import numpy as np

    from mkctl.analysis.diagnose import CANDIDATES, diagnose
    from mkctl.analysis.synth import synthesize, write_synthetic
    from mkctl.io.measurements import read_measurement, write_measurement

    name, experiment, hidden, options = case
    options = dict(options)
    expect = options.pop("expect", "effects")
    fit_offset = options.pop("fit_offset", False)
    known = options.pop("known", None)
    baseline = options.pop("baseline", "model2")
    special = options.pop("offset", 0.0)
    if isinstance(special, float):
        options["offset"] = special
    noise = options.pop("noise", 0.01)
    seed = options.pop("seed", 1)
    if options.pop("rig", False):
        measurement, true_params, truth = rig_record(hidden, known or {}, options["samples"], options["rate"], noise)
        start = time.perf_counter()
        result = diagnose(measurement, fit_offset=fit_offset)
        seconds = time.perf_counter() - start
    else:
        record = synthesize(experiment, hidden, known, baseline, noise, seed, **options)
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "case.csv"
            if isinstance(special, str):  # a user's mistake in the file
                output = record.output - record.output[0] if special == "zero" else record.output * 1e-3
                write_measurement(path, experiment, record.time, record.inputs, output, metadata=record.known,
                                  baseline=baseline)
            else:
                write_synthetic(path, record)
            measurement = read_measurement(path)
            start = time.perf_counter()
            result = diagnose(measurement, fit_offset=fit_offset)
            seconds = time.perf_counter() - start
        true_params, truth = record.truth, sorted(record.hidden_effects)
    if expect == "not diagnosed":
        score = "honest" if result.verdict == "not diagnosed" else "wrong"
    elif expect == "out of library":
        score = ("right" if result.verdict == "incomplete" else
                 "honest" if result.verdict in ("undecided", "not diagnosed") else "wrong")
        truth = ["(quadratic drag: no candidate)"]
    elif result.verdict in ("undecided", "incomplete", "not diagnosed"):
        score = "honest"
    elif sorted(result.missing) != truth:
        score = "wrong"
    else:
        score = "right"
        for effect in truth:
            parameter = CANDIDATES[effect].parameter
            true = getattr(true_params, parameter)
            se = result.uncertainty.get(parameter, np.inf)
            if not abs(result.params[parameter] - true) <= 4 * se + 1e-6 * abs(true):
                score = "right, values off"
    values = ", ".join(f"{k} = {v:.4g} +- {result.uncertainty.get(k, float('nan')):.2g}"
                       for k, v in result.params.items())
    if result.alternatives:  # a tie: each explanation as a whole model (issue 32)
        values = "; ".join(
            f"with {' & '.join(a['with'])}: "
            + ", ".join(f"{k} = {v:.4g} +- {a['uncertainty'].get(k, float('nan')):.2g}"
                        for k, v in a["params"].items()) for a in result.alternatives)
    return {"case": name, "hidden": ", ".join(truth) or "none", "verdict": result.verdict,
            "found": ", ".join(result.missing) or "-", "values": values or "-", "score": score,
            "rmse": f"{result.rmse_before:.3g} -> {result.rmse_after:.3g} {result.output_unit}",
            "seconds": seconds}


def table(rows) -> str:
    lines = ["| case | hidden | verdict | found | values (SI, +- standard error) | RMSE before -> after | "
             "score | time [s] |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['hidden']} | {r['verdict']} | {r['found']} | {r['values']} | {r['rmse']} "
                     f"| {r['score']} | {r['seconds']:.0f} |")
    counts = {s: sum(r["score"] == s for r in rows) for s in ("right", "right, values off", "honest", "wrong")}
    lines.append("")
    lines.append("Score: " + ", ".join(f"{v} {k}" for k, v in counts.items()) + f" of {len(rows)} cases.")
    return "\n".join(lines)


BEGIN, END = "<!-- cases table: bench/bench_diagnosis_cases.py -->", "<!-- end of cases table -->"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write the table into docs/diagnosis.md")
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("-k", default="", help="only cases whose name contains this")
    args = parser.parse_args(argv)
    import dask
    from tqdm import tqdm

    cases = [c for c in CASES if args.k in c[0]]
    tasks = [dask.delayed(run_case)(case) for case in cases]
    with tqdm(total=len(tasks), desc="cases", file=sys.stderr) as bar:
        rows = []
        for chunk in range(0, len(tasks), args.workers):
            rows += dask.compute(*tasks[chunk:chunk + args.workers], scheduler="processes",
                                 num_workers=args.workers)
            bar.update(len(tasks[chunk:chunk + args.workers]))
    text = table(rows)
    print(text)
    if args.write:
        doc = ROOT / "docs" / "diagnosis.md"
        content = doc.read_text(encoding="utf-8")
        if BEGIN not in content or END not in content:
            print(f"{doc}: no {BEGIN} ... {END} markers", file=sys.stderr)
            return 2
        head, rest = content.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        doc.write_text(head + BEGIN + "\n" + text + "\n" + END + tail, encoding="utf-8")
        print(f"wrote the table into {doc}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
