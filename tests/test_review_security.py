"""``mrcheck review`` against other sites' pages and oversized requests: the Host header must name
this server (DNS rebinding), and a body over the limit is refused with 413 before it is read.
Through the app (TestClient) and through a real server on a free port, with raw sockets for what
an HTTP client library will not send (no Host, a huge Content-Length without its body, a chunked
body that never ends)."""

from __future__ import annotations

import contextlib
import http.client
import json
import socket
import time

import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.guard import MAX_BODY, MIN_MAX_BODY, is_loopback, parse_size  # noqa: E402
from mrcheck.cli import main  # noqa: E402

from .test_review import box_review, served_box_review  # noqa: E402

CSV = "/api/export/markers.csv"  # what a rebinding page would read: every marker and its note
MARKER = {"shot": "a", "x": 10.0, "y": 10.0, "category": "other", "severity": 1}


@pytest.fixture()
def box(tmp_path):
    return box_review(tmp_path / "box", (0.0, 0.0, 0.0))


@contextlib.contextmanager
def _client(box, tmp_path, host="127.0.0.1", **options):
    app = create_app(box, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2, host=host, **options)
    with TestClient(app, base_url="http://127.0.0.1:8765") as client:
        yield client


# -- the Host header ------------------------------------------------------------------------------
ANSWERS = {  # bound address: (Host headers it answers, Host headers it refuses)
    "127.0.0.1": (
        [
            "127.0.0.1",
            "127.0.0.1:8765",
            "localhost",
            "LocalHost:8765",
            "localhost.",
            "[::1]",
            "[::1]:8765",
            "[0:0::1]:8765",
            "127.0.0.1:9000",
        ],  # another port: an SSH tunnel (ssh -L 9000:localhost:8765)
        [
            "attacker.example",
            "attacker.example:8765",
            "127.0.0.1.attacker.example",
            "localhost.attacker.example",
            "127.0.0.2",
            "10.0.0.5",
            "[::2]:8765",
            "",
            "::1",
            "[::1",
            "localhost:8765:1",
        ],
    ),
    "::1": (["[::1]:8765", "localhost", "127.0.0.1:8765"], ["attacker.example", "[::2]"]),
    "0.0.0.0": (
        [socket.gethostname(), f"{socket.gethostname()}:8765", "10.1.2.3:8765", "[fe80::1]", "localhost"],
        ["attacker.example", "10.1.2.3.nip.io", "fe80::1"],
    ),
}


@pytest.mark.parametrize("bound", sorted(ANSWERS))
def test_only_the_servers_own_names_are_answered(box, tmp_path, bound):
    good, bad = ANSWERS[bound]
    with _client(box, tmp_path, host=bound) as client:
        for host in good:
            r = client.get(CSV, headers={"Host": host})
            assert r.status_code == 200, (bound, host, r.text)
        for host in bad:
            r = client.get(CSV, headers={"Host": host})
            assert r.status_code == 403, (bound, host, r.status_code)
            error = r.json()["error"]
            assert f"Host {host!r} is not a name of this server" in error and "localhost" in error, error


def test_a_foreign_host_is_refused_before_the_token_is_looked_at(box, tmp_path):
    with _client(box, tmp_path, host="0.0.0.0", token="s3cret") as client:
        assert client.get(CSV, params={"token": "s3cret"}, headers={"Host": "attacker.example"}).status_code == 403
        assert client.get(CSV, headers={"Host": "10.1.2.3:8765"}).status_code == 401
        assert client.get(CSV, params={"token": "s3cret"}, headers={"Host": "10.1.2.3:8765"}).status_code == 200


def test_loopback_means_a_loopback_address_not_a_name_starting_with_127():
    # a name such as 127.attacker.example was taken for loopback: served without a token
    assert all(map(is_loopback, ["127.0.0.1", "127.3.4.5", "::1", "[::1]", "localhost", "LOCALHOST."]))
    assert not any(
        map(is_loopback, ["127.attacker.example", "localhost.attacker.example", "0.0.0.0", "::", "10.0.0.1"])
    )


# -- the body's size ------------------------------------------------------------------------------
def test_a_declared_body_over_the_limit_is_refused_before_any_route_runs(box, tmp_path):
    with _client(box, tmp_path) as client:
        r = client.post("/api/markers", content=b"x" * (MAX_BODY + 1), headers={"Content-Type": "application/json"})
        assert r.status_code == 413, r.text
        assert r.json() == {
            "error": f"request body too large: {MAX_BODY + 1} bytes, over the limit of 1 MiB (--max-body)"
        }
        assert client.request("GET", "/api/info", content=b"x" * (MAX_BODY + 1)).status_code == 413
        assert client.get("/api/markers").json() == []


def test_a_chunked_body_is_refused_once_past_the_limit(box, tmp_path):
    def chunks():  # no Content-Length: httpx sends a generator chunked
        yield b'{"note": "'
        for _ in range(80):
            yield b"x" * 1024

    with _client(box, tmp_path, max_body=MIN_MAX_BODY) as client:
        r = client.post("/api/markers", content=chunks(), headers={"Content-Type": "application/json"})
        assert r.status_code == 413, r.text
        assert r.json() == {"error": "request body too large: over the limit of 64 KiB (--max-body)"}


def test_the_smallest_limit_takes_the_largest_marker(box, tmp_path):
    """2000 characters outside the BMP, each escaped as two \\uXXXX (12 bytes): the largest body
    a marker can have is within MIN_MAX_BODY."""
    body = json.dumps({**MARKER, "note": "\U0001f600" * 2000}).encode()
    assert len(body) > 24000
    with _client(box, tmp_path, max_body=MIN_MAX_BODY) as client:
        r = client.post("/api/markers", content=body, headers={"Content-Type": "application/json"})
        assert r.status_code == 201, r.text
        assert client.get("/api/markers").json()[0]["note"] == "\U0001f600" * 2000


def test_sizes():
    assert [parse_size(s) for s in ("1MiB", "64KiB", "2M", "1 mib", "1048576", "1g")] == [
        1 << 20,
        64 << 10,
        2 << 20,
        1 << 20,
        1048576,
        1 << 30,
    ]
    for bad in ("lots", "1.5MiB", "-1", "1TiB", ""):
        with pytest.raises(ValueError):
            parse_size(bad)


@pytest.mark.parametrize("value, message", [("lots", "'lots' is not a size"), ("1KiB", "at least 64 KiB")])
def test_a_bad_max_body_is_one_line(box, tmp_path, capsys, value, message):
    code = main(["review", str(box.origin), "--max-body", value, "--db", str(tmp_path / "r.sqlite")])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith("error: ") and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "r.sqlite").exists()


# -- a real server ------------------------------------------------------------------------------
@pytest.fixture()
def server(tmp_path):
    """``mrcheck review SCENE --shots DIR --max-body 64KiB`` on a free port: (port, process)."""
    with served_box_review(tmp_path, "64KiB") as served:
        yield served


def _exchange(port, head: str, body=(), timeout=10.0):
    """Send ``head`` (request line and headers, without the blank line) and the ``body`` parts;
    (status, JSON or text) of the answer. A server still waiting for more is a socket timeout."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as sock:
        sock.sendall(head.encode() + b"\r\n\r\n")
        for part in body:
            sock.sendall(part)
        answer = http.client.HTTPResponse(sock)
        answer.begin()
        text = answer.read().decode()
        return answer.status, json.loads(text) if answer.getheader("content-type", "").startswith(
            "application/json"
        ) else text


@pytest.mark.slow
def test_the_real_server_answers_only_its_own_names(server):
    port, _ = server
    status, error = _exchange(port, f"GET {CSV} HTTP/1.1\r\nHost: attacker.example")
    assert status == 403 and "attacker.example" in error["error"]
    assert _exchange(port, f"GET {CSV} HTTP/1.1\r\nHost: localhost:{port}")[0] == 200
    status, error = _exchange(port, f"GET {CSV} HTTP/1.0")  # HTTP/1.0 needs no Host; a browser always sends one
    assert status == 403 and error["error"].startswith("no Host header")


@pytest.mark.slow
def test_the_real_server_refuses_a_huge_declared_body_without_reading_it(server):
    port, _ = server
    start = time.perf_counter()
    # a 1 GiB note announced, not one byte of it sent: a server that reads it first times out here
    status, error = _exchange(
        port,
        f"POST /api/markers HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
        f"Content-Type: application/json\r\nContent-Length: {1 << 30}",
        timeout=5,
    )
    assert status == 413 and "1073741824 bytes, over the limit of 64 KiB" in error["error"]
    assert time.perf_counter() - start < 5


@pytest.mark.slow
def test_the_real_server_stops_reading_a_chunked_body_at_the_limit(server):
    port, proc = server
    # 64 KiB + 1 byte in chunks and no last chunk: a server that waits for the end times out here
    data = [b'{"note": "', b"x" * (MIN_MAX_BODY - 10), b"x"]
    chunks = [b"%x\r\n%s\r\n" % (len(d), d) for d in data]
    status, error = _exchange(
        port,
        f"POST /api/markers HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
        "Content-Type: application/json\r\nTransfer-Encoding: chunked",
        chunks,
        timeout=5,
    )
    assert status == 413 and error == {"error": "request body too large: over the limit of 64 KiB (--max-body)"}
    assert _exchange(port, f"GET /api/markers HTTP/1.1\r\nHost: 127.0.0.1:{port}") == (200, [])
    assert proc.poll() is None
