"""``mrcheck review`` against hostile uploads: BCF zip bombs and malformed zips, photo
decompression bombs, requests from other sites' pages, and BCF imports that would match a
marker many times. Through the app (TestClient) and a real server on a loopback port, whose
memory is read from /proc while it refuses a bomb and answers other requests."""

from __future__ import annotations

import bz2
import concurrent.futures
import contextlib
import io
import json
import struct
import time
import urllib.request
import uuid
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.bcf import BcfComment, BcfTopic, bcf_bytes, read_bcf_bytes, topic_guid  # noqa: E402
from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.cli import main  # noqa: E402

from .test_review import box_review, served_box_review  # noqa: E402

# module fixtures of 3-5 s (a served review) and calls over 1 s: slow by tests/conftest.py's rule
pytestmark = pytest.mark.slow

ORIGIN = "http://127.0.0.1:8765"
MARKER = {"shot": "a", "x": 10.0, "y": 10.0, "category": "other", "severity": 1}
OCTETS = {"Content-Type": "application/octet-stream"}
MB = 1 << 20


@pytest.fixture()
def box(tmp_path):
    return box_review(tmp_path / "box", (0.0, 0.0, 0.0))


@contextlib.contextmanager
def _client(box, tmp_path, **options):
    app = create_app(box, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2, **options)
    with TestClient(app, base_url=ORIGIN) as client:
        yield client


@pytest.fixture()
def client(box, tmp_path):
    with _client(box, tmp_path, host="127.0.0.1") as c:
        yield c


# -- zips made by hand ---------------------------------------------------------------------------
def _markup(guid: str, snapshot: bool = False, comments=()) -> bytes:
    text = "".join(
        f'<Comment Guid="{uuid.uuid4()}"><Date>2026-02-01T10:00:00Z</Date><Author>{a}</Author>'
        f"<Comment>{c}</Comment></Comment>"
        for a, c in comments
    )
    view = f'<Viewpoints Guid="{uuid.uuid4()}"><Snapshot>snapshot.png</Snapshot></Viewpoints>' if snapshot else ""
    return (
        f'<Markup><Topic Guid="{guid}" TopicStatus="Closed"><Title>t</Title><Priority>High</Priority></Topic>'
        f"{text}{view}</Markup>"
    ).encode()


def _zip(entries: dict, method=zipfile.ZIP_DEFLATED) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", method) as z:
        z.writestr("bcf.version", '<Version VersionId="2.1"/>')
        for name, data in entries.items():
            z.writestr(name, data)
    return out.getvalue()


def _raw_zip(entries: list) -> bytes:
    """A zip of ``(name, method, packed bytes, crc, unpacked size)`` entries, packed by the caller:
    what zipfile would compress again (a bzip2 stream made once, written many times)."""
    local, central = io.BytesIO(), io.BytesIO()
    for name, method, packed, crc, size in entries:
        offset, name = local.tell(), name.encode()
        local.write(
            struct.pack("<IHHHHHIIIHH", 0x04034B50, 46, 0, method, 0, 0x21, crc, len(packed), size, len(name), 0)
        )
        local.write(name + packed)
        central.write(
            struct.pack(
                "<IHHHHHHIIIHHHHHII",
                0x02014B50,
                46,
                46,
                0,
                method,
                0,
                0x21,
                crc,
                len(packed),
                size,
                len(name),
                0,
                0,
                0,
                0,
                0,
                offset,
            )
            + name
        )
    start, count, directory = local.tell(), len(entries), central.getvalue()
    end = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, count, count, len(directory), start, 0)
    return local.getvalue() + directory + end


def _patch(data: bytes, name: str, **fields) -> bytes:
    """``data`` with the entry ``name``'s ``flags``, ``method`` or ``size`` changed in its central
    directory record and its local header (what a damaged or hostile zip says)."""
    data = bytearray(data)
    central = {"flags": (8, "<H"), "method": (10, "<H"), "size": (24, "<I")}
    local = {"flags": (6, "<H"), "method": (8, "<H"), "size": (22, "<I")}
    pos = data.find(b"PK\x01\x02")
    while pos >= 0:
        length = struct.unpack_from("<H", data, pos + 28)[0]
        if data[pos + 46 : pos + 46 + length] == name.encode():
            header = struct.unpack_from("<I", data, pos + 42)[0]
            for key, value in fields.items():
                struct.pack_into(central[key][1], data, pos + central[key][0], value)
                struct.pack_into(local[key][1], data, header + local[key][0], value)
            return bytes(data)
        pos = data.find(b"PK\x01\x02", pos + 4)
    raise KeyError(name)


@pytest.fixture(scope="module")
def bzip2_bomb():
    """The issue's bomb, smaller: 8 topics, each snapshot a 60 MB run of zeros as bzip2 (81 bytes)."""
    zeros = b"\0" * (60 * MB)
    packed, crc = bz2.compress(zeros), zlib.crc32(zeros)
    entries = [("bcf.version", 0, b'<Version VersionId="2.1"/>', zlib.crc32(b'<Version VersionId="2.1"/>'), 26)]
    for k in range(8):
        guid = str(uuid.uuid4())
        markup = _markup(guid, snapshot=True)
        entries.append((f"{guid}/markup.bcf", 0, markup, zlib.crc32(markup), len(markup)))
        entries.append((f"{guid}/snapshot.png", zipfile.ZIP_BZIP2, packed, crc, len(zeros)))
    return _raw_zip(entries)


@pytest.fixture(scope="module")
def lying_bomb():
    """A topic's markup followed by 160 MB of blanks, deflated (160 kB), whose directory says 1 kB."""
    guid = str(uuid.uuid4())
    return _patch(_zip({f"{guid}/markup.bcf": _markup(guid) + b" " * (160 * MB)}), f"{guid}/markup.bcf", size=1000)


# -- a real server ------------------------------------------------------------------------------
@pytest.fixture()
def server(tmp_path):
    """``mrcheck review SCENE --shots DIR --max-body 8MiB`` on a free port: (port, process)."""
    with served_box_review(tmp_path, "8MiB") as served:
        yield served


def _post(port, path, data: bytes, headers=OCTETS, timeout=120):
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", data=data, headers=headers, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:
            return answer.status, json.loads(answer.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def _rss_kib(pid: int, field: str) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(next(line.split()[1] for line in status.splitlines() if line.startswith(field + ":")))


def _while_answering(port, pid, call, answered=None):
    """``call()``'s result while GET /api/info is asked every 50 ms: (result, its seconds, the
    slowest GET's seconds, the server's peak memory growth in MB); ``answered``: a list that
    gets one entry per GET answered while ``call`` ran."""
    Path(f"/proc/{pid}/clear_refs").write_text("5")  # the peak (VmHWM) starts again from now
    before = _rss_kib(pid, "VmRSS")
    slowest, done, running = [0.0], [], []
    answered = [] if answered is None else answered

    def poll():
        while not done:
            start = time.perf_counter()
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=60).read()
            slowest[0] = max(slowest[0], time.perf_counter() - start)
            if running and not done:
                answered.append(start)
            time.sleep(0.05)

    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        poller = pool.submit(poll)
        time.sleep(0.2)
        start = time.perf_counter()
        running.append(True)
        try:
            result = call()
        finally:
            seconds = time.perf_counter() - start
            done.append(True)
        poller.result()
    return result, seconds, slowest[0], (_rss_kib(pid, "VmHWM") - before) / 1024


@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="reads the server's memory from /proc")
def test_zip_bombs_are_refused_at_once_without_memory(server, bzip2_bomb, lying_bomb):
    """The issue's bomb (bzip2 snapshots of 60 MB each: 480 MB from 2 kB) took the server to GBs
    and held every request; refused from the zip's directory now. A deflated entry whose
    directory lies about its size is stopped at the size it claims."""
    port, proc = server
    for bomb, reason in ((bzip2_bomb, "unpacks to 480.0 MiB (at most 256.0 MiB)"), (lying_bomb, "Bad CRC-32")):
        (status, answer), seconds, slowest, grown = _while_answering(
            port, proc.pid, lambda: _post(port, "/api/bcf/import", bomb)
        )
        measured = f"{answer}: {seconds:.2f} s, {grown:.0f} MB grown, slowest other request {slowest:.2f} s"
        assert status == 400 and reason in answer.get("error", ""), measured
        assert seconds < 1.0 and grown < 100 and slowest < 0.5, measured
    assert proc.poll() is None


def test_the_server_answers_other_requests_while_a_bcf_file_is_imported(server):
    """4,000 topics (none of this review) take a while to read: other requests are answered meanwhile."""
    port, proc = server
    topics = {}
    for k in range(4000):
        guid = str(uuid.uuid4())
        topics[f"{guid}/markup.bcf"] = _markup(guid, comments=[("a", "b" * 200)] * 20)
    data, answered = _zip(topics), []
    (status, answer), seconds, slowest, _ = _while_answering(
        port, proc.pid, lambda: _post(port, "/api/bcf/import", data), answered
    )
    assert status == 200 and answer == {"matched": 0, "added": 0, "unknown": 4000}, answer
    measured = f"import {seconds:.2f} s, slowest other request {slowest:.2f} s, {len(answered)} answered meanwhile"
    assert slowest < 0.5 and len(answered) >= 3, measured


# -- malformed zips and what an import may hold -------------------------------------------------
def _export(client, count=2) -> tuple[list, bytes]:
    markers = [client.post("/api/markers", json={**MARKER, "x": 5.0 + k}).json() for k in range(count)]
    return markers, client.get("/api/bcf/markers.bcfzip").content


def test_malformed_zips_are_a_400_with_the_reason(client):
    markers, data = _export(client, 1)
    name = next(n for n in zipfile.ZipFile(io.BytesIO(data)).namelist() if n.endswith("markup.bcf"))
    stored = _zip({n: zipfile.ZipFile(io.BytesIO(data)).read(n) for n in [name]}, zipfile.ZIP_STORED)
    at = stored.find(b"<Title>") + 8
    cases = {
        "bad CRC": (stored[:at] + b"X" + stored[at + 1 :], "Bad CRC-32"),
        "encrypted": (_patch(data, name, flags=1), "is encrypted"),
        "Zstandard": (_patch(data, name, method=93), "compressed with Zstandard"),
        "bzip2": (_zip({name: zipfile.ZipFile(io.BytesIO(data)).read(name)}, zipfile.ZIP_BZIP2), "with bzip2"),
    }
    for what, (bad, reason) in cases.items():
        r = client.post("/api/bcf/import", content=bad, headers=OCTETS)
        assert r.status_code == 400 and reason in r.json()["error"], (what, r.text)
    assert client.get("/api/markers").json()[0]["status"] == "Open"


def test_bcf_comments_are_capped_as_notes_are(client):
    markers, data = _export(client, 1)
    guid = read_bcf_bytes(data)[0].guid
    for comments, reason in (
        ([("site", "x" * 2001)], "a comment of 2001 characters (at most 2000, as a note)"),
        ([("site", "ok")] * 201, "201 comments (at most 200)"),
        ([("x" * 201, "ok")], "a comment's author of 201 characters"),
    ):
        r = client.post(
            "/api/bcf/import", content=_zip({f"{guid}/markup.bcf": _markup(guid, comments=comments)}), headers=OCTETS
        )
        assert r.status_code == 400 and reason in r.json()["error"], r.text
        assert client.get("/api/markers").json()[0]["comments"] == []
    fine = _zip({f"{guid}/markup.bcf": _markup(guid, comments=[("site", "x" * 2000)])})
    assert client.post("/api/bcf/import", content=fine, headers=OCTETS).json() == {
        "matched": 1,
        "added": 0,
        "unknown": 0,
    }
    assert client.get("/api/markers").json()[0]["comments"][0]["text"] == "x" * 2000


def test_a_topic_in_a_file_twice_is_refused_not_matched_twice(client):
    """Two markers, and one topic copied into a second folder: this said "matched 3"."""
    markers, data = _export(client, 2)
    first = read_bcf_bytes(data)[0].guid
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        entries = {n: z.read(n) for n in z.namelist() if n != "bcf.version"}
    entries["copy/markup.bcf"] = entries[f"{first}/markup.bcf"]
    r = client.post("/api/bcf/import", content=_zip(entries), headers=OCTETS)
    assert r.status_code == 400 and f"the topic {first} is in the file twice" in r.json()["error"], r.text
    assert [m["status"] for m in client.get("/api/markers").json()] == ["Open", "Open"]


def test_many_topics_of_one_marker_are_refused_at_once(client):
    """10,000 topics of one marker blocked the server for 13 s (a commit per topic); 2,000 here."""
    markers, data = _export(client, 1)
    guid = read_bcf_bytes(data)[0].guid
    body = _zip({f"t{k}/markup.bcf": _markup(guid) for k in range(2000)})
    start = time.perf_counter()
    r = client.post("/api/bcf/import", content=body, headers=OCTETS)
    assert r.status_code == 400 and "twice" in r.json()["error"] and time.perf_counter() - start < 1.0, r.text


def test_a_bcf_file_of_too_many_topics_or_entries_is_refused_from_its_directory(box, tmp_path):
    from mrcheck.apps.bcf.archive import MAX_ENTRIES
    from mrcheck.apps.bcf.read import MAX_TOPICS

    with _client(box, tmp_path, max_body=8 * MB) as client:
        topics = _zip({f"t{k}/markup.bcf": b"" for k in range(MAX_TOPICS + 1)}, zipfile.ZIP_STORED)
        r = client.post("/api/bcf/import", content=topics, headers=OCTETS)
        assert r.status_code == 400 and f"{MAX_TOPICS + 1} topics (at most {MAX_TOPICS}" in r.json()["error"], r.text
        entries = _zip({f"e{k}": b"" for k in range(MAX_ENTRIES)}, zipfile.ZIP_STORED)
        r = client.post("/api/bcf/import", content=entries, headers=OCTETS)
        assert r.status_code == 400 and f"{MAX_ENTRIES + 1} entries" in r.json()["error"], r.text


# -- other sites' pages -----------------------------------------------------------------------------
def test_requests_from_other_sites_change_nothing(client):
    """A page elsewhere may POST text/plain without a preflight; Origin and Sec-Fetch-Site say where it is."""
    marker = client.post("/api/markers", json=MARKER, headers={"Origin": ORIGIN, "Sec-Fetch-Site": "same-origin"})
    assert marker.status_code == 201, marker.text
    body = json.dumps({**MARKER, "note": "forged"})
    foreign = {"Origin": "http://attacker.example", "Sec-Fetch-Site": "cross-site", "Content-Type": "text/plain"}
    for headers in (
        foreign,
        {"Origin": "http://attacker.example"},
        {"Sec-Fetch-Site": "cross-site"},
        {"Origin": "null"},
    ):
        r = client.post("/api/markers", content=body, headers={"Content-Type": "application/json", **headers})
        assert r.status_code == 403 and r.json()["error"].startswith("cross-site request refused"), r.text
    other_port = {"Origin": "http://127.0.0.1:3000", "Sec-Fetch-Site": "same-site"}
    assert client.delete(f"/api/markers/{marker.json()['id']}", headers=other_port).status_code == 403
    # the forgery: a BCF file sent as text/plain from another origin
    guid = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)[0].guid
    changed = _zip({f"{guid}/markup.bcf": _markup(guid, comments=[("x", "forged")])})
    assert client.post("/api/bcf/import", content=changed, headers=foreign).status_code == 403
    r = client.post(
        "/api/addphoto/upload", params={"kind": "photo", "filename": "p.png"}, content=b"x", headers=foreign
    )
    assert r.status_code == 403
    assert [(m["note"], m["status"]) for m in client.get("/api/markers").json()] == [("", "Open")]


def test_state_changing_routes_take_their_content_type_only(client):
    plain = {"Content-Type": "text/plain"}
    r = client.post("/api/markers", content=json.dumps(MARKER), headers=plain)
    assert r.status_code == 415 and r.json()["error"] == "Content-Type must be application/json (got text/plain)"
    assert client.post("/api/markers", content=json.dumps(MARKER)).status_code == 415  # none at all
    r = client.post("/api/bcf/import", content=b"PK", headers={"Content-Type": "multipart/form-data; boundary=x"})
    assert r.status_code == 415 and "application/octet-stream" in r.json()["error"]
    r = client.post("/api/addphoto/upload", params={"kind": "photo", "filename": "p.png"}, content=b"x", headers=plain)
    assert r.status_code == 415
    assert client.post("/api/addphoto/solve", content="{}", headers=plain).status_code == 415
    assert client.get("/api/markers").json() == []


def test_topic_guids_are_random_kept_and_old_ones_stay(box, tmp_path):
    """The GUID was uuid5 of a namespace in the source, the database path and the marker id: any
    page could compute it. Now a uuid4 kept with the marker; a marker of an older database keeps
    the GUID its exports had."""
    with _client(box, tmp_path) as c:
        marker = c.post("/api/markers", json=MARKER).json()
        guid = read_bcf_bytes(c.get("/api/bcf/markers.bcfzip").content)[0].guid
        legacy = topic_guid("review", (tmp_path / "r.sqlite").resolve(), 1, marker["id"])
        assert uuid.UUID(guid).version == 4 and guid != legacy
        assert read_bcf_bytes(c.get("/api/bcf/markers.bcfzip").content)[0].guid == guid
    import sqlite3

    db = sqlite3.connect(tmp_path / "r.sqlite")
    db.execute("ALTER TABLE markers DROP COLUMN guid")  # a database of an earlier mrcheck
    db.commit()
    db.close()
    with _client(box, tmp_path) as c:
        assert read_bcf_bytes(c.get("/api/bcf/markers.bcfzip").content)[0].guid == legacy
        assert c.post("/api/markers", json=MARKER).status_code == 201


# -- photos ------------------------------------------------------------------------------------------
def _png_bomb(width: int, height: int) -> bytes:
    """A 1-bit grey PNG of ``width`` x ``height`` zeros: a few hundred kB, 3 bytes a pixel decoded."""
    chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))  # noqa: E731
    packer, row = zlib.compressobj(9), b"\0" * (1 + (width + 7) // 8)
    idat = b"".join(packer.compress(row * 1000) for _ in range(height // 1000)) + packer.flush()
    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="reads the server's memory from /proc")
def test_a_png_bomb_is_refused_on_its_header(server):
    """A 20000 x 20000 px PNG (1.2 GB decoded) was accepted after seconds and decoded again on GET."""
    port, proc = server
    bomb = _png_bomb(20000, 20000)
    (status, answer), seconds, slowest, grown = _while_answering(
        port, proc.pid, lambda: _post(port, "/api/addphoto/upload?kind=photo&filename=bomb.png", bomb)
    )
    measured = f"{answer}: {seconds:.2f} s, {grown:.0f} MB grown, slowest other request {slowest:.2f} s"
    assert status == 422 and "20000x20000 px (400.0 MP), over the limit of 64 MP" in answer["error"], measured
    assert seconds < 1.0 and grown < 100 and slowest < 0.5, measured


def test_a_photo_over_the_limit_is_refused_everywhere(tmp_path, capsys):
    """Upload, the folder's photos on GET, and the shots at start-up (--max-pixels)."""
    from mrcheck.apps.review.source import open_source

    box = box_review(tmp_path / "box", (0.0, 0.0, 0.0))
    photo = (tmp_path / "box" / "shots" / "photo.png").read_bytes()  # 64 x 48
    with _client(box, tmp_path) as c:
        c.app.state.review.source.max_pixels = 3000
        r = c.post("/api/addphoto/upload", params={"kind": "photo", "filename": "p.png"}, content=photo, headers=OCTETS)
        assert r.status_code == 422 and "64x48 px (0.0 MP), over the limit of 0.003 MP" in r.json()["error"], r.text
        (tmp_path / "box" / "shots" / "other.png").write_bytes(photo)
        r = c.get("/api/addphoto/photo.png", params={"photo": "folder:other.png"})
        assert r.status_code == 422 and "over the limit" in r.json()["error"], r.text
    with pytest.raises(Exception, match="over the limit of 0.003 MP"):
        open_source(tmp_path / "box" / "box.stl", tmp_path / "box" / "shots", max_pixels=3000)
    args = ["review", str(tmp_path / "box" / "box.stl"), "--shots", str(tmp_path / "box" / "shots")]
    code = main([*args, "--db", str(tmp_path / "x.sqlite"), "--max-pixels", "3000"])
    err = capsys.readouterr().err
    assert code == 1 and "photo is 64x48 px" in err and "(--max-pixels)" in err and err.count("\n") == 1, err
    assert main([*args, "--max-pixels", "lots"]) == 1 and "'lots' is not a pixel count" in capsys.readouterr().err


def test_image_sizes_from_their_headers():
    """Every format read agrees with OpenCV; a JPEG's EXIF thumbnail is not taken for the photo."""
    from mrcheck.core.images import check_pixels, encode_image

    image = np.zeros((37, 61, 3), np.uint8)
    for suffix in (".png", ".jpg", ".tif", ".bmp", ".webp", ".gif"):
        data = encode_image(suffix, image)
        assert check_pixels(data, 10_000) == (61, 37), suffix
    lossless = encode_image(".webp", image, quality=101)  # VP8L
    assert check_pixels(lossless, 10_000) == (61, 37)
    jpeg = encode_image(".jpg", image)
    thumbnail = b"Exif\0\0" + b"\xff\xc0\x00\x11\x08\x00\x10\x00\x10" + b"\0" * 20
    with_exif = jpeg[:2] + b"\xff\xe1" + struct.pack(">H", len(thumbnail) + 2) + thumbnail + jpeg[2:]
    assert check_pixels(with_exif, 10_000) == (61, 37)
    with pytest.raises(Exception, match="a text file, not an image"):
        check_pixels(b"these are notes", 100)
    with pytest.raises(Exception, match=r"a HDR image: only PNG, JPEG, TIFF, BMP, GIF, WebP, .* are taken"):
        check_pixels(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 30000 +X 30000\n", 100)
    with pytest.raises(Exception, match=r"truncated PNG \(the file ends before the image does"):
        check_pixels(encode_image(".png", image)[:20], 100)
    with pytest.raises(Exception, match=r"corrupt or truncated PNG \(header broken: "):
        check_pixels(encode_image(".png", image)[:20] + b"IEND\xaeB`\x82", 100)


def test_reading_bcf_in_memory_keeps_its_snapshots():
    topic = BcfTopic(guid=str(uuid.uuid4()), title="t", comments=[BcfComment("c", None, "a", "b")])
    topic.snapshot_png, topic.viewpoint_guid = b"\x89PNG", str(uuid.uuid4())
    assert read_bcf_bytes(bcf_bytes([topic]))[0].snapshot_png == b"\x89PNG"
