"""A ``scheduler`` address that is not a Dask scheduler is one line naming ``scheduler``, within
the connect timeout, at the CLI (``robustness``, ``doe``) and the API (``do_no_harm``,
``run_batch``) alike, before any progress line or file.

The servers are loopback stand-ins on free ports: an HTTP server (its reply used to be read as
a frame length of exabytes: ``MemoryError`` in distributed), a socket that accepts and never
answers (used to hang for ever), one that answers with bytes that are not a Dask handshake,
and a real Dask scheduler (in this process) that the probe must accept.

Time bounds: the connect timeout is 5 s (``CONNECT_TIMEOUT_S``); each refusal must come
within 5 s plus 5 s of slack for a loaded 2-core machine (a hang would exceed any bound).
"""

from __future__ import annotations

import http.server
import socket
import threading
import time

import pytest

from bridgeflap.design.batch.cluster import (
    CONNECT_TIMEOUT_S,
    cluster_client,
    connect_scheduler,
    probe_scheduler,
)
from bridgeflap.model.errors import BridgeflapInputError

#: the connect timeout plus slack for a loaded machine [s] (module docstring)
BOUND_S = CONNECT_TIMEOUT_S + 5.0


class _Quiet(http.server.BaseHTTPRequestHandler):
    def log_message(self, *args):  # no request log on stderr
        pass


@pytest.fixture
def http_address():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def _listener(reply: bytes | None):
    """A loopback socket that accepts; sends ``reply`` on each connection (None: nothing)."""
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(8)
    conns = []

    def serve():
        while True:
            try:
                conn, _ = sock.accept()
            except OSError:
                return
            conns.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return sock, conns


@pytest.fixture
def silent_address():
    sock, conns = _listener(None)
    yield f"127.0.0.1:{sock.getsockname()[1]}"
    sock.close()
    for c in conns:
        c.close()


@pytest.fixture
def http_reply_address():
    """Speaks first, as an HTTP server would answer: the reply's first 8 bytes read as a
    length are 3.07 EiB."""
    sock, conns = _listener(b"HTTP/1.0 400 Bad Request\r\n\r\n")
    yield f"tcp://127.0.0.1:{sock.getsockname()[1]}"
    sock.close()
    for c in conns:
        c.close()


def _refused_in_time(call) -> str:
    t0 = time.monotonic()
    with pytest.raises(BridgeflapInputError) as info:
        call()
    elapsed = time.monotonic() - t0
    assert elapsed < BOUND_S, elapsed
    text = str(info.value)
    assert info.value.field == "scheduler" and "\n" not in text, text
    return text


@pytest.mark.parametrize("server", ["http_address", "silent_address", "http_reply_address"])
def test_not_a_scheduler_is_one_line_in_time(server, request):
    address = request.getfixturevalue(server)
    text = _refused_in_time(lambda: probe_scheduler(address))
    assert address in text
    # the whole connection (probe, then the client) refuses it alike
    _refused_in_time(lambda: connect_scheduler(address))


def test_an_http_reply_is_refused_at_once_as_another_service(http_reply_address):
    t0 = time.monotonic()
    text = _refused_in_time(lambda: probe_scheduler(http_reply_address))
    # no waiting for a timeout: the reply is read and judged (1 s: a loopback round trip)
    assert time.monotonic() - t0 < 1.0
    assert "not as a Dask scheduler" in text


def test_a_malformed_address_is_refused():
    _refused_in_time(lambda: probe_scheduler("tcp://127.0.0.1:99999"))
    _refused_in_time(lambda: probe_scheduler("tcp://:8786"))


def test_a_real_scheduler_passes_the_probe():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, protocol="tcp", scheduler_port=0,
                      dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://")
        probe_scheduler(address)  # raises if the handshake is not recognised
        client = connect_scheduler(address)
        try:
            assert client.scheduler_info()["address"] == address
        finally:
            client.close()


def test_cluster_client_refuses_an_http_server(http_address):
    def enter():
        with cluster_client(1, http_address):
            pass

    _refused_in_time(enter)


def test_do_no_harm_refuses_an_http_scheduler_before_any_line(http_address, humber):
    from bridgeflap.design.assessment.harm import do_no_harm
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    lines = []
    k = Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0, flap_chord_m=3.0)
    _refused_in_time(lambda: do_no_harm(k, humber, count=2, n_modes=4, scheduler=http_address,
                                        progress=lines.append))
    assert lines == []


@pytest.mark.parametrize("command", ["robustness", "doe"])
def test_cli_refuses_an_http_scheduler_in_one_line(command, http_address, tmp_path, capsys,
                                                   monkeypatch):
    from bridgeflap.design.cli.main import main
    from bridgeflap.model.aeroelastic.control import Compensator, Controller
    from bridgeflap.model.aeroelastic.controller_file import save_controller

    monkeypatch.chdir(tmp_path)
    if command == "robustness":
        path = save_controller(Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0,
                                          flap_chord_m=3.0), tmp_path / "c.toml")
        argv = ["robustness", "--controller", str(path), "--samples", "2", "--modes", "4"]
    else:
        (tmp_path / "doe.toml").write_text(
            'name = "tiny"\nbridge = "humber"\nanalysis = "flutter"\n[options]\n'
            'speeds = "0:120:2"\nmodes = 4\n[design]\nkind = "full-factorial"\n'
            '[parameters]\n"deck.gj_nm2" = { values = [3.0e11] }\n')
        argv = ["doe", "doe.toml", "--out", "never"]
    before = sorted(p.name for p in tmp_path.iterdir())
    t0 = time.monotonic()
    rc = main([*argv, "--scheduler", http_address])
    assert time.monotonic() - t0 < BOUND_S
    cap = capsys.readouterr()
    err = cap.err.splitlines()
    assert rc == 2 and cap.out == "", cap
    assert len(err) == 1 and err[0].startswith("bridgeflap: error: scheduler:"), err
    assert "internal error" not in cap.err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
