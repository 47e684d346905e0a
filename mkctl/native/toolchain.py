"""The C toolchains mkctl compiles with, and the FMI platforms the native FMUs carry binaries for.

Two toolchains compile the same generated C with the same flags:

- the system's C compiler: ``$CC`` if set, else the first of ``cc``, ``gcc``, ``clang`` on the PATH;
- the ``ziglang`` package from PyPI (``pip install mkctl[native]``), run as ``python -m ziglang
  cc``: clang with the C libraries of every platform, so one Linux machine with pip alone compiles
  for Linux, Windows and macOS, on x86-64 and ARM.

``MKCTL_CC`` chooses (:data:`ENV_CHOICE`): ``system`` (the system compiler only), ``zig`` (ziglang
only, even when a system compiler is installed), or ``auto`` (the default: ``$CC`` when set, else
the system compiler, else ziglang). The compiled core and the native FMUs' host binary use that
choice; the binaries for the other platforms (:data:`PLATFORMS`) are always cross-compiled by
ziglang, except Windows, which MinGW-w64 builds when it is installed (:mod:`mkctl.native.cross`).

Zig's first compile for a target builds that target's C runtime and caches it
(``$ZIG_GLOBAL_CACHE_DIR``, default ``~/.cache/zig``): seconds to minutes per target, once per
machine (docs/native.md, "A compiler from pip").
"""
from __future__ import annotations

import functools
import importlib.util
import os
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from importlib import metadata

from ..errors import MkctlError

#: Environment variable: which toolchain compiles the core and the host binary ("system", "zig",
#: "auto").
ENV_CHOICE = "MKCTL_CC"
CHOICES = ("auto", "system", "zig")
#: The PyPI package of the zig toolchain, and the extra that installs it.
ZIG_PACKAGE = "ziglang"
ZIG_EXTRA = "mkctl[native]"


class ToolchainError(MkctlError, ValueError):
    """A toolchain setting mkctl cannot follow (an unknown MKCTL_CC)."""


@dataclass(frozen=True)
class Platform:
    """One platform the native FMUs carry a binary for.

    fmi3: the FMI 3.0 platform tuple (the folder of ``binaries/``); fmi2: FMI 2.0's name for it, or
    None where FMI 2.0 has none (the FMI 2.0 FMU carries the sources for it); zig_target:
    ``-target`` of ``zig cc``; suffix: the shared library's; machine and system: what the binary
    runs on."""

    fmi3: str
    fmi2: str | None
    zig_target: str
    suffix: str
    machine: str
    system: str

    def folder(self, fmi_version: str) -> str | None:
        """The folder of ``binaries/`` in an FMU of that FMI version ("2.0" or "3.0"), or None."""
        return self.fmi3 if fmi_version.startswith("3") else self.fmi2


#: Every platform of the native FMUs; the first is the build machine's (mkctl builds on x86-64
#: Linux). aarch64-linux is compiled against glibc 2.17, the first with aarch64, so that old boards
#: load it too.
PLATFORMS = (
    Platform("x86_64-linux", "linux64", "x86_64-linux-gnu", ".so", "x86_64", "linux"),
    Platform("x86_64-windows", "win64", "x86_64-windows-gnu", ".dll", "x86_64", "windows"),
    Platform("aarch64-linux", None, "aarch64-linux-gnu.2.17", ".so", "aarch64", "linux"),
    Platform("x86_64-darwin", "darwin64", "x86_64-macos", ".dylib", "x86_64", "darwin"),
    Platform("aarch64-darwin", None, "aarch64-macos", ".dylib", "aarch64", "darwin"),
)
HOST = PLATFORMS[0]
BY_NAME = {p.fmi3: p for p in PLATFORMS}


def choice() -> str:
    """The toolchain asked for by ``MKCTL_CC`` ("auto" when unset).

    Raises :class:`ToolchainError`."""
    value = os.environ.get(ENV_CHOICE, "").strip().lower() or "auto"
    if value not in CHOICES:
        raise ToolchainError(f"{ENV_CHOICE} must be one of {', '.join(CHOICES)}, got "
                             f"{os.environ.get(ENV_CHOICE)!r}")
    return value


def zig_installed() -> bool:
    """Whether the ``ziglang`` package is importable in this Python."""
    return importlib.util.find_spec(ZIG_PACKAGE) is not None


def zig_command(target: str | None = None) -> list[str] | None:
    """``python -m ziglang cc`` (with ``-target``), or None when ziglang is not installed."""
    if not zig_installed():
        return None
    return [sys.executable, "-m", ZIG_PACKAGE, "cc", *(["-target", target] if target else [])]


def is_zig(compiler: list[str]) -> bool:
    """Whether a compiler command is ziglang's."""
    return list(compiler[1:4]) == ["-m", ZIG_PACKAGE, "cc"]


def system_compiler() -> list[str] | None:
    """The system's C compiler: ``$CC`` when set (None if it is not found), else cc, gcc or clang,
    or None."""
    requested = os.environ.get("CC")
    if requested:
        words = shlex.split(requested)
        found = shutil.which(words[0]) if words else None
        return [found, *words[1:]] if found else None
    for name in ("cc", "gcc", "clang"):
        found = shutil.which(name)
        if found:
            return [found]
    return None


def host_compiler() -> list[str] | None:
    """The compiler of the compiled core and of the build machine's FMU binary, as ``MKCTL_CC``
    chooses."""
    chosen = choice()
    if chosen == "zig":
        return zig_command()
    if chosen == "system":
        return system_compiler()
    if os.environ.get("CC"):  # a compiler the user named: that one, or none if it is missing
        return system_compiler()
    return system_compiler() or zig_command()


def missing_host_compiler() -> str:
    """Why :func:`host_compiler` found none, in a few words."""
    chosen = choice()
    if chosen == "zig":
        return (f"{ENV_CHOICE}=zig but the {ZIG_PACKAGE} package is not installed "
                f"(pip install {ZIG_EXTRA})")
    if chosen == "system":
        return f"no C compiler found (CC, cc, gcc, clang; {ENV_CHOICE}=system)"
    return (f"no C compiler found (CC, cc, gcc, clang, or the {ZIG_PACKAGE} package: "
            f"pip install {ZIG_EXTRA})")


def identity(compiler: list[str]) -> str:
    """The compiler's command and the first line of its ``--version``, and ziglang's version for zig
    (the compiled-core cache records it: another compiler or version builds the library again).
    Asked once per process and command (starting ziglang takes a few tenths of a second)."""
    return _identity(tuple(compiler))


@functools.lru_cache(maxsize=16)
def _identity(compiler: tuple[str, ...]) -> str:
    try:
        done = subprocess.run([*compiler, "--version"], capture_output=True, text=True, timeout=60)
        version = (done.stdout.strip().splitlines() or [""])[0]
    except (OSError, subprocess.SubprocessError):
        version = "unknown"
    if is_zig(list(compiler)):
        try:
            version = f"{ZIG_PACKAGE} {metadata.version(ZIG_PACKAGE)}, {version}"
        except metadata.PackageNotFoundError:
            pass
    return f"{' '.join(compiler)} ({version})"


def cross_compiler(platform: Platform) -> list[str] | None:
    """The compiler of the binary for a platform other than the build machine's: ziglang with the
    platform's target, or None when ziglang is not installed. (Windows: see
    :func:`mkctl.native.cross.platform_compiler`.)"""
    return zig_command(platform.zig_target)
