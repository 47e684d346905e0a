"""Windows binaries of the native FMUs, cross-compiled with MinGW-w64 (model-spec section 7c).

The build machine is Linux; a Windows host needs a DLL. When the MinGW-w64 cross compiler is installed (Debian's
``gcc-mingw-w64-x86-64``: ``x86_64-w64-mingw32-gcc``, or ``$MKCTL_MINGW_CC``), every native FMU (FMI 2.0 and
FMI 3.0) also carries ``binaries/win64/<model>.dll`` (``binaries/x86_64-windows/`` in FMI 3.0), compiled from the
same ``sources/`` with the core's flags (no fused multiply-add, no fast-math) and ``-static-libgcc``: the DLL
needs only ``KERNEL32.dll`` and ``msvcrt.dll``, which every Windows has. Without the cross compiler the build says
so in one line on stderr and the FMUs carry the Linux binary only.

Wine (:func:`find_wine`) runs the cross-compiled C host of ``fmu/fmi2_host.c`` on the DLL, so the tests
(``tests/test_win64.py``) prove the Windows binary gives the Linux binary's results.
"""
from __future__ import annotations

import functools
import os
import shlex
import shutil
import sys
from pathlib import Path

#: Environment variable: the MinGW-w64 compiler command (default ``x86_64-w64-mingw32-gcc``).
ENV_MINGW = "MKCTL_MINGW_CC"
MINGW_CC = "x86_64-w64-mingw32-gcc"
#: Flags of the DLL: it depends on nothing but Windows' own KERNEL32 and msvcrt, and prints numbers as C99 says
#: (MinGW's printf, not msvcrt's three-digit exponents), so its messages read as on Linux.
DLL_FLAGS = ("-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1")
#: Debian's package names, for the one-line notes.
MINGW_PACKAGE = "gcc-mingw-w64-x86-64"
WINE_PACKAGES = "wine wine64"


def find_cross_compiler() -> list[str] | None:
    """The MinGW-w64 compiler command for 64-bit Windows, or None: ``$MKCTL_MINGW_CC`` when set (None if that is
    not found; set it to an empty string to build no Windows binaries), else ``x86_64-w64-mingw32-gcc``."""
    requested = os.environ.get(ENV_MINGW)
    words = shlex.split(requested) if requested is not None else [MINGW_CC]
    if not words:
        return None
    found = shutil.which(words[0])
    return [found, *words[1:]] if found else None


def missing_cross_compiler() -> str:
    """The one line that says why there is no Windows binary."""
    return (f"no MinGW-w64 cross compiler ({os.environ.get(ENV_MINGW) or MINGW_CC}; Debian: apt-get install "
            f"{MINGW_PACKAGE}): the native FMUs carry no Windows binary")


@functools.lru_cache(maxsize=1)
def _note_missing() -> None:
    print(f"mkctl.native: note: {missing_cross_compiler()}", file=sys.stderr)


def add_windows_binary(sources: Path, units: list[str], target: Path, compile_binary) -> bool:
    """Compile the units into the Windows DLL target (``.../binaries/win64/<model>.dll``) with the build's own
    ``compile_binary`` (:func:`mkctl.native.fmu.compile_binary`, handed in: that module calls this one); False (and
    a note on stderr, once per process) when no cross compiler is installed."""
    compiler = find_cross_compiler()
    if compiler is None:
        _note_missing()
        return False
    compile_binary(sources, units, target, compiler=compiler, link_flags=DLL_FLAGS)
    return True


def find_wine() -> list[str] | None:
    """The command that runs a 64-bit Windows program here (``wine64``, ``wine``, Debian's
    ``/usr/lib/wine/wine64``), or None."""
    for name in ("wine64", "wine", "wine-stable"):
        found = shutil.which(name)
        if found:
            return [found]
    debian = Path("/usr/lib/wine/wine64")
    return [str(debian)] if debian.is_file() and os.access(debian, os.X_OK) else None


def wine_environment(prefix: Path) -> dict[str, str]:
    """Wine's environment: its own prefix (``WINEPREFIX``, created on first use: wineboot takes several seconds),
    no debug output, no display needed."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("WINE")}
    env.update(WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    env.pop("DISPLAY", None)
    return env
