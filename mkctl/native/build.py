"""Build the compiled core once per machine: find the C compiler, cache the generated source and library.

Cache folder: ``$MKCTL_CACHE`` if set, else ``$XDG_CACHE_HOME/mkctl`` or ``~/.cache/mkctl``; the files go to
its ``native/`` subfolder:

- ``gen-<inputs>.c``: the generated source, keyed by a hash of everything it is generated from (the
  physics modules, the generator, the C template, the sympy version, the variants), so that the equations
  are traced once, not in every process;
- ``core-<key>.so``: the shared library, keyed by a hash of the generated source it is compiled from, the
  compiler (its command and version) and the flags.

Each has a record beside it (``<name>.json``): its SHA-256 and what it was made from (the inputs' key; the
source's SHA-256, the compiler and its version, the flags). A cached file is used only when the record matches
both the file and what would be made now; anything else (a file edited or swapped in the cache, a record
missing, another compiler) is made again, so the cache never loads code it did not build.

Files are written to a temporary name and renamed, so processes building at the same time do not clash.
The compiler is :func:`mkctl.native.toolchain.host_compiler`'s: ``$CC`` if set (none if that does not exist),
else the first of ``cc``, ``gcc``, ``clang`` on the PATH, else the ``ziglang`` package's (``pip install
mkctl[native]``); ``MKCTL_CC=zig`` or ``MKCTL_CC=system`` asks for one of them only. The library's record holds
the compiler's command and version (ziglang's too), so a library built by one is never loaded for the other.
``MKCTL_NATIVE=0`` switches the compiled core off altogether.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path

from . import TEMPLATE, toolchain

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
    """The C compiler command, or None (:func:`mkctl.native.toolchain.host_compiler`: ``MKCTL_CC``
    chooses; by default ``$CC`` when set, else cc, gcc or clang, else ziglang's)."""
    return toolchain.host_compiler()


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


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _record_path(path: Path) -> Path:
    """The record kept next to a cached file: ``<name>.json``, what the file was made from and its hash."""
    return path.with_name(path.name + ".json")


def _read_record(path: Path) -> dict | None:
    try:
        record = json.loads(_record_path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def _write_record(path: Path, record: dict) -> None:
    _write_atomic(_record_path(path), json.dumps(record, indent=1, sort_keys=True).encode())


def _verified(path: Path, expected: dict) -> bool:
    """Whether the cached ``path`` is what its record says (its SHA-256) and the record is ``expected`` (the
    inputs it was made from: source hash, compiler, flags). A file edited, truncated or swapped in the cache, or
    made by another compiler, fails, and is made again."""
    record = _read_record(path)
    if record is None or any(record.get(k) != v for k, v in expected.items()):
        return False
    try:
        return record.get("sha256") == _digest(path.read_bytes())
    except OSError:
        return False


def compiler_identity(compiler: list[str]) -> str:
    """The compiler's command and the first line of its ``--version`` (cached libraries record it;
    ziglang's version too: :func:`mkctl.native.toolchain.identity`)."""
    return toolchain.identity(compiler)


#: codegen.generate's results in this process, by input_key: the compiled core and the native FMUs' core are
#: generated from the same traced equations, and tracing them takes seconds (tens with a user effect).
_GENERATED: dict[str, tuple] = {}


def generation(variants) -> tuple:
    """:func:`mkctl.native.codegen.generate` for the variants: the C source and its CheckTable, generated once per
    process and set of inputs. Callers must not change the table (``table.copy()`` numbers on from it)."""
    key = input_key(variants)
    if key not in _GENERATED:
        try:
            from . import codegen
        except ImportError as error:
            raise BuildUnavailable(f"cannot generate the C: {error}") from None
        _GENERATED.clear()  # only the newest: an effect registered for one test must not pin its traces
        _GENERATED[key] = codegen.generate(variants)
    return _GENERATED[key]


@contextmanager
def cache_lock(path: Path):
    """Hold an exclusive lock (``<path>.lock``) while ``path`` is made: processes that start together on an empty
    cache (Dask's workers, pytest-xdist's) make it once, the others wait for it and read it. Where there are no
    POSIX locks, or the cache cannot be written, each makes its own (as before: the writes are atomic)."""
    try:
        import fcntl
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(path.with_name(path.name + ".lock"), "a")
    except (ImportError, OSError):
        yield
        return
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX)
        except OSError:  # a file system without locks (some network ones): as without the lock
            pass
        yield


def generated_source(variants) -> Path:
    """The generated C source for the variants, from the cache (verified against its record) or generated now."""
    key = input_key(variants)
    path = cache_dir() / f"gen-{key}.c"
    if path.exists() and _verified(path, {"inputs": key}):
        return path
    with cache_lock(path):
        if not (path.exists() and _verified(path, {"inputs": key})):  # another process may have made it meanwhile
            source, _ = generation(variants)
            data = source.encode()
            _write_atomic(path, data)
            _write_record(path, {"inputs": key, "sha256": _digest(data)})
    return path


def build_library(variants) -> Path:
    """The compiled library for the variants (built now if not cached). Raises :class:`BuildUnavailable`."""
    if not enabled():
        raise BuildUnavailable(f"switched off by {ENV_SWITCH}={os.environ.get(ENV_SWITCH)}")
    compiler = find_compiler()
    if compiler is None:
        raise BuildUnavailable(toolchain.missing_host_compiler())
    return cached_library(compiler, [generated_source(variants)], "core")


def cached_library(compiler: list[str], source_paths: list[Path], prefix: str) -> Path:
    """The library ``<prefix>-<key>`` compiled from the sources (one command), from the cache when
    its record matches them (their SHA-256), the compiler and the flags; compiled now otherwise."""
    hashes = [_digest(path.read_bytes()) for path in source_paths]
    expected = {"source_sha256": hashes[0] if len(hashes) == 1 else hashes,
                "compiler": compiler_identity(compiler), "cflags": list(CFLAGS)}
    # the name is keyed by the compiler too: the system compiler's library and ziglang's coexist
    key = _digest(json.dumps(expected, sort_keys=True).encode())[:20]
    library = cache_dir() / f"{prefix}-{key}{_library_suffix()}"
    if library.exists() and _verified(library, expected):
        return library
    with cache_lock(library):
        if library.exists() and _verified(library, expected):  # another process built it meanwhile
            return library
        return _compile_library(compiler, source_paths, library, expected)


def _compile_library(compiler: list[str], source_paths: list[Path], library: Path,
                     expected: dict) -> Path:
    handle, temporary = tempfile.mkstemp(dir=library.parent, prefix=library.name + ".", suffix=".tmp")
    os.close(handle)
    command = [*compiler, *CFLAGS, "-o", temporary, *map(str, source_paths), "-lm"]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise BuildUnavailable(f"the C compiler failed ({' '.join(command)}): "
                                   + (done.stderr.strip().splitlines() or ["no message"])[0])
        built = Path(temporary).read_bytes()
        os.replace(temporary, library)
        _write_record(library, {**expected, "sha256": _digest(built)})
    except OSError as error:
        raise BuildUnavailable(f"the C compiler could not run: {error}") from None
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return library
