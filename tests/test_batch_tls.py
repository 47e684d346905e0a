"""A Dask cluster over a network, encrypted: a ``tls://`` scheduler with certificates made here (loopback only).

The certificates come from :meth:`distributed.security.Security.temporary` (one self-signed authority, needs
the ``cryptography`` package of the test extra), written as the PEM files a user has. mkctl takes them as Dask
configuration (:func:`mkctl.analysis.batch.tls_config`, what ``--tls-ca/--tls-cert/--tls-key`` set) and builds
the client's :class:`~distributed.security.Security` from it. Checked: a batch runs on the workers of the TLS
scheduler; without certificates, with another authority's, or with certificates for a ``tcp://`` address the
run is refused in one line.
"""
from __future__ import annotations

import threading

import dask
import distributed  # noqa: F401 - its config defaults, before dask.config.set below
import pytest

from mkctl.analysis import batch
from mkctl.analysis.batch import BatchError, run_batch, tls_config
from mkctl.cli import main


def _square(value):
    return value * value, threading.current_thread().name


def _pem_files(folder, security):
    folder.mkdir()
    files = {}
    for what, text in (("ca", security.tls_ca_file), ("cert", security.tls_client_cert),
                       ("key", security.tls_client_key)):
        files[what] = folder / f"{what}.pem"
        files[what].write_text(text)
    return files


@pytest.fixture(scope="module")
def tls_cluster(tmp_path_factory):
    """A LocalCluster speaking TLS on 127.0.0.1 (one worker thread), and the PEM files of its authority."""
    from distributed import LocalCluster
    from distributed.security import Security

    security = Security.temporary()  # an authority and a certificate signed by it, made here
    files = _pem_files(tmp_path_factory.mktemp("tls") / "pem", security)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tls://", security=security,
                      host="127.0.0.1", dashboard_address=":0") as cluster:
        yield cluster.scheduler_address, files


def test_a_tls_scheduler_runs_a_batch_with_the_certificates_as_dask_configuration(tls_cluster):
    address, files = tls_cluster
    assert address.startswith("tls://127.0.0.1:")
    with dask.config.set(tls_config(files["ca"], files["cert"], files["key"])):
        outcomes = run_batch(_square, range(5), scheduler=address, progress=False)
    assert [o.value[0] for o in outcomes] == [0, 1, 4, 9, 16] and not any(o.error for o in outcomes)
    assert all(o.value[1] != threading.current_thread().name for o in outcomes)  # on the cluster's worker


def test_the_command_line_takes_the_tls_files(tls_cluster, tmp_path, capsys):
    address, files = tls_cluster
    status = main(["sweep", "--grid", "c=0:200:3", "--out", str(tmp_path / "sweep"), "--quiet", "--map", "verdict",
                   "--scheduler", address, "--tls-ca", str(files["ca"]), "--tls-cert", str(files["cert"]),
                   "--tls-key", str(files["key"])])
    assert status == 0
    assert (tmp_path / "sweep" / "sweep.csv").read_text().count("\n") == 4  # header and 3 points


def test_a_tls_scheduler_without_certificates_is_one_clear_error(tls_cluster, capsys):
    address, _ = tls_cluster
    with pytest.raises(BatchError, match="speaks TLS: give --tls-ca and --tls-cert"):
        run_batch(_square, [1], scheduler=address, progress=False)
    status = main(["sweep", "--grid", "c=0:200:3", "--quiet", "--scheduler", address])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "--tls-ca" in err[0]


def test_certificates_of_another_authority_are_refused(tls_cluster, tmp_path, monkeypatch):
    from distributed.security import Security

    address, _ = tls_cluster
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 2.0)  # the handshake fails at once; retries until this
    other = _pem_files(tmp_path / "other", Security.temporary())
    with dask.config.set(tls_config(other["ca"], other["cert"], other["key"])):
        with pytest.raises(BatchError, match=f"cannot reach the Dask scheduler at {address}"):
            run_batch(_square, [1], scheduler=address, progress=False)


def test_certificates_for_a_clear_text_address_and_missing_files_are_refused(tls_cluster, tmp_path):
    address, files = tls_cluster
    with dask.config.set(tls_config(files["ca"], files["cert"], files["key"])):
        with pytest.raises(BatchError, match="is not tls://"):
            run_batch(_square, [1], scheduler=address.replace("tls://", "tcp://"), progress=False)
    with pytest.raises(BatchError, match="--tls-ca .*: no such file"):
        tls_config(tmp_path / "nothing.pem")
