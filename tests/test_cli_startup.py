"""The command line answers at once: ``import mkctl`` and ``mkctl --help`` import none of the heavy libraries, and
the lazy parser lists the same commands, with the same help, as the full one. (Times are in bench/bench_cli.py.)"""
import json
import subprocess
import sys

import pytest

from mkctl.cli import COMMANDS, build_parser, main, requested_command

#: Libraries that take a second or more together to import; a command imports the ones it needs when it runs.
HEAVY = ("matplotlib", "dask", "distributed", "control", "fmpy", "scipy", "pandas", "sympy", "pythonfmu")

PROBE = """
import json, sys
{code}
print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})))
"""


def loaded_after(code: str, run_python) -> set:
    return set(run_python(PROBE.format(code=code)))


def test_import_mkctl_loads_no_heavy_library(run_python):
    loaded = loaded_after("import mkctl\nfrom mkctl import Params, read_muscle, MkctlError, DEFAULT", run_python)
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


@pytest.mark.parametrize("argv", [["--help"], ["diagnose", "--help"], ["sweep", "--help"], ["linearize", "--help"]])
def test_help_loads_no_heavy_library(argv, run_python):
    code = f"""
import contextlib, io
from mkctl.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main({argv!r})
    except SystemExit as stop:
        assert stop.code == 0
"""
    loaded = loaded_after(code, run_python)
    # a command's options may take their defaults from the analysis (numpy is fine); never the heavy libraries
    assert not loaded & {"matplotlib", "dask", "distributed", "control", "fmpy", "pandas", "sympy"}, sorted(loaded)


def subcommands(parser):
    return next(a for a in parser._actions if a.dest == "command")


def test_the_lazy_parser_lists_what_the_full_one_has():
    """``mkctl --help`` (every command by name and help only) shows what the full parser would, in its order."""
    full, lazy = subcommands(build_parser()), subcommands(build_parser(""))
    helps = [(a.dest, a.help) for a in full._choices_actions]
    assert helps == [(a.dest, a.help) for a in lazy._choices_actions]
    assert [name for name, _ in helps] == [name for module in COMMANDS for name in module.COMMANDS]


def test_a_command_gets_its_full_parser():
    parser = build_parser("diagnose")
    diagnose = subcommands(parser).choices["diagnose"]
    assert {"json", "out", "fit_offset", "jobs"} <= {a.dest for a in diagnose._actions}
    synth = subcommands(parser).choices["synth"]  # the same module's other commands are full too
    assert "hidden" in {a.dest for a in synth._actions}


def test_requested_command_is_the_first_word():
    assert requested_command(["--help"]) == ""
    assert requested_command(["-h", "diagnose"]) == "diagnose"
    assert requested_command(["diagnose", "x.csv", "--json", "o.json"]) == "diagnose"


def test_an_unknown_command_is_one_line(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["diagnoze"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "invalid choice: 'diagnoze'" in err and "'diagnose'" in err


def test_mkctl_help_from_the_installed_command():
    done = subprocess.run([sys.executable, "-m", "mkctl", "--help"], capture_output=True, text=True)
    assert done.returncode == 0
    for module in COMMANDS:
        for name in module.COMMANDS:
            assert f"    {name}" in done.stdout
