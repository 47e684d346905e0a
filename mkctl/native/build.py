"""Build the compiled core once per machine: find the C compiler, cache the generated source and library.

Cache folder: ``$MKCTL_CACHE`` if set, else ``$XDG_CACHE_HOME/mkctl`` or ``~/.cache/mkctl``; the files go to
its ``native/`` subfolder:

- ``gen-<inputs>.c``: the generated source, keyed by a hash of everything it is generated from (the
  physics modules, the generator, the C template, the sympy version, the variants), so that the equations
  are traced once, not in every process;
- ``core-<source>.so``: the shared library, keyed by a hash of the generated source it is compiled from.

Files are written to a temporary name and renamed, so processes building at the same time do not clash.
The compiler is ``$CC`` if set (none if that does not exist), else the first of ``cc``, ``gcc``, ``clang``
on the PATH. ``MKCTL_NATIVE=0`` switches the compiled core off altogether.
"""
from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

from . import TEMPLATE

#: Environment variable: "0" forces the Python path.
ENV_SWITCH = "MKCTL_NATIVE"
#: Environment variable: the cache folder.
ENV_CACHE = "MKCTL_CACHE"
#: Compiler flags: optimised, but no contraction into fused multiply-adds and no fast-math, so the C rounds
#: as Python does, operation by operation.
CFLAGS = ("-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math")
#: Bump when the generator changes in a way its source files do not show.
GENERATOR_VERSION = "1"


class BuildUnavailable(Exception):
    """The compiled core cannot be built here (no compiler, no sympy, switched off); the reason is the text."""


def enabled() -> bool:
    """False when ``MKCTL_NATIVE=0`` (or "no", "off", "false")."""
    return os.environ.get(ENV_SWITCH, "1").strip().lower() not in ("0", "no", "off", "false")


def cache_dir() -> Path:
    """The folder holding generated sources and libraries."""
    root = os.environ.get(ENV_CACHE)
    if not root:
        root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mkctl"
    return Path(root) / "native"


def find_compiler() -> list[str] | None:
    """The C compiler command, or None: ``$CC`` when set (None if it is not found), else cc, gcc or clang."""
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


def _library_suffix() -> str:
    return ".dll" if sys.platform == "win32" else ".dylib" if sys.platform == "darwin" else ".so"


def input_key(variants) -> str:
    """Hash of everything the generated source depends on."""
    digest = hashlib.sha256(GENERATOR_VERSION.encode())
    physics = Path(__file__).resolve().parent.parent / "physics"
    for path in sorted(physics.glob("*.py")) + [Path(__file__).with_name("codegen.py"),
                                                 Path(__file__).with_name("variants.py"), TEMPLATE]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    try:
        digest.update(metadata.version("sympy").encode())
    except metadata.PackageNotFoundError:
        raise BuildUnavailable("sympy is not installed (it generates the C)") from None
    digest.update(",".join(v.name for v in variants).encode())
    digest.update(registry_fingerprint().encode())
    return digest.hexdigest()[:20]


def _function_fingerprint(function) -> str:
    """What a term computes, as far as Python shows it: its byte code, constants and names (nested code too)."""
    if function is None:
        return "-"
    code = getattr(function, "__code__", None)
    if code is None:
        return repr(function)

    def of(code):
        consts = [of(c) if hasattr(c, "co_code") else repr(c) for c in code.co_consts]
        return f"{code.co_code.hex()}|{consts}|{code.co_names}"
    return of(code)


def registry_fingerprint() -> str:
    """The registered effects as the generated C depends on them: every effect's parameters and structure, and the
    code of the terms of effects not built in (a built-in's code is in the physics modules hashed above)."""
    from ..physics import effects
    parts = []
    for e in effects.all_effects():
        parts.append(repr((e.name, e.parameters, e.switched_by, e.structural, e.quasi_static, e.builtin)))
        if not e.builtin:
            parts += [_function_fingerprint(f) for f in (e.tension, e.pressure_rate, e.pressure_step, e.final,
                                                          e.play, e.viscous)]
    return "\n".join(parts)


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    with os.fdopen(handle, "wb") as out:
        out.write(data)
    os.replace(temporary, path)


def generated_source(variants) -> Path:
    """The generated C source for the variants, from the cache or generated now."""
    path = cache_dir() / f"gen-{input_key(variants)}.c"
    if not path.exists():
        try:
            from . import codegen
        except ImportError as error:
            raise BuildUnavailable(f"cannot generate the C: {error}") from None
        source, _ = codegen.generate_source(variants)
        _write_atomic(path, source.encode())
    return path


def build_library(variants) -> Path:
    """The compiled library for the variants (built now if not cached). Raises :class:`BuildUnavailable`."""
    if not enabled():
        raise BuildUnavailable(f"switched off by {ENV_SWITCH}={os.environ.get(ENV_SWITCH)}")
    compiler = find_compiler()
    if compiler is None:
        raise BuildUnavailable("no C compiler found (CC, cc, gcc, clang)")
    source_path = generated_source(variants)
    source = source_path.read_bytes()
    library = cache_dir() / f"core-{hashlib.sha256(source).hexdigest()[:20]}{_library_suffix()}"
    if library.exists():
        return library
    handle, temporary = tempfile.mkstemp(dir=library.parent, prefix=library.name + ".", suffix=".tmp")
    os.close(handle)
    command = [*compiler, *CFLAGS, "-o", temporary, str(source_path), "-lm"]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise BuildUnavailable(f"the C compiler failed ({' '.join(command)}): "
                                   + (done.stderr.strip().splitlines() or ["no message"])[0])
        os.replace(temporary, library)
    except OSError as error:
        raise BuildUnavailable(f"the C compiler could not run: {error}") from None
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return library
