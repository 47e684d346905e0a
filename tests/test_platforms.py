"""The native FMUs' binaries for ARM Linux and macOS (model-spec section 7c), proven here without
those machines.

- **aarch64-linux**: the C hosts of ``fmu/`` (``fmi2_host.c``, ``fmi3_host.c``) are cross-compiled
  for aarch64 with ziglang and run under qemu-user (Debian's qemu-user-static, with the aarch64 C
  library of libc6-arm64-cross) on the FMI 3.0 FMUs' ``binaries/aarch64-linux`` and on the FMI 2.0
  FMUs' ``sources/`` compiled for aarch64 (FMI 2.0 names no ARM platform: its FMUs carry the sources
  for it). Their results must equal those of the Linux binaries in the gcc build of the same hosts,
  to 1e-12.
- **macOS** (``x86_64-darwin``, ``aarch64-darwin``; FMI 2.0's ``darwin64``): not run here (no
  macOS). Each binary is read as a Mach-O file by the small parser below: a 64-bit dynamic library
  of the right architecture, exporting every function the FMI header declares (and nothing else of
  ours), whose undefined symbols are all bound to macOS's system library
  ``/usr/lib/libSystem.B.dylib``, the only library it loads. The parser is checked on a dylib with
  an undefined symbol of no library, and on a file that is not Mach-O.

Without ziglang or qemu-user the tests skip with the reason, and fail under
``MKCTL_REQUIRE_TOOLCHAINS=1`` (CI).
"""
from __future__ import annotations

import re
import struct
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import require_or_skip
from mkctl.native import toolchain
from mkctl.native.build import CFLAGS
from mkctl.native.cross import QEMU_PACKAGES, find_qemu
from toolchain_helpers import HOST_CASES, compile_host, host_arguments, require_zig, run_host, unzipped_fmus

AARCH64 = toolchain.BY_NAME["aarch64-linux"]


@pytest.fixture(scope="module")
def zig():
    require_zig("binaries for ARM or macOS")
    return toolchain.zig_command


@pytest.fixture(scope="module")
def fmus(tmp_path_factory, zig):
    """{("fmi2" | "fmi3", "knee" | "actuator"): the unzipped FMU folder}, built with every
    platform's binary."""
    return unzipped_fmus(tmp_path_factory.mktemp("platforms"))


# --- every platform's folder ----------------------------------------------------------------------

def test_each_fmu_carries_every_platform_its_fmi_version_names(fmus):
    from fmpy import supported_platforms
    expected = {"fmi2": {"linux64", "win64", "darwin64"},
                "fmi3": {"x86_64-linux", "x86_64-windows", "aarch64-linux", "x86_64-darwin",
                         "aarch64-darwin"}}
    for (version, model), folder in fmus.items():
        found = {p.name: sorted(q.name for q in p.iterdir())
                 for p in (folder / "binaries").iterdir()}
        assert set(found) == expected[version], (version, model, found)
        name = "McKibbenKnee" if model == "knee" else "McKibbenActuator"
        # one binary each, nothing beside it (no .pdb, no .lib)
        for platform in toolchain.PLATFORMS:
            if platform.folder(version) in found:
                assert found[platform.folder(version)] == [name + platform.suffix]
        assert {"linux64", "win64", "darwin64", "c-code"} <= set(supported_platforms(str(folder)))


def test_without_ziglang_the_build_names_each_missing_platform_in_one_line(tmp_path, monkeypatch,
                                                                          capfd):
    from mkctl.native import cross
    from mkctl.native.fmi3 import build_one
    monkeypatch.setattr(toolchain, "zig_installed", lambda: False)
    monkeypatch.setenv("MKCTL_MINGW_CC", "/nonexistent/x86_64-w64-mingw32-gcc")  # and no MinGW-w64
    cross._note_platform_missing.cache_clear()
    cross._note_missing.cache_clear()
    capfd.readouterr()
    for name in ("a", "b"):  # twice: the notes come once per process
        with zipfile.ZipFile(build_one("McKibbenActuator", tmp_path / f"{name}.fmu")) as archive:
            folders = {n.split("/")[1] for n in archive.namelist() if n.startswith("binaries/")}
        assert folders == {"x86_64-linux"}
    notes = [line for line in capfd.readouterr().err.splitlines() if "note:" in line]
    assert sorted(notes) == sorted(
        [f"mkctl.native: note: no toolchain for {p} (pip install mkctl[native]): the native FMUs "
         "carry no binary for it" for p in ("aarch64-linux", "x86_64-darwin", "aarch64-darwin")]
        + ["mkctl.native: note: no MinGW-w64 cross compiler (/nonexistent/x86_64-w64-mingw32-gcc; "
           "Debian: apt-get install gcc-mingw-w64-x86-64) and no ziglang (pip install "
           "mkctl[native]): the native FMUs carry no Windows binary"]), notes


# --- aarch64-linux under qemu-user ----------------------------------------------------------------

@pytest.fixture(scope="module")
def qemu(zig):
    command = find_qemu()
    require_or_skip(command is not None, f"no qemu-user or no aarch64 C library (Debian: apt-get install "
                    f"{QEMU_PACKAGES}): the aarch64 binaries cannot be run here")
    return command


@pytest.fixture(scope="module")
def hosts(tmp_path_factory, qemu):
    """{("fmi2" | "fmi3", "linux" | "aarch64"): the C host}, compiled with gcc and with ziglang
    for aarch64."""
    folder = tmp_path_factory.mktemp("hosts")
    built = {}
    for version in ("fmi2", "fmi3", "fmi2_me"):  # fmi2_me: fmu/fmi2_me_host.c, Model Exchange
        for kind, compiler in (("linux", toolchain.system_compiler()),
                               ("aarch64", toolchain.zig_command(AARCH64.zig_target))):
            built[version, kind] = compile_host(compiler, version, folder / f"{version}_host_{kind}")
    return built


def _compile_fmi2_sources_for_aarch64(folder: Path) -> None:
    """What a user on ARM Linux does with an FMI 2.0 FMU: compile its sources/ (the files
    modelDescription.xml lists) with the core's flags, into binaries/aarch64-linux (where
    fmu/fmi2_host.c looks on aarch64)."""
    from xml.etree import ElementTree
    slave = ElementTree.parse(folder / "modelDescription.xml").getroot().find("CoSimulation")
    units = [str(folder / "sources" / f.get("name")) for f in slave.find("SourceFiles")]
    target = folder / "binaries" / AARCH64.fmi3 / f"{slave.get('modelIdentifier')}.so"
    target.parent.mkdir(parents=True, exist_ok=True)
    flags = [f for f in CFLAGS if f != "-shared"]
    done = subprocess.run([*toolchain.zig_command(AARCH64.zig_target), *flags, "-shared",
                           "-fvisibility=hidden", "-I", str(folder / "sources"), "-o", str(target),
                           *units, "-lm"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_aarch64_binary_under_qemu_gives_the_linux_results(qemu, hosts, fmus, version, model):
    folder = fmus[version, model]
    if version == "fmi2":
        _compile_fmi2_sources_for_aarch64(folder)
    output, stop, start = HOST_CASES[model]
    arguments = host_arguments(folder, output, stop, **start)
    linux = run_host([str(hosts[version, "linux"]), *arguments])
    arm = run_host([*qemu, str(hosts[version, "aarch64"]), *arguments])
    assert linux.shape == arm.shape == (round(stop / 1e-3) + 1, 2)
    if model == "knee":  # the actuator's inputs are held from the start: its tension is constant
        assert np.ptp(linux[:, 1]) > 1e-3 * np.abs(linux[:, 1]).max()  # it moved
    np.testing.assert_allclose(arm, linux, rtol=0, atol=1e-12 * max(1.0, np.abs(linux).max()))


@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_aarch64_binary_under_qemu_integrates_model_exchange_as_linux(qemu, hosts, fmus, model):
    """Model Exchange: the host (fmu/fmi2_me_host.c) integrates the FMU's states itself, in fixed
    Runge-Kutta steps, so both platforms do the same arithmetic; the knee's result is also the
    library's to the integrator's error."""
    from fmpy import read_model_description
    folder = fmus["fmi2", model]
    _compile_fmi2_sources_for_aarch64(folder)
    output, stop, start = HOST_CASES[model]
    states = read_model_description(str(folder)).numberOfContinuousStates
    common = host_arguments(folder, output, stop, **start)
    arguments = [*common[:4], "4", str(states), *common[4:]]  # 4 RK4 steps per 1 ms output
    linux = run_host([str(hosts["fmi2_me", "linux"]), *arguments])
    arm = run_host([*qemu, str(hosts["fmi2_me", "aarch64"]), *arguments])
    assert linux.shape == arm.shape == (round(stop / 1e-3) + 1, 2)
    np.testing.assert_allclose(arm, linux, rtol=0, atol=1e-12 * max(1.0, np.abs(linux).max()))
    co_simulation = run_host([str(hosts["fmi2", "linux"]), *common])  # the FMU's own integrator
    scale = max(np.ptp(co_simulation[:, 1]), 1e-3 * np.abs(co_simulation[:, 1]).max())
    np.testing.assert_allclose(linux[:, 1], co_simulation[:, 1], rtol=0, atol=1e-6 * scale)


def test_a_mechanism_fmus_aarch64_binary_under_qemu_gives_the_linux_results(qemu, hosts, tmp_path_factory):
    """A mechanism's FMU (model-spec 7d) carries the same platforms as the knee's: its ARM binary, run by
    the cross-compiled FMI 3.0 host under qemu-user, gives the Linux binary's numbers."""
    from mkctl.native.mechanism_fmu import build_mechanism
    from mkctl.physics.mechanism import builtin_mechanism
    out = tmp_path_factory.mktemp("mechanism_aarch64")
    paths = build_mechanism(builtin_mechanism("pulley_joint"), out)
    folder = out / "unzipped"
    with zipfile.ZipFile(paths["fmi3/McKibbenPulleyJoint"]) as archive:
        archive.extractall(folder)
    assert (folder / "binaries" / AARCH64.fmi3 / "McKibbenPulleyJoint.so").is_file()
    arguments = host_arguments(folder, "q", 0.5, p_cmd_muscle1=3.3e5, tau=0.02, c=5.0)
    linux = run_host([str(hosts["fmi3", "linux"]), *arguments])
    arm = run_host([*qemu, str(hosts["fmi3", "aarch64"]), *arguments])
    assert linux.shape == arm.shape == (501, 2) and np.ptp(linux[:, 1]) > 1e-2  # the joint turned
    np.testing.assert_allclose(arm, linux, rtol=0, atol=1e-12 * max(1.0, np.abs(linux).max()))


def test_the_aarch64_binary_is_an_arm_elf_library(fmus):
    data = (fmus["fmi3", "knee"] / "binaries" / AARCH64.fmi3 / "McKibbenKnee.so").read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 2  # 64-bit
    assert struct.unpack_from("<HH", data, 16) == (3, 183)  # ET_DYN, EM_AARCH64


def test_the_aarch64_binary_refuses_a_bad_parameter_with_the_linux_message(qemu, hosts, fmus):
    arguments = host_arguments(fmus["fmi3", "knee"], "X", 0.01, m=-1.0)
    runs = [subprocess.run(c, capture_output=True, text=True, env={}, timeout=300)
            for c in ([str(hosts["fmi3", "linux"]), *arguments],
                      [*qemu, str(hosts["fmi3", "aarch64"]), *arguments])]
    assert [run.returncode for run in runs] == [1, 1]
    message = "invalid parameters: parameter m must be positive, got -1.0"
    assert all(message in run.stderr for run in runs), runs[1].stderr


# --- macOS: the Mach-O structure ------------------------------------------------------------------

MH_MAGIC_64, MH_DYLIB = 0xFEEDFACF, 6
CPU_TYPES = {"x86_64": 0x01000007, "aarch64": 0x0100000C}
LC_SYMTAB = 0x2
#: LC_LOAD_DYLIB, LC_LAZY_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB, LC_LOAD_UPWARD_DYLIB
LOAD_DYLIB_COMMANDS = (0xC, 0x20, 0x80000018, 0x8000001F, 0x80000023)
N_STAB, N_TYPE, N_EXT, N_PEXT, N_UNDF, N_SECT = 0xE0, 0x0E, 0x01, 0x10, 0x0, 0xE
SYSTEM_LIBRARY = "/usr/lib/libSystem.B.dylib"
#: Symbols the linker defines in every dylib.
LINKER_SYMBOLS = {"___dso_handle", "__mh_dylib_header"}


class MachO:
    """What a 64-bit little-endian Mach-O file says about itself: CPU type, file type, the libraries
    it loads, its exported symbols and its undefined ones (each with the library that must provide
    it, by the two-level namespace's library ordinal; None: looked up anywhere at run time)."""

    def __init__(self, data: bytes):
        header = struct.unpack_from("<IiiIIIII", data, 0)
        magic, self.cputype, self.filetype, ncmds = header[0], header[1], header[3], header[4]
        if magic != MH_MAGIC_64:
            raise ValueError(f"not a 64-bit Mach-O file (magic {magic:#x})")
        offset, self.libraries, symtab = 32, [], None
        for _ in range(ncmds):
            command, size = struct.unpack_from("<II", data, offset)
            if command in LOAD_DYLIB_COMMANDS:
                name_offset, = struct.unpack_from("<I", data, offset + 8)
                name = data[offset + name_offset:offset + size].split(b"\0")[0]
                self.libraries.append(name.decode())
            elif command == LC_SYMTAB:
                symtab = struct.unpack_from("<IIII", data, offset + 8)
            offset += size
        if symtab is None:
            raise ValueError("no symbol table")
        symbols, count, strings, _ = symtab
        self.exported, self.undefined = set(), {}
        for k in range(count):
            index, kind, _, desc, _ = struct.unpack_from("<IBBHQ", data, symbols + 16 * k)
            name = data[strings + index:].split(b"\0", 1)[0].decode()
            if kind & N_STAB or not kind & N_EXT:
                continue
            if kind & N_TYPE == N_SECT and not kind & N_PEXT:
                self.exported.add(name)
            elif kind & N_TYPE == N_UNDF:
                ordinal = (desc >> 8) & 0xFF
                self.undefined[name] = (self.libraries[ordinal - 1]
                                        if 1 <= ordinal <= len(self.libraries) else None)


def fmi_functions(version: str) -> set[str]:
    """Every function the FMI header declares
    (``#define fmi2GetReal fmi2FullName(fmi2GetReal)``)."""
    from mkctl.native.fmu import fmi2_headers
    header = (fmi2_headers() / f"{version}Functions.h").read_text()
    names = set(re.findall(rf"#define\s+({version}\w+)\s+{version}FullName\(", header))
    assert len(names) > 40, names
    return names


MACOS = [("fmi2", "darwin64", "x86_64"), ("fmi3", "x86_64-darwin", "x86_64"),
         ("fmi3", "aarch64-darwin", "aarch64")]


@pytest.mark.parametrize("version, folder, machine", MACOS)
@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_macos_binary_is_a_dylib_of_its_architecture_with_every_fmi_function(
        fmus, version, folder, machine, model):
    path, = (fmus[version, model] / "binaries" / folder).glob("*.dylib")
    binary = MachO(path.read_bytes())
    assert binary.filetype == MH_DYLIB and binary.cputype == CPU_TYPES[machine]
    # C names carry a leading underscore
    exported = {name[1:] for name in binary.exported - LINKER_SYMBOLS}
    assert exported == fmi_functions(version), exported ^ fmi_functions(version)
    assert binary.libraries == [SYSTEM_LIBRARY]
    outside = {name: library for name, library in binary.undefined.items()
               if library != SYSTEM_LIBRARY}
    assert not outside, outside
    assert {"_malloc", "_exp"} <= set(binary.undefined)  # the C library and libm: the system's


def test_the_mach_o_check_finds_a_symbol_of_no_library_and_refuses_what_is_not_mach_o(zig, tmp_path,
                                                                                      fmus):
    source = tmp_path / "mystery.c"
    source.write_text("double mystery(double);\n"
                      "double fmi2GetVersion(double x) { return mystery(x); }\n")
    dylib = tmp_path / "mystery.dylib"
    done = subprocess.run([*zig(toolchain.BY_NAME["x86_64-darwin"].zig_target), "-shared", "-o",
                           str(dylib), str(source), "-Wl,-undefined,dynamic_lookup"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    binary = MachO(dylib.read_bytes())
    assert binary.undefined["_mystery"] != SYSTEM_LIBRARY and "_fmi2GetVersion" in binary.exported
    with pytest.raises(ValueError, match="not a 64-bit Mach-O"):
        MachO((fmus["fmi3", "knee"] / "binaries" / "aarch64-linux" / "McKibbenKnee.so")
              .read_bytes())


# --- the pythonfmu FMUs' Python -------------------------------------------------------------------

def test_the_pythonfmu_fmus_say_which_python_they_need(tmp_path):
    import sys
    from xml.etree import ElementTree

    from mkctl.fmu.build import build
    built = build(tmp_path, run=False, native=False)
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    for path in built.values():
        with zipfile.ZipFile(path) as archive:
            root = ElementTree.fromstring(archive.read("modelDescription.xml"))
        expected = f"(pythonfmu FMU: the host needs Python {version} with numpy and scipy)"
        assert root.get("description").endswith(expected), root.get("description")
