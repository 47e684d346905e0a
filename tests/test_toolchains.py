"""CI fails, rather than skips, when a toolchain it promises is missing (issue 30).

tests/conftest.py has the switch: ``require_or_skip(available, what)`` for new tests, and a report hook that turns
the existing skips for a missing toolchain (``pytest.skip``, ``skipif`` marks, ``importorskip``) into failures
under ``MKCTL_REQUIRE_TOOLCHAINS=1`` (.ci/run sets it). Checked here on a small suite run by pytest in a fresh
process, with and without the switch: the same tests skip on a user's clone (saying CI would fail) and fail in CI
(naming what is missing); a skip for anything else stays a skip.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SUITE = '''
import pytest
from conftest import require_or_skip


def test_helper_missing():
    require_or_skip(False, "no C compiler (CC, cc, gcc, clang)")


def test_helper_present():
    require_or_skip(True, "no C compiler (CC, cc, gcc, clang)")


def test_old_skip_call():
    pytest.skip("no MinGW-w64 cross compiler (x86_64-w64-mingw32-gcc)")


@pytest.mark.skipif(True, reason="Wine is not installed: the Windows binaries cannot be run here")
def test_old_skipif_mark():
    pass


def test_importorskip():
    pytest.importorskip("libcosimpy_that_is_not_installed_here")


def test_other_skip():
    pytest.skip("slow: runs with MKCTL_SLOW=1 (as .ci/run does)")
'''


def _run(tmp_path, required: bool):
    folder = tmp_path / ("ci" if required else "clone")
    folder.mkdir()
    shutil.copy(ROOT / "tests" / "conftest.py", folder / "conftest.py")
    (folder / "test_suite.py").write_text(SUITE)
    env = {k: v for k, v in os.environ.items() if k != "MKCTL_REQUIRE_TOOLCHAINS"}
    if required:
        env["MKCTL_REQUIRE_TOOLCHAINS"] = "1"
    done = subprocess.run([sys.executable, "-m", "pytest", "-rA", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "--rootdir", str(folder), str(folder)], capture_output=True, text=True, cwd=folder,
                          env=env, timeout=120)
    return done


def _outcome(output: str, test: str) -> str:
    """PASSED, FAILED or ERROR of a test from pytest's -rA summary ('' if not named there: skips are listed by
    place)."""
    for line in output.splitlines():
        if test in line and line.split()[0] in ("PASSED", "FAILED", "ERROR"):
            return line.split()[0]
    return ""


def test_a_user_s_clone_skips_saying_what_is_missing(tmp_path):
    done = _run(tmp_path, required=False)
    assert done.returncode == 0, done.stdout[-3000:]
    assert re.search(r"1 passed, 5 skipped", done.stdout), done.stdout[-2000:]
    assert "no C compiler (CC, cc, gcc, clang) (a missing toolchain: CI fails here, with " \
           "MKCTL_REQUIRE_TOOLCHAINS=1)" in done.stdout


def test_ci_fails_naming_the_missing_toolchain_and_keeps_other_skips(tmp_path):
    done = _run(tmp_path, required=True)
    assert done.returncode == 1, done.stdout[-3000:]
    summary = done.stdout.strip().splitlines()[-1]
    assert "1 skipped" in summary and "1 passed" in summary, summary
    for test in ("test_helper_missing", "test_old_skip_call", "test_old_skipif_mark", "test_importorskip"):
        assert _outcome(done.stdout, test) in ("FAILED", "ERROR"), (test, done.stdout[-3000:])
    for what in ("no C compiler (CC, cc, gcc, clang), and MKCTL_REQUIRE_TOOLCHAINS=1 says",
                 "MinGW-w64 is missing", "Wine is missing", "libcosimpy is missing"):
        assert what in done.stdout, (what, done.stdout[-3000:])


@pytest.mark.parametrize("reason, tool", [
    ("no C compiler: no native FMUs", "a C compiler"), ("gcc is not installed: cannot compile the C host",
                                                        "a C compiler"),
    ("Wine's first start (wineboot) took more than 120 s here", "Wine"),
    ("cmake is not installed: fmpy's compile needs it", "cmake"),
    ("could not import 'libcosimpy': No module named 'libcosimpy'", "libcosimpy"),
    ("slow: runs with MKCTL_SLOW=1 (as .ci/run does)", None),
    ("the slaves of this checkout have no P_rated", None),
])
def test_the_existing_skip_reasons_are_recognized(reason, tool):
    from conftest import missing_toolchain
    assert missing_toolchain(reason) == tool


def test_ci_run_sets_the_switch_and_fails_a_failed_install():
    script = (ROOT / ".ci" / "run").read_text()
    assert "export MKCTL_REQUIRE_TOOLCHAINS=1" in script
    assert "will skip" not in script and "exit 1" in script
