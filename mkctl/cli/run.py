"""``mkctl run``: the whole job in one command, into one folder with an index page.

Steps, each reusing a subcommand or a scenario as a user would run it, from the installed package (no file of
a checkout is needed), in this process except the FMU build:

1. build and check the FMUs (``python -m mkctl.fmu.build``, what ``build_fmu.py`` runs, in a fresh Python) into
   ``OUT/fmu``;
2. drive the knee FMU through fmpy: a pressure step from equilibrium (:mod:`mkctl.scenarios.pressure_step`);
3. reproduce the paper's figures and claims (``mkctl paper``);
4. the linear view: linearization, root loci against c, tau and the height gain, step responses
   (``mkctl linearize``, ``mkctl rootlocus``, ``mkctl step``);
5. make a knee measurement with a hidden effect (``mkctl synth``), compare the baseline with it and
   diagnose it (``mkctl compare``, ``mkctl diagnose``);
6. write ``OUT/index.md`` and ``OUT/index.html``, every figure with a sentence on what it shows.

Each step's printed summary is kept in ``OUT/<step>/summary.txt`` and shown on the index page.
"""
from __future__ import annotations

import contextlib
import io
import json
import sys
import time
from pathlib import Path

from ..errors import MkctlError
from ..io.report import Section, write_index
from .options import output_folder

#: What the synthetic measurement hides: viscous damping [N s/m], which the baseline (model 2) lacks.
HIDDEN_DAMPING = 45.0


class RunError(MkctlError):
    """A step of the main job failed; the message names the step and what it printed."""


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "run": "the whole job: FMUs, a scenario, the paper, control analysis, a diagnosis; one index page",
}


def register(subparsers) -> None:
    """Add ``run`` to the ``mkctl`` parser."""
    p = subparsers.add_parser(
        "run", help=COMMANDS["run"],
        description="Build and check the FMUs, drive the knee FMU through fmpy, reproduce the paper's figures "
                    "and claims, run the control analysis, make a measurement with a hidden effect and "
                    "diagnose it, and write everything into one folder with an index page (index.md, "
                    "index.html).")
    p.add_argument("--out", type=Path, default=Path("out"), metavar="DIR",
                   help="output folder (default: out)")
    p.add_argument("--quick", action="store_true",
                   help="shorter records and runs: a smoke test, not results to read")
    p.set_defaults(func=run_all)


class _Job:
    """Runs the steps in order, printing progress, and collects the index sections."""

    def __init__(self, out: Path, steps: int):
        self.out, self.steps, self.done = out, steps, 0
        self.sections: list[Section] = []
        self.started = time.perf_counter()

    def step(self, title: str, on_index: bool = True) -> Section:
        self.done += 1
        elapsed = time.perf_counter() - self.started
        print(f"[{self.done}/{self.steps}] {title} (at {elapsed:.0f} s)", file=sys.stderr, flush=True)
        section = Section(title)
        if on_index:
            self.sections.append(section)
        return section

    def command(self, section: Section, folder: Path, argv: list[str]) -> str:
        """Run an ``mkctl`` subcommand in this process, keep what it printed, fail loudly if it fails."""
        from . import main  # the package's entry point; imported here to avoid a cycle at import time

        buffer = io.StringIO()
        with contextlib.redirect_stdout(buffer):
            status = main(argv)
        text = buffer.getvalue()
        self._keep(section, folder, f"$ mkctl {' '.join(argv)}\n{text}")
        if status != 0:
            raise RunError(f"step '{section.title}': mkctl {argv[0]} exited with status {status}")
        return text

    def function(self, section: Section, folder: Path, label: str, call) -> str:
        """Run ``call()`` (a scenario's ``main`` or the FMU build) in this process, keep what it printed (and the
        one-line error it wrote to stderr, if any), fail loudly if it fails."""
        out, err = io.StringIO(), io.StringIO()
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                status = call()
        except SystemExit as stop:  # argparse in a scenario: a usage error is a bug here, say so
            status = stop.code
        status = 0 if status is None else status
        self._keep(section, folder, f"$ {label}\n{out.getvalue()}")
        if status != 0:
            last = (err.getvalue().strip().splitlines() or ["(no message)"])[-1]
            raise RunError(f"step '{section.title}': {label} failed: {last}")
        return out.getvalue()

    def _keep(self, section: Section, folder: Path, text: str) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        summary = folder / "summary.txt"
        with summary.open("a", encoding="utf-8") as handle:
            handle.write(text + "\n")
        section.summary = (section.summary + "\n" + text).strip()


#: What the index page says under each file it shows: {file, relative to the output folder: (title, caption)}.
CAPTIONS = {
    "fmu/McKibbenKnee.fmu": ("McKibbenKnee.fmu", "The knee as an FMI 2.0 co-simulation FMU (spec section 7), validated "
                             "with fmpy; load it in any FMI host."),
    "fmu/McKibbenActuator.fmu": ("McKibbenActuator.fmu", "One muscle as an FMU (inputs p_cmd, L, Ldot; outputs f, P), "
                                 "for composing robots in other tools."),
    "native/McKibbenKnee.fmu": ("native/McKibbenKnee.fmu", "The same knee compiled from the generated C (spec "
                                "section 7b): no Python needed in the host; per 1 ms step 8 times faster through "
                                "fmpy's simulate_fmu (fmpy's own cost is then the floor) and 27 times in a lean host "
                                "loop (docs/fmu.md); use it unless you need to edit the model in Python."),
    "native/McKibbenActuator.fmu": ("native/McKibbenActuator.fmu", "The same muscle compiled from the generated C "
                                    "(spec section 7b): no Python needed in the host, the same inputs and outputs as "
                                    "McKibbenActuator.fmu."),
    "scenario/pressure_step.png": ("Pressure step through the FMU", "Hip height and knee angle after a 5 % step of the "
                                   "extensor command, simulated by the knee FMU under fmpy: a damped oscillation about "
                                   "the new equilibrium."),
    "scenario/pressure_step.csv": ("pressure_step.csv", "The FMU's outputs of that run, as CSV."),
    "paper/fig5_contraction.png": ("Fig. 5: contraction against pressure", "Model 1 (pressure only, dashed) against "
                                   "model 2 (with rubber elasticity, solid) under constant loads: the rubber makes the "
                                   "muscle stiffer and lets it push below its rest length."),
    "paper/fig7_surfaces.png": ("Fig. 7: the h = 0 sheet and the equilibrium set", "Over (Pe', Pf', alpha): equilibria "
                                "above the orange h = 0 sheet are stable (blue), those below it unstable (red); the "
                                "black curve is where stability is lost."),
    "paper/fig7_sections.png": ("Fig. 7 in sections", "The extensor pressure that holds the leg and the one on h = 0, "
                                "against alpha, for several flexor pressures: where the first has its minimum, "
                                "stability is lost."),
    "paper/claims.md": ("claims.md", "Each claim of the paper's Section VI with the number from the model that "
                        "supports or refutes it."),
    "control/poles.png": ("Poles at alpha = 60 deg", "Model 2 alone leaves the poles on the imaginary axis (a1 = 0, "
                          "Eq. 19 fails); the damping from the closed form moves them into the left half plane."),
    "control/rootlocus_c.png": ("Root locus against the damping c", "The exact root locus of the velocity-feedback "
                                "loop that viscous damping is: the poles leave the imaginary axis as c grows, meet "
                                "on the real axis at critical damping."),
    "control/rootlocus_tau.png": ("Eigenvalues against the pressure lag tau", "In open loop the lag only adds a pole at "
                                  "-1/tau; closed around a height controller it costs gain, most (the critical gain is "
                                  "least) when 1/tau is near the knee's natural frequency, tau ~ 0.1 s."),
    "control/rootlocus_gain.png": ("Root locus against the height-control gain", "Hip-height feedback through the "
                                   "extensor pressure, with and without the lag: without it every gain is stable; "
                                   "with it the gain is limited, the cost of the lag."),
    "control/step_small.png": ("Small pressure step: linear, nonlinear, FMU", "For a small step the linear model, the "
                               "nonlinear model and the FMU agree."),
    "control/step_large.png": ("Large pressure step: linear, nonlinear, FMU", "For a large step the nonlinear model "
                               "and the FMU (which agree) part from the linear model."),
    "diagnosis/knee_hidden_damping.csv": ("knee_hidden_damping.csv", "A synthetic knee record (spec section 5) with "
                                          "viscous damping hidden in it; the true value is in the .truth.json beside "
                                          "it, not in the file."),
    "diagnosis/diagnosis.json": ("diagnosis.json", "The diagnosis report (spec section 6): effects found, fitted "
                                 "parameters with their uncertainty, the candidates' scores and residual signatures."),
}


def _show(section: Section, out: Path, relative: str, path: Path | None = None, title: str | None = None) -> None:
    """Put a file on the index with its title and caption from :data:`CAPTIONS`."""
    default_title, caption = CAPTIONS[relative]
    section.add(path if path is not None else out / relative, title or default_title, caption)


def run_all(args) -> int:
    """``mkctl run``: the six steps in order, each into its own folder, then the index page."""
    out: Path = output_folder(args.out, "--out").resolve()
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("*/summary.txt"):
        stale.unlink()
    job = _Job(out, steps=6)
    knee_fmu = _build_fmus(job, out)
    _scenario(job, out, args.quick)
    _paper(job, out)
    _control(job, out, knee_fmu, args.quick)
    _diagnosis(job, out, args.quick)
    job.step("Write the index page", on_index=False)
    md, html = write_index(out, "mkctl: the whole job",
                           "Everything one `mkctl run` made: the FMUs, a co-simulation through fmpy, the paper's "
                           "figures and claims, the control analysis and a diagnosis of a measurement with a "
                           "hidden effect. Each section shows what its step printed.", job.sections)
    print(f"index: {md.resolve()}")
    print(f"       {html.resolve()} (figures inline, for a browser)")
    return 0


def _build_fmus(job: _Job, out: Path) -> Path:
    """Step 1: build and check the FMUs (pythonfmu and native); returns the knee FMU."""
    from ..scenarios.common import build_fmus

    fmu_dir = out / "fmu"
    s = job.step("Build and check the FMUs")
    built = {}

    def build():
        paths, printed = build_fmus(fmu_dir, run=True, native=True)
        built.update(paths)
        print(printed, end="")

    job.function(s, fmu_dir, f"build the FMUs into {fmu_dir} (mkctl.fmu.build)", build)
    _show(s, out, "fmu/McKibbenKnee.fmu", built["knee"])
    _show(s, out, "fmu/McKibbenActuator.fmu", built["actuator"])
    for which in ("native_knee", "native_actuator"):
        if which in built:
            _show(s, out, f"native/{built[which].name}", built[which])
    return built["knee"]


def _scenario(job: _Job, out: Path, quick: bool) -> None:
    """Step 2: a pressure step driven through the knee FMU with fmpy."""
    from ..scenarios import pressure_step

    scenario_dir = out / "scenario"
    s = job.step("Drive the knee FMU with fmpy: a pressure step from equilibrium")
    argv = ["--out", str(scenario_dir), "--fmu-dir", str(out / "fmu")] + (["--duration", "1.5"] if quick else [])
    job.function(s, scenario_dir, f"python -m mkctl.scenarios.pressure_step {' '.join(argv)}",
                 lambda: pressure_step.main(argv))
    for name in ("scenario/pressure_step.png", "scenario/pressure_step.csv"):
        _show(s, out, name)


def _paper(job: _Job, out: Path) -> None:
    """Step 3: the paper's figures and claims."""
    paper_dir = out / "paper"
    s = job.step("Reproduce the paper's figures and claims")
    job.command(s, paper_dir, ["paper", "--out", str(paper_dir), "--quiet"])
    for name in ("paper/fig5_contraction.png", "paper/fig7_surfaces.png", "paper/fig7_sections.png", "paper/claims.md"):
        _show(s, out, name)


def _control(job: _Job, out: Path, knee_fmu: Path, quick: bool) -> None:
    """Step 4: linearization, root loci and step responses with python-control, the FMU alongside."""
    control_dir = out / "control"
    s = job.step("Control analysis with python-control")
    fmu_args = ["--fmu", str(knee_fmu)]
    job.command(s, control_dir, ["linearize", "--out", str(control_dir), *fmu_args])
    for vary in ("c", "tau", "gain"):
        job.command(s, control_dir, ["rootlocus", "--vary", vary, "--out", str(control_dir)])
    job.command(s, control_dir, ["step", "--out", str(control_dir), *fmu_args]
                + (["--duration", "1.0"] if quick else []))
    for name in ("poles.png", "rootlocus_c.png", "rootlocus_tau.png", "rootlocus_gain.png", "step_small.png",
                 "step_large.png"):
        _show(s, out, f"control/{name}")


def _diagnosis(job: _Job, out: Path, quick: bool) -> None:
    """Step 5: a knee record with damping hidden, compared and diagnosed."""
    data_dir = out / "diagnosis"
    s = job.step("Diagnose a measurement with a hidden effect")
    data = data_dir / "knee_hidden_damping.csv"
    synth = ["synth", "knee", str(data), "--hidden", f"c={HIDDEN_DAMPING:g}", "--seed", "1"]
    job.command(s, data_dir, synth + (["--samples", "1500"] if quick else []))
    job.command(s, data_dir, ["compare", str(data), "--out", str(data_dir)])
    report_json = data_dir / "diagnosis.json"
    job.command(s, data_dir, ["diagnose", str(data), "--json", str(report_json), "--out", str(data_dir)])
    report = json.loads(report_json.read_text())
    found = ", ".join(f"{name} = {value:.4g}" for name, value in report["params"].items()) or "nothing"
    s.summary = (f"Hidden in the data: viscous damping, c = {HIDDEN_DAMPING:g} N s/m. Found: "
                 f"{', '.join(report['missing']) or 'nothing'} ({found}, SI units); RMSE "
                 f"{report['rmse_before']:.4g} mm -> {report['rmse_after']:.4g} mm.\n\n" + s.summary)
    _show(s, out, "diagnosis/knee_hidden_damping.csv", data)
    for png in sorted(data_dir.glob("*.png")):
        s.add(png, png.stem.replace("_", " "), _diagnosis_sentence(png.name))
    _show(s, out, "diagnosis/diagnosis.json", report_json)


def _diagnosis_sentence(name: str) -> str:
    """One sentence for each picture that compare and diagnose write, by the end of its file name."""
    sentences = {
        "_compare_overlay.png": "mkctl compare: the measured hip height against the baseline model's simulation "
                                "of the same pressure commands.",
        "_compare_residual.png": "mkctl compare: what the baseline misses, sample by sample.",
        "_error_steps.png": "The error falling step by step as the diagnosis adds each missing effect; the last "
                            "bar is the final fit on the whole record.",
        "_overlay.png": "The measurement against the model before and after the diagnosis.",
        "_residuals.png": "The residual before (the baseline) and after (with the effects found): only noise "
                          "is left.",
        "_signatures.png": "The force the baseline lacks against what each candidate effect acts through "
                           "(velocity, direction of motion, the pressure a lag holds back, the smaller muscle "
                           "tension): the evidence behind the choice.",
    }
    for ending, sentence in sentences.items():
        if name.endswith(ending) and not (ending == "_overlay.png" and name.endswith("_compare_overlay.png")):
            return sentence
    return "A figure of the diagnosis."
