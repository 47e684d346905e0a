"""Many runs at once: a small engine over Dask, and the diagnosis of many records with it.

:func:`run_batch` runs one plain function over many items on a ``dask.distributed`` cluster: by default
a :class:`distributed.LocalCluster` of ``jobs`` worker processes on this machine (one thread each: the
model is plain Python and numpy, and processes sidestep the GIL), or an existing cluster when given the
address of its scheduler (``tcp://HOST:PORT``). Both are the same code path: a ``distributed.Client``
submits one task per item and collects the results *as they complete*, so that a caller can write each
one down at once (``on_result``) and a worker that dies loses no finished result (Dask runs the lost
tasks again on another worker). An item whose function raises is an :class:`Outcome` with an error
message, not the end of the batch.

:func:`diagnose_batch` is the diagnosis of many measurement files (``mkctl diagnose FILE...``): one
JSON report per record, written as it completes, a summary table (CSV, rewritten after every record,
and on screen) and a figure that compares the records' parameters (:class:`BatchResult`).

A remote cluster needs mkctl importable on its workers (the functions are sent by reference) and, for
:func:`diagnose_batch`, the files readable there under the same paths (a shared folder).

Example
-------
>>> from mkctl.analysis.batch import run_batch
>>> outcomes = run_batch(abs, [-1, 2, -3], jobs=2, progress=False)   # doctest: +SKIP
>>> [o.value for o in outcomes]                                       # doctest: +SKIP
[1, 2, 3]
"""
from __future__ import annotations

import contextlib
import csv
import glob
import json
import logging
import math
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable


from ..errors import MkctlError
from ..io.text import write_text_atomic
from ..results import Result
from ..physics import effects as registry

#: Seconds to wait for an existing scheduler before giving up (a typo should not hang the command).
CONNECT_TIMEOUT_S = 5.0
#: Name of the summary table and the comparison figure that :func:`diagnose_batch` writes.
SUMMARY_CSV = "batch_summary.csv"
SUMMARY_PNG = "batch_parameters.png"


class BatchError(MkctlError, ValueError):
    """A batch that cannot run as asked: no files, an unreachable scheduler, a bad number of jobs."""


def default_jobs() -> int:
    """Worker processes of the default local cluster: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


@dataclass
class Outcome:
    """What became of one item: its value, or the one-line message of what went wrong."""

    index: int  #: position of the item in the batch
    item: Any
    value: Any = None
    error: str | None = None  #: None when the function returned
    seconds: float = math.nan  #: time the function took on its worker [s]

    @property
    def ok(self) -> bool:
        return self.error is None


def error_message(error: BaseException) -> str:
    """One line for an error raised on a worker: a user's mistake as is, anything else with its type."""
    if isinstance(error, MkctlError):
        return str(error)
    if isinstance(error, OSError) and error.strerror:
        return f"cannot use {error.filename}: {error.strerror}" if error.filename else error.strerror
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0] if text else ''}".rstrip(": ")


def _call(function: Callable, item, model=None) -> tuple:
    """Run on a worker: (value, error message or None, seconds). Never raises for the function's errors.

    ``model``: the submitting process's model (:func:`mkctl.physics.effects.current`: the built-in effects and the
    user's, model-spec section 4c), current on the worker while the function runs, so that it knows their effects
    and parameters as the submitter does (the effects travel with the model: no file is read again)."""
    start = time.perf_counter()
    try:
        with registry.using(model or registry.current()):
            value, error = function(item), None
    except Exception as exc:  # noqa: BLE001 - one bad item must not stop the batch
        value, error = None, error_message(exc)
    return value, error, time.perf_counter() - start


#: Dask's configuration keys of a client's TLS files (what :class:`distributed.security.Security` reads), by the
#: ``--tls-*`` option that sets each.
TLS_CONFIG = {"ca": "distributed.comm.tls.ca-file", "cert": "distributed.comm.tls.client.cert",
              "key": "distributed.comm.tls.client.key"}


def tls_config(ca=None, cert=None, key=None) -> dict:
    """Dask configuration for a ``tls://`` scheduler from the ``--tls-ca/--tls-cert/--tls-key`` files (PEM): the
    keys of :data:`TLS_CONFIG` (absolute paths) and ``distributed.comm.require-encryption``; {} with none given
    (then Dask's own configuration counts: ``~/.config/dask/*.yaml`` or ``DASK_DISTRIBUTED__COMM__TLS__...``).
    Use it as ``with dask.config.set(tls_config(...)):``. Raises :class:`BatchError` for a file that is missing."""
    values = {}
    for what, path in (("ca", ca), ("cert", cert), ("key", key)):
        if path is None:
            continue
        if not Path(path).is_file():
            raise BatchError(f"--tls-{what} {path}: no such file")
        values[TLS_CONFIG[what]] = str(Path(path).resolve())
    if values:
        values["distributed.comm.require-encryption"] = True
    return values


def scheduler_security(scheduler: str, security=None):
    """The :class:`distributed.security.Security` of a connection to ``scheduler``: ``security`` as given, else
    Dask's configuration (:func:`tls_config`). A ``tls://`` address needs a CA and a client certificate (the
    scheduler checks who connects, the client checks the scheduler); a ``tcp://`` address with encryption
    required is refused rather than sent in clear text. Raises :class:`BatchError` in one line."""
    from distributed.security import Security

    security = Security() if security is None else security
    if scheduler.startswith("tls://"):
        missing = [what for what, value in (("--tls-ca", security.tls_ca_file),
                                            ("--tls-cert", security.tls_client_cert)) if not value]
        if missing:
            raise BatchError(f"the scheduler {scheduler} speaks TLS: give {' and '.join(missing)} (and --tls-key "
                             f"unless the certificate file holds the key), or set Dask's distributed.comm.tls "
                             f"configuration (docs/batch.md)")
    elif security.require_encryption:
        raise BatchError(f"TLS certificates are given but the scheduler address {scheduler} is not tls://: "
                         f"write tls://HOST:PORT (a tcp:// connection is clear text)")
    return security


def _client(jobs: int | None, scheduler: str | None, dashboard: str | None = None, security=None):
    """A distributed.Client on a new LocalCluster of ``jobs`` processes (scheduler, workers and the scheduler's HTTP
    server on loopback; ``dashboard``: where that server listens instead, ``HOST:PORT`` or ``PORT`` on loopback),
    or on the scheduler at ``scheduler`` (``tcp://`` or ``tls://``, see :func:`scheduler_security`)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        security = scheduler_security(scheduler, security)
        try:
            with dask.config.set({"distributed.comm.timeouts.connect": f"{CONNECT_TIMEOUT_S}s"}):
                client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s", security=security)
        except (OSError, TimeoutError, ValueError) as error:
            detail = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
            raise BatchError(f"cannot reach the Dask scheduler at {scheduler} within {CONNECT_TIMEOUT_S:g} s "
                             f"({detail})") from None
        try:  # tasks would wait for ever on a cluster without workers
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError):
            client.close()
            raise BatchError(f"the Dask scheduler at {scheduler} has no workers (start some: dask worker "
                             f"{scheduler})") from None
        return client, None
    jobs = default_jobs() if jobs is None else jobs
    if int(jobs) != jobs or jobs < 1:
        raise BatchError(f"--jobs must be a whole number >= 1, got {jobs!r}")
    with _workers_ignore_interrupts():
        cluster = LocalCluster(n_workers=int(jobs), threads_per_worker=1, processes=True, host=LOOPBACK,
                               dashboard_address=_dashboard_address(dashboard),
                               silence_logs=logging.CRITICAL)
    return Client(cluster), cluster


def _dashboard_address(dashboard: str | None) -> str:
    """The dashboard's address for LocalCluster: ``PORT`` -> loopback:PORT, ``HOST:PORT`` as given; None -> any
    free port on loopback (the scheduler's HTTP server runs anyway, for its health and metrics routes: on Dask's
    fixed 8787 a second batch would warn that the port is taken)."""
    if dashboard is None:
        return f"{LOOPBACK}:0"
    text = str(dashboard).strip()
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = LOOPBACK, text
    if not port.isdigit() or int(port) > 65535:
        raise BatchError(f"--dashboard {text}: expected PORT or HOST:PORT (0: any free port)")
    return f"{host or LOOPBACK}:{int(port)}"


#: Where the local cluster's scheduler, workers and dashboard listen: this machine only. Nothing of a batch is
#: offered to the network unless the user starts a cluster of their own and passes its scheduler address.
LOOPBACK = "127.0.0.1"


@contextlib.contextmanager
def _workers_ignore_interrupts():
    """Worker processes started inside this block ignore SIGINT: they inherit the ignored signal through exec
    (a blocked one would not do: the spawn unblocks it).

    Ctrl-C in a terminal reaches the whole process group: only this process should answer it, with one line,
    and close the cluster; workers that took it themselves would each print a traceback. The price: a Ctrl-C
    pressed in the second or two while the workers start is ignored (press it again)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def run_batch(function: Callable, items: Iterable, jobs: int | None = None, scheduler: str | None = None,
              progress: bool = True, on_result: Callable[[Outcome], None] | None = None,
              description: str = "items", dashboard: str | None = None, security=None) -> list[Outcome]:
    """``function(item)`` for every item, in parallel on Dask; the outcomes in the items' order.

    Parameters
    ----------
    function : a picklable callable of one argument (a module-level function: workers import it).
    items : the arguments, each sent to a worker as is (keep them small: paths, parameter chunks).
    jobs : worker processes of the local cluster (default: the cores, :func:`default_jobs`). Ignored with
        ``scheduler``. ``jobs=0``: no Dask, one item after the other in this process (for debugging, and
        for batches too small to pay for starting workers, about 2 s).
    scheduler : address of a running Dask scheduler (``tcp://HOST:PORT``, or ``tls://HOST:PORT`` with
        certificates: ``security`` or Dask's configuration, :func:`scheduler_security`); default: a new
        LocalCluster of processes, closed at the end.
    progress : show a progress bar (tqdm, on stderr).
    on_result : called in this process with each :class:`Outcome` as soon as it completes (in completion
        order): write results down here, so that nothing finished is lost if the batch stops later.
    description : what the items are, for the progress bar.
    dashboard : serve Dask's dashboard of the local cluster at this address (``PORT`` on loopback, or
        ``HOST:PORT``; its link is printed on stderr); default None: a free port on loopback, not printed.
        The scheduler and the workers of the local cluster listen on loopback only.
    security : a :class:`distributed.security.Security` for ``scheduler`` (default: Dask's configuration,
        which :func:`tls_config` sets from the command line's ``--tls-*`` files).

    Returns a list of :class:`Outcome`, one per item, in the items' order. An item whose function raised
    has ``error`` set (one line) and does not stop the others; so has an item whose worker died more often
    than Dask allows (``distributed.scheduler.allowed-failures``). Raises :class:`BatchError` if the
    scheduler cannot be reached, or has no worker, within :data:`CONNECT_TIMEOUT_S`.
    """
    items = list(items)
    outcomes: list[Outcome | None] = [None] * len(items)
    if not items:
        return []
    if jobs == 0 and not scheduler:
        return _run_here(function, items, progress, on_result, description)
    from distributed import as_completed
    from tqdm import tqdm

    client, cluster = _client(jobs, scheduler, dashboard, security)
    if cluster is not None and dashboard is not None:
        print(f"Dask dashboard: {client.dashboard_link}", file=sys.stderr)
    bar = tqdm(total=len(items), desc=description, unit=description.rstrip("s") or "item", file=sys.stderr,
               disable=not progress, dynamic_ncols=True)
    try:
        model = registry.current()  # workers get the model itself: the user's effects travel with it
        futures = [client.submit(_call, function, item, model, pure=False) for item in items]
        index = {future.key: i for i, future in enumerate(futures)}
        for future in as_completed(futures):
            i = index[future.key]
            try:
                value, error, seconds = future.result()
            except Exception as exc:  # noqa: BLE001 - a worker that died too often, a cancelled task
                value, error, seconds = None, f"the task failed on its worker: {error_message(exc)}", math.nan
            outcome = Outcome(i, items[i], value, error, seconds)
            outcomes[i] = outcome
            future.release()
            if on_result is not None:
                on_result(outcome)
            bar.update(1)
    finally:
        bar.close()
        client.close()
        if cluster is not None:
            cluster.close()
    return outcomes


def _run_here(function, items, progress, on_result, description) -> list[Outcome]:
    """``jobs=0``: the items one after the other in this process, with the same outcomes as on Dask."""
    from tqdm import tqdm

    outcomes = []
    for i, item in enumerate(tqdm(items, desc=description, unit=description.rstrip("s") or "item",
                                  file=sys.stderr, disable=not progress, dynamic_ncols=True)):
        value, error, seconds = _call(function, item)
        outcomes.append(Outcome(i, item, value, error, seconds))
        if on_result is not None:
            on_result(outcomes[-1])
    return outcomes


# --- The diagnosis of many records --------------------------------------------------------------------

def expand_files(patterns: Iterable[str], suffix: str = ".csv") -> list[Path]:
    """The measurement files named by ``patterns``: files, folders (their ``*.csv``, sorted) and globs.

    Raises :class:`BatchError` naming a pattern that matches nothing, a folder without files, or a path
    that does not exist. A file named twice is taken once.
    """
    files: list[Path] = []
    for pattern in patterns:
        path = Path(pattern)
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() == suffix)
            if not found:
                raise BatchError(f"{pattern}: no {suffix} file in this folder")
        elif path.is_file():
            found = [path]
        elif glob.has_magic(pattern):
            found = sorted(Path(p) for p in glob.glob(pattern, recursive=True) if Path(p).is_file())
            if not found:
                raise BatchError(f"{pattern}: no file matches this pattern")
        else:
            raise BatchError(f"{pattern}: no such file or folder")
        files.extend(found)
    unique = list(dict.fromkeys(p.resolve() for p in files))
    if not unique:
        raise BatchError("no measurement file given")
    return unique


def diagnose_file(path, base=None, fit_offset: bool = False, mechanism=None) -> dict:
    """Read one measurement file and diagnose it (runs on a worker): the public report plus its time.

    ``base``: the parameters the file's metadata overrides (a muscle file's; default the paper's);
    ``fit_offset``: fit a constant sensor offset (as ``mkctl diagnose --fit-offset``);
    ``mechanism``: the mechanism a mechanism record is read with (a built-in's name or a FILE.py the
    user gave, as ``--mechanism``: loaded here, on the worker; a record never loads the file it
    names)."""
    from .diagnose import diagnose, public
    from .mechanism_files import mechanism as load_mechanism
    from ..io.measurements import read_measurement
    from ..physics.params import Params

    start = time.perf_counter()
    mechanism = None if mechanism is None else load_mechanism(mechanism)
    measurement = read_measurement(path, base=Params() if base is None else base,
                                   mechanism=mechanism)
    report = public(diagnose(measurement, fit_offset=fit_offset) if fit_offset else diagnose(measurement))
    for name in ("rmse_before", "rmse_after"):
        value = report.get(name)
        if value is None or not math.isfinite(value):
            raise BatchError(f"{path}: the diagnosis gave no finite {name.replace('_', ' ')} ({value}): counted as "
                             "failed")
    report["seconds"] = time.perf_counter() - start
    return report


@dataclass(repr=False)
class BatchResult(Result):
    """The diagnosis of many records: one row per record, the reports, and where they were written.

    Attributes: ``files`` (the records, in order), ``reports`` ({file: the report of spec section 6, as
    written to JSON}; records that failed are absent), ``errors`` ({file: one-line message}), ``seconds``
    (wall time of the whole batch [s]), ``workers`` (where it ran), ``out`` (the folder written, or None).
    """

    files: list[str]
    reports: dict
    errors: dict
    seconds: float
    workers: str
    out: Path | None = None
    written: dict = field(default_factory=dict)  #: {file: JSON path}

    @property
    def parameters(self) -> list[str]:
        """Names of the parameters fitted in any record, in the order the diagnosis knows them."""
        from .diagnose import CANDIDATES

        order = [c.parameter for c in CANDIDATES.values()]
        found = {name for report in self.reports.values() for name in report.get("params", {})}
        return [name for name in order if name in found] + sorted(found - set(order))

    def table(self) -> list[dict]:
        """One row per record (for :meth:`to_dataframe`): file, status, missing effects, each parameter and its
        standard error, RMSE before and after (in the file's output unit), seconds, error message."""
        return summary_rows(self.files, self.reports, self.errors, self.parameters)

    def to_dataframe(self):
        import pandas as pd

        return pd.DataFrame(self.table(), columns=summary_columns(self.parameters))

    to_dataframe.__doc__ = table.__doc__

    def text_table(self) -> str:
        """The summary as a readable text table (as ``mkctl diagnose FILE...`` prints it)."""
        return format_table(self.table(), self.parameters)

    def plot(self, path=None):
        """Each fitted parameter with its standard error, record by record; saved as PNG if ``path`` is given.

        Returns the matplotlib Figure."""
        return plot_parameters(self.table(), self.parameters, path)

    def summary_lines(self) -> list[str]:
        ok = len(self.reports)
        lines = [f"{len(self.files)} records, {ok} diagnosed, {len(self.errors)} failed, "
                 f"{self.seconds:.1f} s on {self.workers}"]
        counts: dict = {}
        for report in self.reports.values():
            for effect in report.get("missing") or ["nothing"]:
                counts[effect] = counts.get(effect, 0) + 1
        if counts:
            lines.append("missing: " + ", ".join(f"{k} in {v}" for k, v in counts.items()))
        return lines + self.text_table().splitlines()


def summary_columns(parameters: list[str]) -> list[str]:
    """Columns of the batch summary table."""
    columns = ["file", "status", "experiment", "samples", "missing", "verdict"]
    for name in parameters:
        columns += [name, f"{name}_se"]
    return columns + ["rmse_before", "rmse_after", "unit", "seconds", "error"]


def summary_rows(files, reports: dict, errors: dict, parameters: list[str]) -> list[dict]:
    """One dict per file, in the files' order; a file with neither report nor error is 'pending'."""
    rows = []
    for file in files:
        report = reports.get(file)
        row = {column: None for column in summary_columns(parameters)}
        row["file"] = file
        if report is not None:
            row.update(status="ok", experiment=report["experiment"], samples=report["samples"],
                       missing=";".join(report["missing"]), verdict=report.get("verdict"),
                       rmse_before=report["rmse_before"],
                       rmse_after=report["rmse_after"], unit=report["output_unit"], seconds=report.get("seconds"),
                       error="; ".join(report.get("problems") or []) or None)
            for name in parameters:
                row[name] = report["params"].get(name)
                row[f"{name}_se"] = report["uncertainty"].get(name)
        elif file in errors:
            row.update(status="error", error=errors[file])
        else:
            row["status"] = "pending"
        rows.append(row)
    return rows


def write_summary_csv(path, rows: list[dict], parameters: list[str]) -> Path:
    """Write the summary table (atomically: a finished batch never leaves half a file)."""
    return write_rows(path, rows, summary_columns(parameters))


#: First characters that make a spreadsheet read a cell as a formula (CSV injection): a text cell that starts with
#: one (a record named "=HYPERLINK(...).csv") is written with a leading apostrophe, as spreadsheets do.
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def csv_cell(value):
    """A value as a CSV cell: None empty; a text that a spreadsheet would run as a formula prefixed with "'"
    (a number stays a number); quotes, commas and line breaks are the csv module's to quote."""
    if value is None:
        return ""
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        try:
            float(value)
        except ValueError:
            return "'" + value
    return value


def write_rows(path, rows: list[dict], columns: list[str] | None = None) -> Path:
    """Write table rows as CSV (UTF-8; an undecodable file name's bytes as backslash escapes), atomically
    (columns: given, or the first row's keys); None is an empty cell; see :func:`csv_cell`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(path.name + ".tmp")
    with temporary.open("w", newline="", encoding="utf-8", errors="backslashreplace") as handle:
        writer = csv.DictWriter(handle, fieldnames=[csv_cell(c) for c in columns or list(rows[0])])
        writer.writeheader()
        for row in rows:
            writer.writerow({csv_cell(k): csv_cell(v) for k, v in row.items()})
    os.replace(temporary, path)
    return path


def _number(value, digits: int = 4) -> str:
    return "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) else f"{value:.{digits}g}"


def format_table(rows: list[dict], parameters: list[str]) -> str:
    """The summary rows as a text table: file, missing effects, value +- standard error, RMSE, time."""
    from ..physics.params import UNITS

    header = ["file", "missing"] + [f"{name} [{UNITS.get(name, '')}]" for name in parameters] + \
        ["RMSE before", "RMSE after", "unit", "time [s]"]
    lines = []
    for row in rows:
        name = Path(row["file"]).name
        if row["status"] != "ok":
            lines.append([name, f"{row['status'].upper()}: {row['error'] or ''}"])
            continue
        missing = row["missing"].replace(";", ", ") or "nothing"
        if row.get("verdict") in ("not diagnosed", "undecided", "incomplete"):
            missing = f"{missing} ({row['verdict']})" if row["verdict"] != "not diagnosed" else "NOT DIAGNOSED"
        cells = [name, missing]
        for parameter in parameters:
            value, error = row[parameter], row[f"{parameter}_se"]
            cells.append("-" if value is None else _number(value) + (f" +- {_number(error, 2)}" if error is not None
                                                                     else ""))
        cells += [_number(row["rmse_before"]), _number(row["rmse_after"]), row["unit"] or "",
                  _number(row["seconds"], 3)]
        lines.append(cells)
    widths = [len(h) for h in header]
    for cells in lines:
        if len(cells) == len(header):
            widths = [max(w, len(c)) for w, c in zip(widths, cells)]
    out = ["  ".join(h.ljust(w) for h, w in zip(header, widths)).rstrip()]
    for cells in lines:
        if len(cells) == len(header):
            out.append("  ".join(c.ljust(w) for c, w in zip(cells, widths)).rstrip())
        else:  # an error row: the message runs across the table
            out.append(f"{cells[0].ljust(widths[0])}  {cells[1]}")
    return "\n".join(out)


#: The longest record name a figure's axis shows, in characters (longer ones end in an ellipsis).
TICK_LABEL_CHARACTERS = 28


def tick_label(name: str) -> str:
    """A record's name as an axis label: on one line, what the font cannot draw as escapes
    (:func:`mkctl.io.plotting.drawable`), '$' escaped (no mathtext), at most :data:`TICK_LABEL_CHARACTERS`
    characters."""
    from ..io.plotting import drawable

    text = drawable(" ".join(str(name).splitlines()))
    if len(text) > TICK_LABEL_CHARACTERS:
        text = text[:TICK_LABEL_CHARACTERS - 1] + "\u2026"
    return text.replace("$", r"\$")


def plot_parameters(rows: list[dict], parameters: list[str], path=None):
    """One panel per parameter: its value with the standard error as error bar, one point per record.

    Records that did not fit the parameter (or failed) are left out of that panel. Returns the Figure,
    saved as PNG at ``path`` if given (:func:`mkctl.io.plotting.save_png`, which closes it)."""
    from ..io.plotting import new_figure, save_png
    from ..physics.params import UNITS

    names = [tick_label(Path(row["file"]).name) for row in rows]
    panels = parameters or [None]
    fig, axes = new_figure(len(panels), 1, figsize=(max(5.0, 0.45 * len(rows) + 2.5), 2.6 * len(panels)),
                           squeeze=False)
    for ax, name in zip(axes[:, 0], panels):
        if name is None:
            ax.text(0.5, 0.5, "no parameter was fitted in any record", ha="center", va="center",
                    transform=ax.transAxes)
        else:
            x = [i for i, row in enumerate(rows) if row.get(name) is not None]
            y = [rows[i][name] for i in x]
            error = [rows[i][f"{name}_se"] or 0.0 for i in x]
            ax.errorbar(x, y, yerr=error, fmt="o", capsize=3, color="tab:blue")
            ax.set_ylabel(f"{name} [{UNITS.get(name, '')}]")
            ax.ticklabel_format(axis="y", useOffset=False)
        failed = [i for i, row in enumerate(rows) if row["status"] == "error"]
        for i in failed:
            ax.axvspan(i - 0.4, i + 0.4, color="tab:red", alpha=0.12, lw=0)
        ax.set_xlim(-0.6, len(rows) - 0.4)
        ax.set_xticks(range(len(rows)), names if ax is axes[-1, 0] else [""] * len(rows), rotation=60,
                      ha="right", fontsize=7)
        ax.grid(alpha=0.3)
    axes[0, 0].set_title("fitted parameters per record\n(error bars: one standard error; red: the record failed)",
                         fontsize=9)
    if path is not None:
        save_png(fig, path)
    return fig


def _json_names(files: list[str]) -> dict:
    """A JSON file name per record: its stem, made unique when two folders hold the same name."""
    names, seen = {}, {}
    for file in files:
        stem = Path(file).stem
        count = seen.get(stem, 0)
        seen[stem] = count + 1
        names[file] = f"{stem}.diagnosis.json" if count == 0 else f"{stem}.{count}.diagnosis.json"
    return names


def _diagnose_item(item) -> dict:
    return diagnose_file(*item)


def _file_digest(file) -> str | None:
    """The SHA-256 of a file's content, or None when it cannot be read."""
    import hashlib

    try:
        return hashlib.sha256(Path(file).read_bytes()).hexdigest()
    except OSError:
        return None


def _input_key(file: str, base, fit_offset: bool, mechanism=None) -> dict:
    """What a record's report depends on besides mkctl: the file's content (SHA-256) and the options
    (a mechanism file given: its content too)."""
    digest = _file_digest(file)
    key = {"sha256": digest, "fit_offset": bool(fit_offset),
           "params": None if base is None else {k: v for k, v in base.as_dict().items()}}
    if mechanism is not None:
        text = mechanism if isinstance(mechanism, str) else mechanism.name
        digest = _file_digest(text) if text.endswith(".py") else None
        key["mechanism"] = {"name": text, "sha256": digest}
    from .effect_files import registered_definitions
    user = registered_definitions()
    if user:  # the user's effects are candidates: another definition makes another report
        key["effects"] = user
    return key


def _kept_report(path: Path, key: dict) -> dict | None:
    """The report at ``path`` if a former run wrote it for the same input (:func:`_input_key`), else None."""
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(report, dict) or report.get("input") != key or key["sha256"] is None:
        return None
    report.pop("input")
    return report


def diagnose_batch(files: Iterable, out=None, jobs: int | None = None, scheduler: str | None = None,
                   progress: bool = True, on_record: Callable[[str, dict | None, str | None], None] | None = None,
                   base=None, fit_offset: bool = False, dashboard: str | None = None,
                   mechanism=None) -> BatchResult:
    """Diagnose many measurement files in parallel (:func:`run_batch` over :func:`diagnose_file`).

    Parameters
    ----------
    files : paths, folders or glob patterns (:func:`expand_files`).
    out : folder for ``<stem>.diagnosis.json`` per record, :data:`SUMMARY_CSV` and :data:`SUMMARY_PNG`; each
        JSON is written as its record completes and the CSV rewritten after every record. None: write nothing.
    jobs, scheduler, progress, dashboard : as in :func:`run_batch`.
    on_record : called with (file, report or None, error or None) as each record completes.
    base : the :class:`mkctl.physics.params.Params` each file's metadata overrides (a muscle file's,
        ``--params``); default the paper's.
    fit_offset : fit a constant sensor offset in every record (``--fit-offset``).
    mechanism : the mechanism mechanism records are read with (``--mechanism``: a built-in's name
        or a FILE.py, loaded on each worker); None: the one each record names, built-ins only.

    Returns a :class:`BatchResult`. A file that cannot be read or diagnosed is a row with its error message.
    """
    paths = [str(p) for p in expand_files([str(f) for f in files])]
    out = Path(out) if out is not None else None
    reports: dict = {}
    errors: dict = {}
    written: dict = {}
    json_names = _json_names(paths)

    if mechanism is not None:  # checked here, once, before any work (a one-line error)
        from .mechanism_files import mechanism as load_mechanism

        loaded = load_mechanism(mechanism)
        if isinstance(mechanism, (str, Path)):  # a name or a path travels to the workers as text
            text = str(mechanism)
            mechanism = str(Path(text).resolve()) if text.endswith(".py") else text
        else:
            mechanism = loaded
    keys = {file: _input_key(file, base, fit_offset, mechanism) for file in paths}

    def record(file: str, report: dict | None, error: str | None, write: bool = True):
        if error is None:
            reports[file] = report
        else:
            errors[file] = error
        if out is not None:
            if error is None:
                path = out / json_names[file]
                if write:  # aside and renamed: a kill never leaves half a report for a re-run to trust
                    write_text_atomic(path, json.dumps({**report, "input": keys[file]}, indent=2,
                                                       allow_nan=False) + "\n")
                written[file] = path
            parameters = BatchResult(paths, reports, errors, 0.0, "").parameters
            write_summary_csv(out / SUMMARY_CSV, summary_rows(paths, reports, errors, parameters), parameters)
        if on_record is not None:
            on_record(file, report, error)

    start = time.perf_counter()
    # a re-run into the same folder keeps the reports of records already done (same file content, same options)
    done = {file: _kept_report(out / json_names[file], keys[file]) for file in paths} if out is not None else {}
    for file, report in done.items():
        if report is not None:
            record(file, report, None, write=False)
    todo = [file for file in paths if done.get(file) is None]
    if progress and len(todo) < len(paths):
        print(f"{len(paths) - len(todo)} of {len(paths)} records already diagnosed in {out} (same file, same "
              "options): kept", file=sys.stderr)
    run_batch(_diagnose_item, [(path, base, fit_offset, mechanism) for path in todo], jobs=jobs,
              scheduler=scheduler,
              progress=progress, description="records", dashboard=dashboard,
              on_result=lambda o: record(todo[o.index], o.value if o.ok else None, o.error))
    workers = f"the scheduler at {scheduler}" if scheduler else "this process" if jobs == 0 else \
        f"{default_jobs() if jobs is None else jobs} local processes"
    result = BatchResult(paths, reports, errors, time.perf_counter() - start, workers, out, written)
    if out is not None:
        result.plot(out / SUMMARY_PNG)
    return result



# --- many muscles: one calibration per file ---------------------------------------------------------

#: Parameters reported in the calibration batch's summary, in this order.
CALIBRATION_COLUMNS = ("b", "n", "C1", "C2", "Fc")


def _calibrate_item(item) -> dict:
    """Run on a worker: calibrate one file as its own muscle; returns its muscle-file content + timing."""
    path, options = item
    from .calibrate import calibrate, read_records
    start = time.perf_counter()
    chosen = {} if options.get("effects") is None else {"effects": options["effects"]}
    result = calibrate(read_records([path], options.get("base")), fit=options.get("fit", ()),
                       params=options.get("base"), link_n=options.get("link_n", False), **chosen)
    report = result.to_dict()
    report["seconds"] = time.perf_counter() - start
    return report


def calibration_rows(files, reports: dict, errors: dict) -> list[dict]:
    """One summary row per file: effects, each parameter of :data:`CALIBRATION_COLUMNS` with its standard
    error, NRMS before and after, time, and the error of a file that failed."""
    rows = []
    for file in files:
        row = {"file": file, "status": "pending", "effects": None}
        for name in CALIBRATION_COLUMNS:
            row[name] = row[f"{name}_se"] = None
        row.update(nrms_before=None, nrms_after=None, seconds=None, error=None)
        report = reports.get(file)
        if report is not None:
            row.update(status="ok", effects=";".join(report["effects"]), nrms_before=report["nrms_before"],
                       nrms_after=report["nrms_after"], seconds=report["seconds"])
            for name in CALIBRATION_COLUMNS:
                row[name] = report["params"].get(name)
                row[f"{name}_se"] = report.get("stderr", {}).get(name)
        elif file in errors:
            row.update(status="error", error=errors[file])
        rows.append(row)
    return rows


def calibrate_batch(files: Iterable, out, jobs: int | None = None, scheduler: str | None = None,
                    progress: bool = True, base=None, fit=(), link_n: bool = False, effects=None,
                    on_record: Callable | None = None) -> list[dict]:
    """Calibrate every file as its own muscle (:func:`mkctl.analysis.calibrate.calibrate`), in parallel on the
    batch engine (:func:`run_batch`). Each muscle file ``OUT/<stem>.muscle.json`` and the summary
    ``OUT/calibration_summary.csv`` are written as records complete; at the end ``OUT/calibration_parameters.png``
    shows each parameter with its error bar per file. One bad file is reported in its row and does not stop the
    rest. Returns the summary rows in the files' order."""
    from ..io.muscle import params_from_values, write_muscle

    files = [str(f) for f in expand_files(files)]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    names = {file: name.replace(".diagnosis.json", ".muscle.json") for file, name in _json_names(files).items()}
    options = {"base": base, "fit": tuple(fit), "link_n": link_n, "effects": effects}
    reports, errors = {}, {}
    summary = out / "calibration_summary.csv"

    def written(outcome: Outcome) -> None:
        file = files[outcome.index]
        if outcome.ok:
            report = dict(outcome.value)
            reports[file] = report
            for assumption in report.get("assumed", []):  # a default taken for this muscle: said on stderr too
                print(f"mkctl calibrate: warning: {Path(file).name}: {assumption}", file=sys.stderr)
            muscle = {k: v for k, v in report.items() if k != "params"}
            write_muscle(out / names[file], params_from_values(report["params"], file), **muscle)
        else:
            errors[file] = outcome.error
        write_rows(summary, calibration_rows(files, reports, errors))
        if on_record is not None:
            on_record(outcome)

    run_batch(_calibrate_item, [(file, options) for file in files], jobs=jobs, scheduler=scheduler,
              progress=progress, on_result=written, description="muscles")
    rows = calibration_rows(files, reports, errors)
    write_rows(summary, rows)
    plot_parameters(rows, [n for n in CALIBRATION_COLUMNS if any(r[n] is not None for r in rows)],
                    out / "calibration_parameters.png")
    return rows


