"""Measurement files (model-spec section 5): read them into SI arrays, and write them.

A file is plain CSV. Optional metadata lines come first, each ``# key = value``; then one header row;
then one row of numbers per sample::

    # experiment = knee
    # baseline = model2
    # m = 10
    time_s,pe_cmd_kPa,pf_cmd_kPa,x_mm
    0.000,1693.66,100,849.92
    ...

- ``experiment`` (required): ``isotonic`` or ``knee``. ``baseline``: ``model1`` or ``model2`` (default).
  Any parameter name of :data:`mkctl.physics.params.PARAMETER_NAMES` overrides the default (SI units); an
  effect parameter (``c = 45``) makes that effect part of the baseline with that known value. The
  baseline model is chosen with ``baseline``, not ``model``. Lines starting with ``#`` that hold no
  ``=`` are free comments.
- Columns are named ``<quantity>_<unit>``, in any order (:data:`EXPERIMENTS` lists the quantities). The
  unit suffix says how to convert to SI: time ``s, ms``; pressure ``Pa, kPa, MPa, bar``; force ``N, kN``;
  length ``m, cm, mm`` (suffixes are case-insensitive). Further columns (a second sensor, a note) are
  allowed and ignored; their cells are not read.
- Every required cell must be a finite number and time must increase strictly. At least two rows.

A file that breaks a rule raises :class:`mkctl.errors.MeasurementFileError` with a one-line message
that names the file, the line (1-based) and the problem, e.g.
``data.csv line 7: column 'x_mm' is not a number: 'abc'``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import MeasurementFileError, ParameterError
from ..physics.params import PARAMETER_NAMES, Params


class Quantity(NamedTuple):
    """One column of an experiment: its name (before the unit suffix), its kind and its canonical unit."""

    name: str
    kind: str  #: "time", "pressure", "force" or "length"
    unit: str  #: the unit :func:`write_measurement` uses


class Experiment(NamedTuple):
    """The columns of one experiment: the inputs in order, then the measured output."""

    name: str
    inputs: tuple[Quantity, ...]
    output: Quantity
    description: str


#: The experiments of model-spec section 5.
EXPERIMENTS = {
    "isotonic": Experiment(
        "isotonic",
        (Quantity("time", "time", "s"), Quantity("pressure", "pressure", "kPa"), Quantity("force", "force", "N")),
        Quantity("length", "length", "mm"),
        "an actuator under a hanging load, pressure swept slowly (Fig. 5); pressure measured in the bladder",
    ),
    "knee": Experiment(
        "knee",
        (Quantity("time", "time", "s"), Quantity("pe_cmd", "pressure", "kPa"), Quantity("pf_cmd", "pressure", "kPa")),
        Quantity("x", "length", "mm"),
        "the robot leg of Fig. 6 driven by pressure commands, starting at rest in equilibrium",
    ),
}

#: Unit suffixes accepted for each kind of quantity, with the factor that converts to SI.
UNIT_FACTORS = {
    "time": {"s": 1.0, "ms": 1e-3},
    "pressure": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5},
    "force": {"N": 1.0, "kN": 1e3},
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
}

#: Baselines a file may name, and the model number (params.model) each one means.
BASELINES = {"model1": 1, "model2": 2}

#: Metadata keys besides the parameter names.
METADATA_KEYS = ("experiment", "baseline")


def unit_factor(kind: str, unit: str) -> float | None:
    """Factor from ``unit`` to SI for a quantity of ``kind``, or None if the suffix is not known."""
    for name, factor in UNIT_FACTORS[kind].items():
        if name.lower() == unit.lower():
            return factor
    return None


@dataclass(frozen=True)
class Measurement:
    """One measured record, in SI units, with the baseline it is to be compared with.

    ``inputs`` maps each input quantity's name (``time`` excluded) to its SI array; ``output`` is the
    measured output in SI; ``output_column`` and ``output_factor`` say how the file showed it
    (``output / output_factor`` gives the file's numbers back).
    """

    experiment: str
    baseline: str
    params: Params  #: the baseline's parameters: defaults, the file's overrides, model from ``baseline``
    overrides: dict  #: the parameter values the file gives, by name (SI)
    time: np.ndarray
    inputs: dict
    output: np.ndarray
    output_column: str
    output_factor: float
    source: str = "<memory>"
    extra_columns: tuple = field(default=())

    @property
    def samples(self) -> int:
        return int(self.time.size)

    @property
    def output_unit(self) -> str:
        """The unit of the output column, as the file wrote it (the suffix of ``output_column``)."""
        return self.output_column.rsplit("_", 1)[1]

    def to_file_units(self, values_si):
        """Output values (or errors) in the units of the file's output column."""
        return np.asarray(values_si, dtype=float) / self.output_factor


def read_measurement(path) -> Measurement:
    """Read a measurement file (model-spec section 5); raise MeasurementFileError for any broken rule."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise MeasurementFileError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise MeasurementFileError(f"{path}: is a folder, not a measurement file") from None
    except UnicodeDecodeError:
        raise MeasurementFileError(f"{path}: not a text file (it is not UTF-8)") from None
    except OSError as error:
        raise MeasurementFileError(f"{path}: cannot be read ({error.strerror})") from None
    return parse_measurement(text, str(path))


def parse_measurement(text: str, source: str = "<text>") -> Measurement:
    """Parse the text of a measurement file; ``source`` names it in error messages."""
    def fail(line_number, message):
        where = f"{source} line {line_number}" if line_number else source
        raise MeasurementFileError(f"{where}: {message}")

    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        fail(1, "the file is empty (no metadata, header or data)")

    metadata: dict[str, tuple[str, int]] = {}
    header_index = None
    for index, raw in enumerate(lines):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith("#"):
            header_index = index
            break
        body = line[1:].strip()
        if "=" not in body:
            continue  # a free comment
        key, value = (part.strip() for part in body.split("=", 1))
        if not key:
            fail(index + 1, "metadata line has no key before '='")
        if key in metadata:
            fail(index + 1, f"metadata key {key!r} given twice (first on line {metadata[key][1]})")
        if key == "model":
            fail(index + 1, "choose the model with 'baseline = model1' or 'baseline = model2', not 'model'")
        if key not in METADATA_KEYS and key not in PARAMETER_NAMES:
            fail(index + 1, f"unknown metadata key {key!r} (known: experiment, baseline and the parameter "
                            f"names {', '.join(n for n in PARAMETER_NAMES if n != 'model')})")
        metadata[key] = (value, index + 1)
    if header_index is None:
        fail(len(lines) + 1, "no header row after the metadata (the file holds only '#' lines)")

    # experiment and baseline
    if "experiment" not in metadata:
        fail(header_index + 1, "metadata '# experiment = isotonic' or '# experiment = knee' is missing "
                               "before the header")
    name, name_line = metadata["experiment"]
    if name not in EXPERIMENTS:
        fail(name_line, f"unknown experiment {name!r} (known: {', '.join(EXPERIMENTS)})")
    experiment = EXPERIMENTS[name]
    baseline, baseline_line = metadata.get("baseline", ("model2", None))
    if baseline not in BASELINES:
        fail(baseline_line, f"unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")

    # parameters
    overrides: dict[str, float] = {}
    for key, (value, line_number) in metadata.items():
        if key in METADATA_KEYS:
            continue
        number = _to_float(value)
        if number is None:
            fail(line_number, f"parameter {key!r} is not a number: {value!r}")
        try:
            Params().replace(**{key: number})
        except ParameterError as error:
            fail(line_number, str(error))
        overrides[key] = number
    try:
        params = Params().replace(model=BASELINES[baseline], **overrides)
    except ParameterError as error:
        fail(None, f"metadata: {error}")

    # header
    header_line = header_index + 1
    header_text = lines[header_index]
    if "," not in header_text:
        for separator, label in ((";", "semicolons"), ("\t", "tabs")):
            if separator in header_text:
                fail(header_line, f"not comma-separated: the header row is separated by {label}; measurement "
                                  "files use commas between columns and '.' as the decimal point")
    header = [cell.strip() for cell in header_text.split(",")]
    columns: dict[str, tuple[int, float]] = {}  # quantity name -> (column index, factor to SI)
    names = [q.name for q in (*experiment.inputs, experiment.output)]
    kinds = {q.name: q.kind for q in (*experiment.inputs, experiment.output)}
    extra = []
    for position, cell in enumerate(header):
        if not cell:
            fail(header_line, f"header cell {position + 1} is empty")
        if header.index(cell) != position:
            fail(header_line, f"column {cell!r} appears twice")
        quantity, _, unit = cell.rpartition("_")
        if cell in names:
            fail(header_line, f"column {cell!r} has no unit suffix (for example "
                              f"'{cell}_{_canonical_unit(experiment, cell)}')")
        if quantity not in names:
            extra.append(cell)
            continue
        factor = unit_factor(kinds[quantity], unit)
        if factor is None:
            fail(header_line, f"column {cell!r}: unknown unit {unit!r} for {quantity} "
                              f"(use {', '.join(UNIT_FACTORS[kinds[quantity]])})")
        if quantity in columns:
            fail(header_line, f"two columns for {quantity}: {header[columns[quantity][0]]!r} and {cell!r}")
        columns[quantity] = (position, factor)
    missing = [q for q in names if q not in columns]
    if missing:
        expected = ", ".join(f"{q.name}_{q.unit}" for q in (*experiment.inputs, experiment.output))
        column = f"{missing[0]}_{_canonical_unit(experiment, missing[0])}"
        article = "an" if name[0] in "aeiou" else "a"
        units = "/".join(UNIT_FACTORS[kinds[missing[0]]])
        fail(header_line, f"missing column {column!r} (any unit {units} will do; {article} {name} file "
                          f"needs {expected})")

    # data rows
    rows: list[list[float]] = []
    row_lines: list[int] = []
    previous_time_cell = ""  # the time cell of the row before, for the "time does not increase" message
    for index in range(header_index + 1, len(lines)):
        line = lines[index].strip()
        if not line:
            continue
        if line.startswith("#"):
            fail(index + 1, "metadata and comments must come before the header row")
        cells = [cell.strip() for cell in line.split(",")]
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
            values.append(number * factor)
        time_cell = cells[columns["time"][0]]
        if rows and values[0] <= rows[-1][0]:
            fail(index + 1, f"time does not increase: {header[columns['time'][0]]} = {time_cell} after "
                            f"{previous_time_cell} on line {row_lines[-1]}")
        rows.append(values)
        row_lines.append(index + 1)
        previous_time_cell = time_cell
    if len(rows) < 2:
        fail(row_lines[-1] if rows else header_line + 1,
             f"a record needs at least 2 data rows after the header (line {header_line}), found {len(rows)}")

    data = np.array(rows, dtype=float)
    output_position = names.index(experiment.output.name)
    out_index, out_factor = columns[experiment.output.name]
    return Measurement(
        experiment=name,
        baseline=baseline,
        params=params,
        overrides=overrides,
        time=data[:, 0].copy(),
        inputs={q.name: data[:, i + 1].copy() for i, q in enumerate(experiment.inputs[1:])},
        output=data[:, output_position].copy(),
        output_column=header[out_index],
        output_factor=out_factor,
        source=source,
        extra_columns=tuple(extra),
    )


def _canonical_unit(experiment: Experiment, quantity: str) -> str:
    return next(q.unit for q in (*experiment.inputs, experiment.output) if q.name == quantity)


def _to_float(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


#: Significant digits of the numbers :func:`write_measurement` writes.
DIGITS = 12


def round_to_file(values, quantity: Quantity):
    """SI values as they come back from a file written by :func:`write_measurement` (rounded to DIGITS)."""
    factor = UNIT_FACTORS[quantity.kind][quantity.unit]
    scaled = np.asarray(values, dtype=float) / factor
    return np.array([float(f"{v:.{DIGITS}g}") for v in scaled]) * factor


def write_measurement(path, experiment: str, time, inputs: dict, output, metadata: dict | None = None,
                      baseline: str | None = None, comments: tuple[str, ...] = ()) -> Path:
    """Write a measurement file in the canonical units (s, kPa, N, mm); arrays are SI.

    ``inputs`` maps the experiment's input names (``pressure, force`` or ``pe_cmd, pf_cmd``) to arrays;
    ``metadata`` holds parameter overrides (SI) for the baseline; ``comments`` become free ``#`` lines.
    Returns the path written.
    """
    if experiment not in EXPERIMENTS:
        raise MeasurementFileError(f"unknown experiment {experiment!r} (known: {', '.join(EXPERIMENTS)})")
    spec = EXPERIMENTS[experiment]
    quantities = (*spec.inputs, spec.output)
    arrays = [np.asarray(time, dtype=float)] + [np.asarray(inputs[q.name], dtype=float) for q in spec.inputs[1:]]
    arrays.append(np.asarray(output, dtype=float))
    scaled = np.column_stack([a / UNIT_FACTORS[q.kind][q.unit] for a, q in zip(arrays, quantities)])
    number = "{:.%dg}" % DIGITS
    lines = [f"# {text}" for text in comments]
    lines.append(f"# experiment = {experiment}")
    if baseline is not None:
        lines.append(f"# baseline = {baseline}")
    for key, value in (metadata or {}).items():
        lines.append(f"# {key} = {value!r}")
    lines.append(",".join(f"{q.name}_{q.unit}" for q in quantities))
    lines.extend(",".join(number.format(v) for v in row) for row in scaled)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
