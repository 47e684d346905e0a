"""Binaries of the native FMUs for every FMI platform, cross-compiled from this Linux machine
(model-spec 7c).

The build machine's binary (``linux64`` / ``x86_64-linux``) is compiled by :mod:`mkctl.native.fmu`;
this module adds the others (:data:`mkctl.native.toolchain.PLATFORMS`), from the same ``sources/``
with the core's flags (no fused multiply-add, no fast-math):

- ``x86_64-windows`` (FMI 2.0: ``win64``): MinGW-w64 when installed (Debian's
  ``gcc-mingw-w64-x86-64``: ``x86_64-w64-mingw32-gcc``, or ``$MKCTL_MINGW_CC``), with
  ``-static-libgcc``: the DLL needs only ``KERNEL32.dll`` and ``msvcrt.dll``, which every Windows
  has; else ziglang (``-target x86_64-windows-gnu``);
- ``aarch64-linux`` (FMI 2.0 has no name for it: the FMI 2.0 FMU carries the sources), ziglang
  against glibc 2.17;
- ``x86_64-darwin`` (FMI 2.0: ``darwin64``) and ``aarch64-darwin`` (FMI 3.0 only), ziglang with its
  macOS libraries (the dylibs link against ``/usr/lib/libSystem.B.dylib`` only).

A platform whose toolchain is missing is left out, with one line on stderr per process saying so.

Wine (:func:`find_wine`) runs the cross-compiled C hosts of ``fmu/`` on the Windows DLLs
(``tests/test_win64.py``), qemu-user (:func:`find_qemu`) on the aarch64 ones
(``tests/test_platforms.py``); the macOS binaries are checked by their structure, not run.
"""
from __future__ import annotations

import functools
import os
import shlex
import shutil
import sys
import tempfile
from pathlib import Path

from . import toolchain

#: Environment variable: the MinGW-w64 compiler command (default ``x86_64-w64-mingw32-gcc``).
ENV_MINGW = "MKCTL_MINGW_CC"
MINGW_CC = "x86_64-w64-mingw32-gcc"
#: Flags of the DLL: it depends on nothing but Windows' own KERNEL32 and msvcrt, and prints numbers
#: as C99 says (MinGW's printf, not msvcrt's three-digit exponents), so its messages read as on
#: Linux.
DLL_FLAGS = ("-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1")
#: Flags of ziglang's binaries by system: Windows as MinGW-w64's (C99 printf); the others need none.
ZIG_FLAGS = {"windows": ("-D__USE_MINGW_ANSI_STDIO=1",), "linux": (), "darwin": ()}
#: Debian's package names, for the one-line notes.
MINGW_PACKAGE = "gcc-mingw-w64-x86-64"
WINE_PACKAGES = "wine wine64"


def find_cross_compiler() -> list[str] | None:
    """The MinGW-w64 compiler command for 64-bit Windows, or None: ``$MKCTL_MINGW_CC`` when set
    (None if that is not found; set it to an empty string to build no Windows binaries), else
    ``x86_64-w64-mingw32-gcc``."""
    requested = os.environ.get(ENV_MINGW)
    words = shlex.split(requested) if requested is not None else [MINGW_CC]
    if not words:
        return None
    found = shutil.which(words[0])
    return [found, *words[1:]] if found else None


def missing_cross_compiler() -> str:
    """The one line that says why there is no Windows binary."""
    if os.environ.get(ENV_MINGW) == "":
        return (f"no MinGW-w64 cross compiler ({ENV_MINGW} is empty: no Windows binary asked "
                "for): the native FMUs carry no Windows binary")
    return (f"no MinGW-w64 cross compiler ({os.environ.get(ENV_MINGW) or MINGW_CC}; Debian: "
            f"apt-get install {MINGW_PACKAGE}) and no ziglang (pip install {toolchain.ZIG_EXTRA}): "
            "the native FMUs carry no Windows binary")


@functools.lru_cache(maxsize=1)
def _note_missing() -> None:
    print(f"mkctl.native: note: {missing_cross_compiler()}", file=sys.stderr)


def add_windows_binary(sources: Path, units: list[str], target: Path, compile_binary) -> bool:
    """Compile the units into the Windows DLL target (``.../binaries/win64/<model>.dll``) with
    MinGW-w64 and the build's own ``compile_binary`` (:func:`mkctl.native.fmu.compile_binary`,
    handed in: that module calls this one); False (and a note on stderr, once per process) when no
    cross compiler is installed."""
    compiler = find_cross_compiler()
    if compiler is None:
        _note_missing()
        return False
    compile_binary(sources, units, target, compiler=compiler, link_flags=DLL_FLAGS)
    return True


def platform_compiler(platform: toolchain.Platform) -> tuple[list[str], tuple[str, ...]] | None:
    """The compiler command and link flags of a platform's binary, or None when its toolchain is
    missing: Windows: MinGW-w64 if installed, else ziglang; the others: ziglang."""
    if platform.system == "windows":
        mingw = find_cross_compiler()
        if mingw is not None:
            return mingw, DLL_FLAGS
        if os.environ.get(ENV_MINGW) == "":  # no Windows binary asked for
            return None
    zig = toolchain.cross_compiler(platform)
    return (zig, ZIG_FLAGS[platform.system]) if zig is not None else None


@functools.lru_cache(maxsize=None)
def _note_platform_missing(name: str) -> None:
    print(f"mkctl.native: note: no toolchain for {name} (pip install {toolchain.ZIG_EXTRA}): the "
          "native FMUs carry no binary for it", file=sys.stderr)


def add_platform_binaries(sources: Path, units: list[str], binaries: Path, model_name: str,
                          fmi_version: str, compile_binary) -> list[str]:
    """Compile the units into ``binaries/<folder>/<model><suffix>`` for every platform but the build
    machine's that the FMI version names (:meth:`mkctl.native.toolchain.Platform.folder`), with the
    build's own ``compile_binary``; returns the folders written. A platform without its toolchain is
    left out (one note on stderr per process)."""
    written = []
    for platform in toolchain.PLATFORMS:
        folder = platform.folder(fmi_version)
        if platform is toolchain.HOST or folder is None:
            continue
        found = platform_compiler(platform)
        if found is None:
            if platform.system == "windows":
                _note_missing()
            else:
                _note_platform_missing(platform.fmi3)
            continue
        compiler, flags = found
        target = binaries / folder / f"{model_name}{platform.suffix}"
        target.parent.mkdir(parents=True, exist_ok=True)
        # compiled in a folder of its own: zig writes a .pdb and an import library beside a DLL;
        # only the binary goes into the FMU
        with tempfile.TemporaryDirectory(prefix="mkctl_cross_") as temporary:
            built = Path(temporary) / target.name
            compile_binary(sources, units, built, compiler=compiler, link_flags=flags)
            shutil.move(built, target)
        written.append(folder)
    return written


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
    """Wine's environment: its own prefix (``WINEPREFIX``, created on first use: wineboot takes
    several seconds), no debug output, no display needed."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("WINE")}
    env.update(WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    env.pop("DISPLAY", None)
    return env


#: Debian's packages that run aarch64 Linux programs here: the emulator, and the aarch64 C library
#: it loads.
QEMU_PACKAGES = "qemu-user-static libc6-arm64-cross"
#: Where Debian's libc6-arm64-cross puts the aarch64 C library (qemu's -L).
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")


def find_qemu() -> list[str] | None:
    """The command that runs a dynamically linked aarch64 Linux program here (``qemu-aarch64-static
    -L /usr/aarch64-linux-gnu``), or None when qemu-user or the aarch64 C library is missing."""
    for name in ("qemu-aarch64-static", "qemu-aarch64"):
        found = shutil.which(name)
        if found and (AARCH64_SYSROOT / "lib" / "ld-linux-aarch64.so.1").exists():
            return [found, "-L", str(AARCH64_SYSROOT)]
    return None
