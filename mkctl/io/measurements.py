"""Measurement files (model-spec section 5): read them into SI arrays, and write them.

A file is plain CSV. Optional metadata lines come first, each ``# key = value``; then one header row;
then one row of numbers per sample::

    # experiment = knee
    # baseline = model2
    # m = 10
    time_s,pe_cmd_kPa,pf_cmd_kPa,x_mm
    0.000,1693.66,100,849.92
    ...

- ``experiment`` (required): ``isotonic``, ``knee`` or ``isometric`` (:data:`EXPERIMENTS` lists their
  columns). ``baseline``: ``model1`` or ``model2`` (default). Any parameter name of
  :data:`mkctl.physics.params.PARAMETER_NAMES` overrides the default (SI units); an effect parameter
  (``c = 45``) makes that effect part of the baseline with that known value. The baseline model is chosen
  with ``baseline``, not ``model``. Metadata is checked as a whole once it is all read, so a file that sets
  both ``L0`` and ``b`` is judged on the pair. Lines starting with ``#`` that hold no ``=`` are free comments.
- A constant sensor offset of any column may be declared as ``<quantity>_offset_<unit> = value``
  (``x_offset_mm = 12``, ``beta_offset_deg = -1.5``, ``force_offset_N = 0.4``): the sensor read
  ``true + offset``, and the reader subtracts it.
- Columns are named ``<quantity>_<unit>``, in any order. The unit suffix says how to convert to SI:
  time ``s, ms``; pressure ``Pa, kPa, MPa, bar, psi``; force ``N, kN``; length ``m, cm, mm, in``; angle
  ``deg, rad`` (suffixes are case-insensitive). Further columns (a second sensor, a note) are allowed and
  ignored; their cells are not read.
- A knee file has one measured output: ``x`` (hip height) or ``beta`` (the interior knee angle, what a joint
  encoder reads), and may hold measured bladder pressures ``pe``, ``pf`` beside the commands.
- An isometric file (blocked-force test) has ``length, pressure, force``, optionally ``time`` first and a
  ``branch`` column (``up``/``down``); without it the branch follows from the pressure's direction in time
  order within each length (which needs ``time``).
- A mechanism record (``experiment = mechanism``, model-spec 5d) names its mechanism (``mechanism = hanging_mass``,
  ``pulley_joint``, ``knee`` or ``FILE.py``) and has ``time``, a command per muscle (``p1_cmd``, ``p2_cmd`` or the
  muscle's name, ``muscle1_cmd``), optional measured pressures (``p1`` or ``muscle1``) and the coordinate (``q`` or
  its name, ``theta``, ``L``) in a length or angle unit (:func:`mechanism_experiment`). Its metadata may set the
  mechanism's own parameters (``r_p = 0.025``) and ``q0`` (SI). A record never loads code: a ``FILE.py`` it names
  is accepted only when the caller hands in that same file, loaded (``--mechanism FILE.py``: issue 30).
- A driven-length record (``experiment = actuator``) has ``time, length``, the pressure measured (``pressure``) or
  commanded (``p_cmd``), exactly one of them, and the force as output.
- A pressure record (``experiment = pressure``, model-spec 5c) has ``time``, a set-point ``p_cmd``
  or a valve's opening ``valve`` (-1..1, no unit suffix), exactly one of them, the measured gauge
  pressure ``p`` and optionally a moving ``length``; its metadata may give the settings
  ``length_<unit>`` (held), ``load_<unit>`` (free under a load) and ``supply_<unit>``
  (:data:`SETTINGS`; the supply is required with ``valve``). The rig's numbers (``P_supply``,
  ``V_dead``, ``T_air``, ``k_poly``: ``Parameter.rig``) are known values; a valve's own values
  switch ``valve_flow`` on, and a ``valve`` column puts it in the baseline.
- Every required cell must be a finite number and time must increase strictly. At least two rows.

A file that breaks a rule raises :class:`mkctl.errors.MeasurementFileError` with a one-line message
that names the file, the line (1-based) and the problem, e.g.
``data.csv line 7: column 'x_mm' is not a number: 'abc'``.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..errors import MeasurementFileError, MkctlError, ParameterError
from ..physics import effects as effects_registry
from ..physics.params import DEFAULT, PARAMETER_NAMES, Params
from .record_format import (  # noqa: F401 (re-exported: the format's names)
    BASELINES, BRANCHES, EXPERIMENTS, LARGEST, MECHANISM_KEYS, METADATA_KEYS, SETTING_EXPERIMENTS,
    SETTINGS, UNIT_FACTORS, Experiment, Measurement, Quantity, mechanism_experiment, setting_of,
    unit_factor)
from .text import read_user_text, write_text_atomic




# --- reading --------------------------------------------------------------------------------------

def read_measurement(path, base: Params = DEFAULT, mechanism=None) -> Measurement:
    """Read a measurement file (model-spec section 5); raise MeasurementFileError for any broken rule.

    ``base``: the parameters the file's metadata overrides (default: the paper's; a muscle file's with
    ``--params``). ``mechanism``: the :class:`~mkctl.physics.mechanism.Mechanism` the user gave
    (``--mechanism``), for a mechanism record (see :func:`parse_measurement`).
    """
    text = read_user_text(path, MeasurementFileError, "a measurement file")
    return parse_measurement(text, str(path), base, mechanism)


class _Fail:
    """Raises a one-line MeasurementFileError naming the source and the line."""

    def __init__(self, source: str):
        self.source = source

    def __call__(self, line_number, message):
        where = f"{self.source} line {line_number}" if line_number else self.source
        raise MeasurementFileError(f"{where}: {message}")


def parse_measurement(text: str, source: str = "<text>", base: Params = DEFAULT, mechanism=None) -> Measurement:
    """Parse the text of a measurement file; ``source`` names it in error messages; ``base`` as in
    :func:`read_measurement`.

    ``mechanism``: for a mechanism record, the mechanism the user gave on the command line (a value, already
    loaded). Nothing in a record runs code (issue 30): its ``mechanism = NAME`` may name a built-in; its
    ``mechanism = FILE.py`` (resolved against the record's folder) is accepted only when ``mechanism`` is that
    same file, loaded by the user's ``--mechanism FILE.py``; a record without the line takes ``mechanism``.
    """
    fail = _Fail(source)
    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        fail(1, "the file is empty (no metadata, header or data)")
    metadata, header_index = _read_metadata(lines, fail)
    experiment, baseline, params, overrides, offset_items, mech = _check_metadata(
        metadata, header_index, base, fail, source, mechanism)
    columns, output, extra, header = _read_header(lines[header_index], header_index + 1, experiment, fail)
    offsets = _offsets(offset_items, experiment, columns, fail)
    data, branch, row_lines = _read_rows(lines, header_index, header, columns, experiment, fail)

    def column(name):  # SI values with the declared sensor offset removed
        return data[name] - offsets.get(name, 0.0)

    has_time = "time" in columns
    time = data["time"] if has_time else np.arange(len(row_lines), dtype=float)
    inputs = {q.name: column(q.name) for q in experiment.inputs[1:]}
    inputs.update({q.name: column(q.name) for q in experiment.optional if q.name in columns})
    if experiment.name == "isometric":
        branch = _isometric_branch(branch, inputs, has_time, row_lines, header_index, fail)
    if experiment.name == "pressure":
        params = _pressure_record_params(params, overrides, mech["settings"], columns, metadata,
                                         header_index + 1, fail)
    out_position, out_factor = columns[output.name]
    return Measurement(
        experiment=experiment.name, baseline=baseline, params=params, overrides=overrides, time=time,
        inputs=inputs, output=column(output.name), output_column=header[out_position], output_factor=out_factor,
        source=source, extra_columns=tuple(extra), output_quantity=output.name, offsets=offsets, branch=branch,
        has_time=has_time, **mech,
    )


#: A metadata line: ``# key = value`` with key an identifier (offsets: ``x_offset_mm``).
_METADATA_LINE = re.compile(r"#\s*([A-Za-z_]\w*)\s*=\s*(.*?)\s*$")
#: A value that makes a line with an unknown key metadata (to be refused) rather than prose: one number or word.
_ONE_VALUE = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[A-Za-z_][\w.+-]*")


def known_metadata_key(key: str) -> bool:
    """Whether key is metadata a file may give: experiment, baseline, a parameter name, an offset, or a mechanism
    record's ``mechanism`` and ``q0`` (its own parameters are known once its mechanism is)."""
    return (key in METADATA_KEYS or key in MECHANISM_KEYS or key in PARAMETER_NAMES
            or "_offset_" in key or setting_of(key) is not None)


def metadata_line(line: str) -> tuple[str, str] | None:
    """(key, value) of a ``#`` line that is metadata, or None for a comment.

    The rule (docs/calibrate.md, "Comments and metadata"): a line is metadata when it reads ``# key = value`` with
    key an identifier that is a known key (its value is then checked), or an unknown identifier followed by one
    number or one word (a mistyped key: refused, naming the keys it could be). Every other ``#`` line is a comment:
    one with no ``=``, a key that is not an identifier (``# supply - drop = 50 kPa``), or an unknown key followed by
    prose (``# pressure = supply minus drop``)."""
    match = _METADATA_LINE.fullmatch(line.strip())
    if match is None:
        return None
    key, value = match.groups()
    if known_metadata_key(key) or key == "model" or _ONE_VALUE.fullmatch(value):
        return key, value
    return None


def _close_keys(key: str, own: tuple = ()) -> str:
    """Known keys a mistyped one could be (difflib), as a phrase; ``own``: a mechanism record's further keys."""
    import difflib

    known = [*METADATA_KEYS, *own, *(n for n in PARAMETER_NAMES if n != "model")]
    close = [k for k in known if k.lower() == key.lower()] or difflib.get_close_matches(key, known, n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(k) for k in close)}?)" if close else ""


def _read_metadata(lines, fail) -> tuple[dict, int]:
    """The ``# key = value`` lines before the header (:func:`metadata_line`): {key: (value, line number)}, and the
    header's index."""
    metadata: dict[str, tuple[str, int]] = {}
    for index, raw in enumerate(lines):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith("#"):
            return metadata, index
        parsed = metadata_line(line)
        if parsed is None:
            continue  # a comment
        key, value = parsed
        if key in metadata:
            fail(index + 1, f"metadata key {key!r} given twice (first on line {metadata[key][1]})")
        if key == "model":
            fail(index + 1, "choose the model with 'baseline = model1' or 'baseline = model2', not 'model'")
        # unknown keys are refused once the experiment is known (_check_keys): a mechanism record's own
        # parameters are known only then
        metadata[key] = (value, index + 1)
    fail(len(lines) + 1, "no header row after the metadata (the file holds only '#' lines)")


def _check_keys(metadata: dict, own: tuple, fail) -> None:
    """Every key known: the general ones, a parameter, an offset, or (mechanism records) ``own``."""
    for key, (_, line_number) in metadata.items():
        if key in MECHANISM_KEYS and key not in own:
            fail(line_number, f"metadata key {key!r} belongs to a mechanism record ('# experiment = mechanism')")
        if not known_metadata_key(key) and key not in own:
            extra = f", {', '.join(own)}" if own else ""
            fail(line_number, f"unknown metadata key {key!r}{_close_keys(key, own)}; known: experiment, "
                              f"baseline{extra}, <column>_offset_<unit> and the parameter names "
                              f"{', '.join(n for n in PARAMETER_NAMES if n != 'model')} (a '#' line with '=' is "
                              f"metadata when its key is one word and its value one number or word)")


def _record_mechanism(metadata: dict, header_index: int, source: str, given, fail):
    """The mechanism of a mechanism record: its ``mechanism`` line checked against the one the user gave."""
    from ..physics.mechanism import BUILTIN

    if "mechanism" not in metadata:
        if given is None:
            fail(header_index + 1, "a mechanism record needs '# mechanism = " + " | ".join(BUILTIN)
                                   + " | FILE.py' before the header (or --mechanism on the command line)")
        return given
    value, line = metadata["mechanism"]
    if value in BUILTIN:
        if given is not None and given is not BUILTIN[value] and given != BUILTIN[value]:
            fail(line, f"the record names the mechanism {value!r}, the command line {given.name!r}")
        return BUILTIN[value]
    if not value.endswith(".py"):
        fail(line, f"unknown mechanism {value!r} (built-in: {', '.join(BUILTIN)}; or a FILE.py)")
    folder = Path(".") if source.startswith("<") else Path(source).parent
    wanted = (folder / value).resolve()
    loaded = getattr(given, "reload", ())
    if given is not None and len(loaded) >= 2 and Path(loaded[1]) != wanted:
        fail(line, f"the record names the mechanism file {wanted}, the command line {loaded[1]}")
    if given is None or len(loaded) < 2:
        # a record is data: it never runs a file; the user loads it knowingly
        fail(line, f"the record names the mechanism file {value!r}; a record cannot load code: give it with "
                   f"--mechanism {wanted} (or mechanism(...) in Python)")
    return given


def table_default_hint(message: str, given=(), params: Params = DEFAULT) -> str:
    """What a refusal owes to the paper's defaults: for each parameter of Table I or II that ``message`` names,
    that was not ``given`` and still has the table's value in ``params``, the sentence that says so and how to
    give one's own (``# b = ...`` in the file, or ``--params``); "" when there is none."""
    from ..physics.params import TABLE_I, TABLE_II

    hints = []
    for table, entries in (("Table I", TABLE_I), ("Table II", TABLE_II)):
        for name, quantity in entries.items():
            if (name in given or not re.search(rf"\b{re.escape(name)} = ", message)
                    or not math.isclose(getattr(params, name), quantity.value, rel_tol=1e-12)):
                continue
            hints.append(f"{name} = {quantity.value:g} {quantity.unit} is {table}'s {quantity.description} "
                         f"{name}, a default: give your muscle's with '# {name} = ...' in the file (or in the "
                         f"muscle file of --params MUSCLE.json)")
    return "; ".join(hints)


def _check_metadata(metadata: dict, header_index: int, base: Params, fail, source: str = "<text>",
                    mechanism=None):
    """Experiment, baseline and parameters, checked as a whole after all metadata is read."""
    if "experiment" not in metadata:
        _check_keys(metadata, (), fail)
        fail(header_index + 1, "metadata '# experiment = " + " | ".join(EXPERIMENTS) + "' is missing before "
                               "the header")
    name, name_line = metadata["experiment"]
    if name not in EXPERIMENTS:
        _check_keys(metadata, (), fail)
        fail(name_line, f"unknown experiment {name!r} (known: {', '.join(EXPERIMENTS)})")
    mech: dict = {}
    own: tuple = ()
    if name == "mechanism":
        mech["mechanism"] = _record_mechanism(metadata, header_index, source, mechanism, fail)
        own = (*MECHANISM_KEYS, *mech["mechanism"].parameter_names)
    elif mechanism is not None:
        fail(name_line, f"a mechanism ({getattr(mechanism, 'name', mechanism)}) was given, but this is "
                        f"{'an' if name[0] in 'aeiou' else 'a'} {name} record, not 'experiment = mechanism'")
    _check_keys(metadata, own, fail)
    baseline, baseline_line = metadata.get("baseline", ("model2", None))
    if baseline not in BASELINES:
        fail(baseline_line, f"unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")
    overrides: dict[str, float] = {}
    offsets: dict[str, tuple[float, int, str]] = {}
    own_values: dict[str, tuple[float, int]] = {}
    settings: dict[str, tuple[float, int]] = {}
    for key, (value, line_number) in metadata.items():
        if key in METADATA_KEYS or key == "mechanism" and own:
            continue
        if setting_of(key) is not None and key not in PARAMETER_NAMES:
            if name not in SETTING_EXPERIMENTS:
                fail(line_number, f"metadata key {key!r} belongs to a pressure record "
                                  "('# experiment = pressure')")
            setting, factor = setting_of(key)
            number = _to_float(value)
            if number is None or not math.isfinite(number):
                fail(line_number, f"{key!r} is not a finite number: {value!r}")
            if setting in settings:
                fail(line_number,
                     f"two values for the {setting} (first on line {settings[setting][1]})")
            if not abs(number * factor) <= LARGEST[SETTINGS[setting]]:
                fail(line_number, f"{key} = {value} is outside the range of a real rig")
            settings[setting] = (number * factor, line_number)
            continue
        number = _to_float(value)
        what = "offset" if key not in PARAMETER_NAMES else "parameter"
        if number is None:
            fail(line_number, f"{what} {key!r} is not a number: {value!r}")
        if not math.isfinite(number):
            fail(line_number, f"{what} {key!r} is not a finite number: {value!r}")
        if key in PARAMETER_NAMES:
            overrides[key] = number
        elif key in own:
            own_values[key] = (number, line_number)
        else:
            offsets[key] = (number, line_number, key)
    try:
        params = base.replace(model=BASELINES[baseline], **overrides)
    except ParameterError as error:
        # name the lines that set the parameters the error speaks of, so that a pair (L0 and b) is found
        lines = sorted(metadata[k][1] for k in overrides if re.search(rf"\b{k}\b", str(error)))
        hint = table_default_hint(str(error), overrides, base)
        fail(lines[0] if len(lines) == 1 else None,
             f"{error}" + (f" (set on lines {', '.join(map(str, lines))})" if len(lines) > 1 else "")
             + (f" ({hint})" if hint else ""))
    if name == "pressure":
        params, overrides, mech = _pressure_settings(params, overrides, settings, metadata, fail)
    if name != "mechanism":
        return EXPERIMENTS[name], baseline, params, overrides, offsets, mech
    return (mechanism_experiment(mech["mechanism"]), baseline, params, overrides, offsets,
            _mechanism_values(mech["mechanism"], params, own_values, fail))


def _pressure_settings(params: Params, overrides: dict, settings: dict, metadata: dict, fail):
    """A pressure record's settings (model-spec 5c): the supply becomes the known ``P_supply``, the
    held length must lie in 0 < L < b, a load excludes a held length; a value of an effect that is
    not the rig's own (``C_fill``, not ``P_supply``) switches its effect on, as an effect parameter
    does in any record.
    """
    if "supply" in settings:
        if "P_supply" in overrides:
            fail(
                settings["supply"][1],
                f"the supply is given twice (P_supply on line {metadata['P_supply'][1]})",
            )
        overrides = {**overrides, "P_supply": settings["supply"][0]}
    if "length" in settings and "load" in settings:
        fail(
            settings["load"][1],
            f"a held length (line {settings['length'][1]}) and a load: a pressure record's "
            "muscle is held, moving or free under a load, one of them",
        )
    if "length" in settings and not 0 < settings["length"][0] < params.b:
        fail(
            settings["length"][1],
            f"the held length {settings['length'][0] * 1e3:g} mm must lie between 0 and "
            f"the braid length b = {params.b * 1e3:g} mm",
        )
    if "load" in settings and settings["load"][0] < 0:
        fail(settings["load"][1], "the load must not be negative (it pulls the muscle)")
    switched = {}
    for effect in effects_registry.all_effects():
        q = effect.switch_parameter
        if not q.switch or q.name in overrides:
            continue
        given = [
            n for n in overrides if n in effect.parameter_names and not effect.parameter(n).rig
        ]
        if given:
            switched[q.name] = q.on_value
    try:
        params = params.replace(**overrides, **switched)
    except ParameterError as error:
        fail(None, str(error))
    return params, overrides, {"settings": {k: v for k, (v, _) in settings.items()}}


def _pressure_record_params(
    params: Params,
    overrides: dict,
    settings: dict,
    columns: dict,
    metadata: dict,
    header_line: int,
    fail,
) -> Params:
    """A pressure record's columns against its settings: a moving length is not also held, and a
    record driven by valve openings names its supply and has the valve in its baseline (the effect a
    command's opening comes from: it cannot be simulated without it, model-spec 5c)."""
    if "length" in columns and ("length" in settings or "load" in settings):
        key = next(k for k in metadata if setting_of(k) and setting_of(k)[0] in ("length", "load"))
        fail(
            metadata[key][1],
            f"'{key}' and a length column: a pressure record's muscle is held, moving or "
            "free under a load, one of them",
        )
    if "valve" not in columns:
        return params
    if "P_supply" not in overrides:
        fail(
            header_line,
            "a record driven by valve openings needs its supply pressure: '# supply_kPa = ...' "
            "before the header",
        )
    valves = {
        e.switch_parameter.name: e.switch_parameter.on_value
        for e in effects_registry.all_effects()
        if e.valve_opening is not None and e.switch_parameter.switch and not e.is_on(params)
    }
    return params.replace(**valves) if valves else params


def _mechanism_values(mechanism, params: Params, values: dict, fail) -> dict:
    """The mechanism, its own values (checked against their bounds) and q0 (inside its stops)."""
    q0 = values.pop("q0", None)
    own = {k: v for k, (v, _) in values.items()}
    try:
        bound = mechanism.bind(params, **own)
        low, high = mechanism.stop_positions(bound)
    except MkctlError as error:
        lines = [line for k, (_, line) in values.items() if re.search(rf"\b{k}\b", str(error))]
        fail(lines[0] if len(lines) == 1 else None, f"mechanism {mechanism.name}: {error}")
    if q0 is not None and not low <= q0[0] <= high:
        fail(q0[1], f"q0 = {q0[0]:g} {mechanism.unit} is outside the stops of {mechanism.name} "
                    f"({low:g}, {high:g}) {mechanism.unit} (q0 is in SI: m or rad)")
    return {"mechanism": mechanism, "mechanism_values": own, "q0": None if q0 is None else q0[0]}


def _read_header(header_text: str, header_line: int, experiment: Experiment, fail):
    """Columns {quantity: (index, factor)}, the output quantity the file has, extra columns, header cells."""
    if "," not in header_text:
        for separator, label in ((";", "semicolons"), ("\t", "tabs")):
            if separator in header_text:
                fail(header_line, f"not comma-separated: the header row is separated by {label}; measurement "
                                  "files use commas between columns and '.' as the decimal point")
    header = _cells(header_text)
    while len(header) > 1 and not header[-1]:  # a spreadsheet's trailing comma: no column there
        header.pop()
    kinds = {q.name: q.kind for q in experiment.quantities}
    aliases = dict(experiment.aliases)
    columns: dict[str, tuple[int, float]] = {}
    extra = []
    for position, cell in enumerate(header):
        if not cell:
            fail(header_line, f"header cell {position + 1} is empty")
        if header.index(cell) != position:
            fail(header_line, f"column {cell!r} appears twice")
        if experiment.name == "isometric" and cell == "branch":
            columns["branch"] = (position, 1.0)
            continue
        # a unitless quantity: the valve
        if UNIT_FACTORS.get(kinds.get(cell), {}).get("") is not None:
            if cell in columns:
                fail(header_line, f"column {cell!r} appears twice")
            columns[cell] = (position, 1.0)
            continue
        quantity, _, unit = cell.rpartition("_")
        quantity = aliases.get(quantity, quantity)
        if cell in kinds or cell in aliases:
            fail(header_line, f"column {cell!r} has no unit suffix (for example "
                              f"'{cell}_{_canonical_unit(experiment, aliases.get(cell, cell))}')")
        if quantity not in kinds:
            extra.append(cell)
            continue
        factor = unit_factor(kinds[quantity], unit)
        if factor is None:
            fail(header_line, f"column {cell!r}: unknown unit {unit!r} for {quantity} "
                              f"(use {', '.join(UNIT_FACTORS[kinds[quantity]])})")
        if quantity in columns:
            fail(header_line, f"two columns for {quantity}: {header[columns[quantity][0]]!r} and {cell!r}")
        columns[quantity] = (position, factor)
    required = [q for q in experiment.inputs if q.name in columns or q.name != "time" or experiment.time_required]
    missing = [q for q in required if q.name not in columns]
    outputs = [q for q in experiment.outputs if q.name in columns]
    if not missing and not outputs:
        missing = [experiment.output]
    if missing:
        expected = ", ".join(f"{q.name}_{q.unit}" for q in (*experiment.inputs, experiment.output))
        alternatives = " or ".join(f"{q.name}_{q.unit}" for q in experiment.outputs)
        q = missing[0]
        article = "an" if experiment.name[0] in "aeiou" else "a"
        if q in experiment.outputs and len(experiment.outputs) > 1:
            fail(header_line, f"missing the measured output: a column {alternatives} (any unit of its kind will "
                              f"do; {article} {experiment.name} file needs {expected})")
        fail(header_line, f"missing column {q.name + '_' + q.unit!r} (any unit {'/'.join(UNIT_FACTORS[q.kind])} "
                          f"will do; {article} {experiment.name} file needs {expected})")
    if len(outputs) > 1:
        fail(header_line, f"two measured outputs {header[columns[outputs[0].name][0]]!r} and "
                          f"{header[columns[outputs[1].name][0]]!r}: a {experiment.name} file has one of them")
    if experiment.one_of:
        present = [name for name in experiment.one_of if name in columns]
        wanted = " or ".join(column_name(q) for q in experiment.quantities
                             if q.name in experiment.one_of)
        if len(present) != 1:
            article = "an" if experiment.name[0] in "aeiou" else "a"
            fail(header_line, (f"missing column {wanted}" if not present else
                               f"two columns {' and '.join(header[columns[n][0]] for n in present)}")
                 + f": {article} {experiment.name} file has exactly one of {wanted}")
    return columns, outputs[0], extra, header


def _offsets(items: dict, experiment: Experiment, columns: dict, fail) -> dict[str, float]:
    """Declared sensor offsets ``<quantity>_offset_<unit>``, in SI, by quantity."""
    kinds = {q.name: q.kind for q in experiment.quantities}
    offsets = {}
    for key, (value, line_number, _) in items.items():
        quantity, _, unit = key.partition("_offset_")
        if quantity not in kinds:
            fail(line_number, f"unknown metadata key {key!r}: an offset is <quantity>_offset_<unit> with a "
                              f"quantity of this file ({', '.join(q for q in kinds if q in columns and q != 'time')})")
        factor = unit_factor(kinds[quantity], unit)
        if factor is None:
            fail(line_number, f"offset {key!r}: unknown unit {unit!r} for {quantity} "
                              f"(use {', '.join(UNIT_FACTORS[kinds[quantity]])})")
        if quantity not in columns:
            fail(line_number, f"offset {key!r} for a column the file does not have")
        if not abs(value * factor) <= LARGEST[kinds[quantity]]:
            fail(line_number, f"offset {key!r} = {value:g} {unit} is outside the range of a real sensor "
                              f"(at most {_in_unit(LARGEST[kinds[quantity]], factor)} {unit} either way)")
        offsets[quantity] = value * factor
    return offsets


def _in_unit(si: float, factor: float) -> str:
    """An SI magnitude shown in a file's unit (``factor``: the unit in SI)."""
    return f"{si / factor:g}"


def _read_rows(lines, header_index: int, header, columns: dict, experiment: Experiment, fail):
    """Numbers by quantity (SI, before offsets), the branch cells (isometric) and each row's line number."""
    names = [q for q in columns if q != "branch"]
    kinds = {q.name: q.kind for q in experiment.quantities}
    rows: list[list[float]] = []
    branches: list[int] = []
    row_lines: list[int] = []
    previous_time_cell = ""
    for index in range(header_index + 1, len(lines)):
        line = lines[index].strip()
        if not line:
            continue
        if line.startswith("#"):
            fail(index + 1, "metadata and comments must come before the header row")
        cells = _cells(line)
        while len(cells) > len(header) and not cells[-1]:  # trailing commas, as spreadsheets write them
            cells.pop()
        if len(cells) != len(header):
            fail(index + 1, f"expected {len(header)} cells as in the header, found {len(cells)}")
        values = []
        for quantity in names:
            position, factor = columns[quantity]
            cell = cells[position]
            number = _to_float(cell)
            if number is None:
                fail(index + 1, f"column {header[position]!r} is not a number: {cell!r}")
            if not math.isfinite(number):
                fail(index + 1, f"column {header[position]!r} is not a finite number: {cell!r}")
            largest = LARGEST[kinds[quantity]]
            if kinds[quantity] == "opening" and not abs(number) <= largest:
                fail(index + 1, f"column {header[position]!r} = {cell} must lie in [-1, 1] (the "
                                "valve's opening: 1 open to the supply, 0 closed, -1 open to the "
                                "exhaust)")
            if not abs(number * factor) <= largest:
                fail(index + 1, f"column {header[position]!r} = {cell} is outside the range of a real "
                                f"{kinds[quantity]} sensor (at most {_in_unit(largest, factor)} "
                                f"{header[position].rpartition('_')[2]} either way)")
            values.append(number * factor)
        if "branch" in columns:
            cell = cells[columns["branch"][0]].lower()
            if cell not in BRANCHES:
                fail(index + 1, f"column 'branch' must be up or down, got {cells[columns['branch'][0]]!r}")
            branches.append(BRANCHES[cell])
        if "time" in columns:
            position = columns["time"][0]
            t = values[names.index("time")]
            if rows and t <= rows[-1][names.index("time")]:
                fail(index + 1, f"time does not increase: {header[position]} = {cells[position]} after "
                                f"{previous_time_cell} on line {row_lines[-1]}")
            previous_time_cell = cells[position]
        rows.append(values)
        row_lines.append(index + 1)
    if len(rows) < 2:
        fail(row_lines[-1] if rows else header_index + 2,
             f"a record needs at least 2 data rows after the header (line {header_index + 1}), found {len(rows)}")
    table = np.array(rows, dtype=float)
    data = {name: table[:, i].copy() for i, name in enumerate(names)}
    return data, (np.array(branches) if branches else None), row_lines


def _isometric_branch(branch, inputs: dict, has_time: bool, row_lines, header_index, fail) -> np.ndarray:
    """The branch of every isometric row: the file's, or inferred from the pressure's direction per length."""
    length, pressure = inputs["length"], inputs["pressure"]
    if np.ptp(pressure) == 0:
        fail(header_index + 1, "an isometric file needs more than one pressure (it holds only "
                               f"{pressure[0] / 1e3:g} kPa): the force must be measured as the pressure changes")
    if branch is not None:
        return branch
    if not has_time:
        fail(header_index + 1, "an isometric file without a 'branch' column needs 'time_s' to tell the rising "
                               "pressure (up) from the falling one (down)")
    inferred = np.zeros(length.size, dtype=int)
    for value in np.unique(length):
        rows = np.flatnonzero(length == value)
        p = pressure[rows]
        step = np.diff(p)
        direction = np.sign(np.concatenate([step[:1], step]))  # the first row follows the second's direction
        # a held pressure (no change) keeps the direction it came with
        for i in range(1, direction.size):
            if direction[i] == 0:
                direction[i] = direction[i - 1]
        if direction.size and direction[0] == 0:
            nonzero = direction[direction != 0]
            direction[direction == 0] = nonzero[0] if nonzero.size else 1
        inferred[rows] = direction
    return inferred


def _cells(line: str) -> list[str]:
    """A row's cells, stripped of spaces and of the double quotes some spreadsheets put around every cell."""
    cells = []
    for cell in line.split(","):
        cell = cell.strip()
        if len(cell) >= 2 and cell[0] == cell[-1] == '"':
            cell = cell[1:-1].strip()
        cells.append(cell)
    return cells


def _canonical_unit(experiment: Experiment, quantity: str) -> str:
    return next(q.unit for q in experiment.quantities if q.name == quantity)


def column_name(q: Quantity) -> str:
    """A quantity's column in its canonical unit (``p_kPa``; a unitless one by its name:
    ``valve``)."""
    return f"{q.name}_{q.unit}" if q.unit else q.name


def _to_float(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


# --- records from arrays (notebooks) ---------------------------------------------------------------

def measurement_from_arrays(experiment: str, time, inputs: dict, output, output_column: str | None = None,
                            params: dict | None = None, baseline: str = "model2", branch=None,
                            base: Params = DEFAULT, source: str = "<arrays>", mechanism=None,
                            settings: dict | None = None) -> Measurement:
    """A :class:`Measurement` from SI arrays, checked by the same rules as a file (it is written to text and
    parsed, so nothing can differ from reading a file).

    Parameters: experiment ``isotonic | knee | isometric``; time [s] (None for an isometric record
    with ``branch``); inputs {name: SI array} (``pressure, force``; ``pe_cmd, pf_cmd`` and
    optionally ``pe, pf``; ``length, pressure``); output, the measured output in SI; output_column,
    which output column it is (default the experiment's canonical one, e.g. ``x_mm``; ``beta_deg``
    for a knee angle); params: known parameters (SI) as in a file's metadata; branch: isometric
    +1/-1 (or "up"/"down") per row; mechanism: a mechanism record's
    :class:`~mkctl.physics.mechanism.Mechanism` (inputs ``p1_cmd``, ...; output ``q``); settings: a
    pressure record's (``{"supply_kPa": 620.0}``, :func:`write_measurement`).
    """
    import io
    text = io.StringIO()
    write_measurement(text, experiment, time, inputs, output, metadata=params, baseline=baseline,
                      output_column=output_column, branch=branch, mechanism=mechanism,
                      settings=settings)
    return parse_measurement(text.getvalue(), source, base, mechanism)


def measurement_from_dataframe(frame, experiment: str, params: dict | None = None, baseline: str = "model2",
                               base: Params = DEFAULT, source: str = "<DataFrame>", mechanism=None) -> Measurement:
    """A :class:`Measurement` from a pandas DataFrame whose columns are named as in a file (``time_s``,
    ``pe_cmd_kPa``, ``x_mm``, ...; units from the suffixes), with metadata given as arguments (``mechanism``: a
    mechanism record's, loaded)."""
    lines = [f"# experiment = {experiment}", f"# baseline = {baseline}"]
    if mechanism is not None:
        lines.append(f"# mechanism = {mechanism_reference(mechanism)}")
    lines += [f"# {key} = {value!r}" for key, value in (params or {}).items()]
    lines.append(",".join(str(c) for c in frame.columns))
    for row in frame.itertuples(index=False):
        lines.append(",".join(repr(float(v)) if not isinstance(v, str) else v for v in row))
    return parse_measurement("\n".join(lines) + "\n", source, base, mechanism)


# --- writing --------------------------------------------------------------------------------------

#: Significant digits of the numbers :func:`write_measurement` writes.
DIGITS = 12


def round_to_file(values, quantity: Quantity):
    """SI values as they come back from a file written by :func:`write_measurement` (rounded to DIGITS)."""
    factor = UNIT_FACTORS[quantity.kind][quantity.unit]
    scaled = np.asarray(values, dtype=float) / factor
    return np.array([float(f"{v:.{DIGITS}g}") for v in scaled]) * factor


def _quantity(experiment: Experiment, column: str) -> Quantity:
    """The output quantity named by a column such as ``x_mm`` or ``beta_deg`` (its unit becomes canonical)."""
    name, _, unit = column.rpartition("_")
    for q in experiment.outputs:
        if q.name == name:
            if unit_factor(q.kind, unit) is None:
                raise MeasurementFileError(f"output column {column!r}: unknown unit {unit!r} for {name}")
            exact = next(u for u in UNIT_FACTORS[q.kind] if u.lower() == unit.lower())
            return Quantity(name, q.kind, exact)
    names = ", ".join(f"{q.name}_{q.unit}" for q in experiment.outputs)
    raise MeasurementFileError(f"{column!r} is not an output of a {experiment.name} file (use {names})")


def experiment_columns(experiment: str, mechanism=None) -> Experiment:
    """The :class:`Experiment` of a record: :data:`EXPERIMENTS`'s, or a mechanism record's
    (:func:`mechanism_experiment`)."""
    if experiment not in EXPERIMENTS:
        raise MeasurementFileError(f"unknown experiment {experiment!r} (known: {', '.join(EXPERIMENTS)})")
    if experiment == "mechanism":
        if mechanism is None:
            raise MeasurementFileError("a mechanism record needs its mechanism")
        return mechanism_experiment(mechanism)
    return EXPERIMENTS[experiment]


def mechanism_reference(mechanism, folder=None) -> str:
    """What a record's ``mechanism = ...`` line says: a built-in's name, or the file's path relative to the
    record's ``folder`` (absolute where there is none)."""
    if not mechanism.reload:
        return mechanism.name
    import os

    file = Path(mechanism.reload[1])
    try:
        reference = str(file) if folder is None else os.path.relpath(file, Path(folder).resolve())
    except ValueError:  # another drive
        reference = str(file)
    if not reference.isprintable():  # one line of metadata, nothing more
        raise MeasurementFileError(f"the mechanism file's path {reference!r} cannot be written into a record "
                                   "(a control character); rename it")
    return reference


def write_measurement(path, experiment: str, time, inputs: dict, output, metadata: dict | None = None,
                      baseline: str | None = None, comments: tuple[str, ...] = (), output_column: str | None = None,
                      branch=None, mechanism=None, settings: dict | None = None):
    """Write a measurement file in the canonical units (s, kPa, N, mm, deg); arrays are SI.

    ``inputs`` maps the experiment's input names (``pressure, force``; ``pe_cmd, pf_cmd`` and
    optionally the measured ``pe, pf``; ``length, pressure``) to arrays; ``output_column`` picks the
    output (default the canonical one; ``beta_deg`` for a knee angle); ``metadata`` holds parameter
    overrides (SI) and offsets; ``comments`` become free ``#`` lines; ``time`` may be None for an
    isometric record with ``branch`` (+1/-1 or "up"/"down" per row). ``path`` may be an open text
    stream. ``mechanism``: a mechanism record's mechanism (written as ``mechanism = NAME`` or its
    file's path relative to the record). ``settings``: a pressure record's metadata in the file's
    units (``{"supply_kPa": 620.0, "length_mm": 180.0}``). Returns the path written.
    """
    spec = experiment_columns(experiment, mechanism)
    out = spec.output if output_column is None else _quantity(spec, output_column)
    quantities = [q for q in spec.inputs if q.name != "time" or time is not None]
    quantities += [q for q in spec.optional if q.name in inputs]
    arrays = [np.asarray(time if q.name == "time" else inputs[q.name], dtype=float) for q in quantities]
    quantities.append(out)
    arrays.append(np.asarray(output, dtype=float))
    scaled = np.column_stack([a / UNIT_FACTORS[q.kind][q.unit] for a, q in zip(arrays, quantities)])
    bad = ~np.isfinite(scaled)
    if bad.any():  # nothing non-finite is written: a file mkctl writes is one it reads back
        row, column = (int(i[0]) for i in np.nonzero(bad))
        q = quantities[column]
        raise MeasurementFileError(f"cannot write {scaled[row, column]} in column {q.name}_{q.unit} (row {row + 1}): "
                                   "a measurement file holds finite numbers only")
    number = "{:.%dg}" % DIGITS
    lines = [f"# {text}" for text in comments]
    lines.append(f"# experiment = {experiment}")
    for key, value in (settings or {}).items():
        lines.append(f"# {key} = {value!r}")
    if experiment == "mechanism":
        folder = None if hasattr(path, "write") else Path(path).parent
        lines.append(f"# mechanism = {mechanism_reference(mechanism, folder)}")
    if baseline is not None:
        lines.append(f"# baseline = {baseline}")
    for key, value in (metadata or {}).items():
        lines.append(f"# {key} = {value!r}")
    header = [column_name(q) for q in quantities]
    branch_cells = None
    if branch is not None:
        signs = {1: "up", -1: "down", "up": "up", "down": "down"}
        branch_cells = [signs[b if isinstance(b, str) else int(b)] for b in branch]
        header.append("branch")
    lines.append(",".join(header))
    for i, row in enumerate(scaled):
        cells = [number.format(v) for v in row]
        if branch_cells is not None:
            cells.append(branch_cells[i])
        lines.append(",".join(cells))
    if hasattr(path, "write"):
        path.write("\n".join(lines) + "\n")
        return path
    return write_text_atomic(path, "\n".join(lines) + "\n")
