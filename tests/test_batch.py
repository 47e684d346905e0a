"""The batch engine: many records in parallel give what one by one gives, on a LocalCluster and on a real
Dask cluster of separate processes; bad files and dead workers do not stop a batch."""
import csv
import json
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import dask
import distributed  # noqa: F401 - its config defaults, before dask.config.set below
import numpy as np
import pytest

from mkctl.analysis.batch import BatchError, diagnose_batch, diagnose_file, expand_files, run_batch
from mkctl.analysis.diagnose import diagnose, public
from mkctl.analysis.sweep import sweep
from mkctl.analysis.synth import synthesize, write_synthetic
from mkctl.io.measurements import read_measurement

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}

#: Short isotonic records (about a second of diagnosis each) with known hidden effects.
RECORDS = {"friction": ["coulomb_friction"], "damping": ["viscous_damping"], "plain": []}


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    folder = tmp_path_factory.mktemp("records")
    truth = {}
    for i, (name, hidden) in enumerate(RECORDS.items()):
        record = synthesize("isotonic", hidden=hidden, samples=200, seed=i)
        path, _ = write_synthetic(folder / f"{name}.csv", record)
        truth[str(path.resolve())] = record
    (folder / "broken.csv").write_text("# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,2\n")
    return folder, truth


@pytest.fixture(scope="module")
def one_by_one(records):
    """The reference: each record diagnosed by the plain function, in this process."""
    _, truth = records
    return {path: public(diagnose(read_measurement(path))) for path in truth}


def _same_report(report, reference):
    assert report["missing"] == reference["missing"]
    assert report["params"].keys() == reference["params"].keys()
    for name, value in reference["params"].items():
        assert report["params"][name] == pytest.approx(value, rel=1e-9)
        assert report["uncertainty"][name] == pytest.approx(reference["uncertainty"][name], rel=1e-6)
    assert report["rmse_after"] == pytest.approx(reference["rmse_after"], rel=1e-9)


def test_a_parallel_batch_gives_the_answers_of_one_by_one_and_survives_a_broken_file(records, one_by_one, tmp_path):
    folder, truth = records
    out = tmp_path / "out"
    seen = []

    def on_record(file, report, error):  # written as it completes: the JSON and the table are there already
        seen.append(file)
        rows = list(csv.DictReader((out / "batch_summary.csv").open()))
        assert {r["file"]: r["status"] for r in rows}[file] == ("ok" if report else "error")
        if report:
            assert json.loads((out / f"{Path(file).stem}.diagnosis.json").read_text())["missing"] == report["missing"]

    result = diagnose_batch([folder], out, jobs=2, progress=False, on_record=on_record)
    broken = str((folder / "broken.csv").resolve())
    assert sorted(seen) == sorted(result.files) and len(result.files) == 4
    assert list(result.errors) == [broken] and "broken.csv" in result.errors[broken]
    for path, record in truth.items():
        assert result.reports[path]["missing"] == record.hidden_effects  # the hidden truth is found
        _same_report(result.reports[path], one_by_one[path])
    table = result.to_dataframe()
    assert list(table["status"]) == ["error", "ok", "ok", "ok"]  # broken, damping, friction, plain
    assert table.loc[1, "c"] == pytest.approx(one_by_one[str((folder / "damping.csv").resolve())]["params"]["c"])
    assert re.search(r"broken\.csv +ERROR: .*broken\.csv", result.text_table())
    figure = result.plot()
    assert [ax.get_ylabel() for ax in figure.axes] == ["c [N s/m]", "Fc [N]"]
    assert (out / "batch_parameters.png").stat().st_size > 0
    assert "4 records, 3 diagnosed, 1 failed" in repr(result)


def test_a_worker_that_dies_loses_no_finished_result(tmp_path):
    marker = str(tmp_path / "others-done")

    def work(item):  # "die" kills its worker once the other items are back in this process
        if item != "die":
            return item * 2
        deadline = time.monotonic() + 60
        while not os.path.exists(marker) and time.monotonic() < deadline:
            time.sleep(0.05)
        os._exit(3)

    done = []

    def on_result(outcome):
        done.append(outcome.index)
        if len(done) == 3:
            Path(marker).touch()

    # one task per worker at a time (no task waits behind "die"); a task that killed its worker is not retried
    with dask.config.set({"distributed.scheduler.allowed-failures": 0, "distributed.scheduler.worker-saturation": 1.0}):
        outcomes = run_batch(work, ["die", 1, 2, 4], jobs=2, progress=False, on_result=on_result)
    assert [o.value for o in outcomes] == [None, 2, 4, 8]
    assert "failed on its worker" in outcomes[0].error
    assert sorted(done[:3]) == [1, 2, 3] and done[3] == 0


def test_an_error_in_one_item_is_its_outcome_and_jobs_0_runs_here():
    outcomes = run_batch(diagnose_file, ["/nonexistent/file.csv"], jobs=0, progress=False)
    assert not outcomes[0].ok and "file.csv" in outcomes[0].error
    pids = run_batch(lambda item: os.getpid(), [0, 1], jobs=0, progress=False)
    assert {o.value for o in pids} == {os.getpid()}


def test_expand_files_names_what_matches_nothing(records, tmp_path):
    folder, truth = records
    assert len(expand_files([str(folder / "*.csv"), str(folder / "plain.csv")])) == 4  # once each
    with pytest.raises(BatchError, match=r"nothing\*\.csv: no file matches"):
        expand_files([str(tmp_path / "nothing*.csv")])
    with pytest.raises(BatchError, match="no .csv file in this folder"):
        expand_files([str(tmp_path)])
    with pytest.raises(BatchError, match="no such file"):
        expand_files([str(tmp_path / "missing.csv")])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_cluster(tmp_path):
    """A scheduler and two workers (no nanny), each a separate process on 127.0.0.1; stopped by process id."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = [open(tmp_path / f"{name}.log", "w") for name in ("scheduler", "worker1", "worker2")]
    processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                   "--port", str(port), "--no-dashboard"], stdout=logs[0], stderr=logs[0], env=ENV,
                                  cwd=tmp_path)]
    try:
        for log in logs[1:]:
            processes.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-nanny",
                 "--no-dashboard", "--host", "127.0.0.1"], stdout=log, stderr=log, env=ENV, cwd=tmp_path))
        from distributed import Client

        deadline = time.monotonic() + 60
        while True:
            try:
                with Client(address, timeout="2s") as client:
                    client.wait_for_workers(2, timeout=max(1.0, deadline - time.monotonic()))
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        yield address, [p.pid for p in processes[1:]]
    finally:
        # one at a time, the workers before the scheduler: a worker whose scheduler went away while it closed
        # hung in its close for the whole timeout (20 s of every run)
        for process in reversed(processes):
            os.kill(process.pid, 15)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.kill(process.pid, 9)
                process.wait()
        for log in logs:
            log.close()


def test_a_dask_cluster_of_separate_processes_runs_a_batch_and_a_sweep(dask_cluster, records, one_by_one, tmp_path):
    address, worker_pids = dask_cluster
    folder, truth = records
    pids = run_batch(lambda item: os.getpid(), range(6), scheduler=address, progress=False)
    assert {o.value for o in pids} <= set(worker_pids)  # ran on the workers, not here

    files = [folder / "friction.csv", folder / "damping.csv"]
    result = diagnose_batch(files, tmp_path / "out", scheduler=address, progress=False)
    assert not result.errors and result.workers == f"the scheduler at {address}"
    for path in files:
        _same_report(result.reports[str(path.resolve())], one_by_one[str(path.resolve())])

    grid = {"c": (0, 200, 9), "alpha_deg": (30, 70, 5), "tau": [0.0, 0.05]}
    remote = sweep(grid, scheduler=address, progress=False, chunk=20)
    here = sweep(grid, jobs=0, progress=False)
    for name in ("a1", "a2", "pe_kPa", "damping_ratio", "settling_time_s", "overshoot_percent"):
        # equal up to rounding: numpy's vector math may round the last bit differently in other chunk sizes
        np.testing.assert_allclose(remote.columns[name], here.columns[name], rtol=1e-12, atol=1e-300)
    assert list(remote.verdict) == list(here.verdict)


def test_an_unreachable_scheduler_is_one_clear_error(monkeypatch):
    from mkctl.analysis import batch
    assert batch.CONNECT_TIMEOUT_S <= 10  # a short connect timeout, not the default minute(s)
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 1.0)  # the wait below, shortened
    port = _free_port()  # nothing listens there
    start = time.monotonic()
    with pytest.raises(BatchError, match=f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}"):
        run_batch(abs, [1], scheduler=f"tcp://127.0.0.1:{port}", progress=False)
    assert time.monotonic() - start < 10  # the timeout is what it waits


def test_a_scheduler_without_workers_is_one_clear_error(monkeypatch):
    from distributed import LocalCluster

    from mkctl.analysis import batch
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 1.0)  # how long it waits for a worker, shortened

    with LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as empty:
        with pytest.raises(BatchError, match="has no workers"):
            run_batch(abs, [1], scheduler=empty.scheduler_address, progress=False)


def _mkctl(*args, cwd):
    return subprocess.run([sys.executable, "-m", "mkctl", *args], capture_output=True, text=True, cwd=cwd, env=ENV,
                          timeout=300)


def test_cli_diagnose_over_files_writes_a_table_and_reports_the_broken_one(records, tmp_path):
    folder, _ = records
    done = _mkctl("diagnose", str(folder / "friction.csv"), str(folder / "broken.csv"), "--out", str(tmp_path / "o"),
                  "--jobs", "0", "--quiet", cwd=tmp_path)
    assert done.returncode == 1, done.stderr  # one record failed: the batch finished, the status says so
    assert re.search(r"friction\.csv +coulomb_friction", done.stdout) and "broken.csv" in done.stdout
    rows = list(csv.DictReader((tmp_path / "o" / "batch_summary.csv").open()))
    assert [r["status"] for r in rows] == ["ok", "error"]


@pytest.mark.parametrize("args, message", [
    (["nothing/*.csv"], "nothing/*.csv: no file matches this pattern"),
    (["a.csv", "b.csv", "--json", "x.json"], "--json names one report"),
])
def test_cli_diagnose_batch_bad_input_is_one_line(tmp_path, args, message):
    for name in ("a.csv", "b.csv"):
        (tmp_path / name).write_text("x")
    done = _mkctl("diagnose", *args, cwd=tmp_path)
    assert done.returncode == 2 and message in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
