"""``mrcheck review`` over HTTPS: the certificate of ``--self-signed`` (its names, kept on the
next start, made anew when it nearly ends or the names change, its key private), the one-line
errors of ``--tls-cert``/``--tls-key`` before the port is bound, and a server that answers
https and wss against the certificate it printed (also in headless Chromium, where the page is
a secure context with a camera API).

Test certificates are made here with ``cryptography``; no key file is committed."""

from __future__ import annotations

import base64
import contextlib
import hashlib
import json
import socket
import ssl
import stat
import threading
import time
from datetime import timedelta

import pytest

pytest.importorskip("fastapi")
uvicorn = pytest.importorskip("uvicorn")

from cryptography import x509  # noqa: E402
from cryptography.hazmat.primitives import hashes, serialization  # noqa: E402
from cryptography.hazmat.primitives.asymmetric import ec  # noqa: E402
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID  # noqa: E402

from mrcheck.apps.review.selfsigned import (  # noqa: E402
    RENEW_BEFORE,
    VALIDITY,
    ServerNames,
    certificate_names,
    machine_addresses,
    self_signed_tls,
    server_names,
)
from mrcheck.apps.review.server import start  # noqa: E402
from mrcheck.apps.review.tls import TRUST_HOW, TlsOptions, utc_now  # noqa: E402
from mrcheck.cli import main  # noqa: E402

from .project_files import check_error, free_port  # noqa: E402
from .test_review import box_review, needs_chromium, open_browser  # noqa: E402


@pytest.fixture()
def box(tmp_path):
    """A review's command line arguments: a box scene and its shots folder, a database."""
    folder = tmp_path / "box"
    box_review(folder, (0.0, 0.0, 0.0))
    (tmp_path / "review").mkdir()
    return [folder / "box.stl", "--shots", folder / "shots", "--db", tmp_path / "review" / "r.sqlite"]


@pytest.fixture()
def no_serving(monkeypatch):
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: None)  # start, print, stop


def _review(capsys, *args):
    code = main(["review", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _load(path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def _pem_pair(folder, name="server", days=30, start_days=-1, key=None):
    """A self-signed certificate for 127.0.0.1 and its key, written to NAME.pem and NAME-key.pem;
    ``key``: the key to write instead of the certificate's (a mismatch)."""
    own = ec.generate_private_key(ec.SECP256R1())
    now, subject = utc_now(), x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "test")])
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(own.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + timedelta(days=start_days))
        .not_valid_after(now + timedelta(days=days))
        .add_extension(x509.SubjectAlternativeName([x509.DNSName("localhost")]), critical=False)
        .sign(own, hashes.SHA256())
    )
    cert_path, key_path = folder / f"{name}.pem", folder / f"{name}-key.pem"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(_key_pem(key or own))
    return cert_path, key_path


def _key_pem(key, encryption=None) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        encryption or serialization.NoEncryption(),
    )


# -- the certificate of --self-signed -------------------------------------------------------------
def test_the_certificate_names_the_bound_address(tmp_path):
    import ipaddress

    local = certificate_names(_load(self_signed_tls(tmp_path / "local", server_names("127.0.0.1")).cert))
    assert {"localhost", socket.gethostname().lower()} <= local.dns
    assert {ipaddress.ip_address("127.0.0.1"), ipaddress.ip_address("::1")} <= local.ips
    everywhere = certificate_names(_load(self_signed_tls(tmp_path / "all", server_names("0.0.0.0")).cert))
    assert machine_addresses() <= everywhere.ips and local.dns <= everywhere.dns
    assert not any(ip.is_unspecified for ip in everywhere.ips)  # never 0.0.0.0 itself
    other = certificate_names(_load(self_signed_tls(tmp_path / "one", server_names("192.0.2.7")).cert))
    assert ipaddress.ip_address("192.0.2.7") in other.ips


def test_the_server_certificate_is_signed_by_the_one_to_trust(tmp_path):
    """ca.pem (what a tablet installs) says CA:TRUE, as Android and iOS need; cert.pem, served,
    is an EC P-256 server certificate of a year that says CA:FALSE; ca.pem's key is not kept."""
    tls = self_signed_tls(tmp_path / "tls", ServerNames.of(["localhost", "127.0.0.1"]))
    ca, cert = _load(tls.trust), _load(tls.cert)
    cert.verify_directly_issued_by(ca)
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    assert not cert.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    usage = cert.extensions.get_extension_for_class(x509.KeyUsage).value
    assert usage.digital_signature and not usage.key_cert_sign
    eku = cert.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
    assert list(eku) == [ExtendedKeyUsageOID.SERVER_AUTH]
    assert isinstance(cert.public_key(), ec.EllipticCurvePublicKey) and cert.public_key().curve.name == "secp256r1"
    assert timedelta(days=364) < cert.not_valid_after_utc - cert.not_valid_before_utc <= VALIDITY + timedelta(days=1)
    assert sorted(p.name for p in (tmp_path / "tls").iterdir()) == ["ca.pem", "cert.pem", "key.pem"]
    assert stat.S_IMODE((tmp_path / "tls" / "key.pem").stat().st_mode) == 0o600
    assert stat.S_IMODE((tmp_path / "tls").stat().st_mode) == 0o700
    assert tls.fingerprint == ca.fingerprint(hashes.SHA256()).hex(":").upper()


def test_the_certificate_is_kept_on_the_next_start(tmp_path):
    names = ServerNames.of(["localhost", "127.0.0.1"])
    first = self_signed_tls(tmp_path, names)
    files = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    again = self_signed_tls(tmp_path, names)
    assert first.made and not again.made and again.fingerprint == first.fingerprint
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == files
    # a start that needs fewer names (loopback after 0.0.0.0) keeps it too
    assert not self_signed_tls(tmp_path, ServerNames.of(["localhost"])).made


def test_a_certificate_that_nearly_ends_is_made_anew(tmp_path):
    names = ServerNames.of(["localhost"])
    ends_soon = utc_now() - VALIDITY + RENEW_BEFORE - timedelta(days=1)
    old = self_signed_tls(tmp_path, names, now=ends_soon)
    assert old.not_after - utc_now() < RENEW_BEFORE
    new = self_signed_tls(tmp_path, names)
    assert new.made and new.fingerprint != old.fingerprint and new.not_after - utc_now() > VALIDITY - timedelta(days=1)
    ends_later = utc_now() - VALIDITY + RENEW_BEFORE + timedelta(days=1)  # more than RENEW_BEFORE left: kept
    kept = self_signed_tls(tmp_path / "later", names, now=ends_later)
    assert not self_signed_tls(tmp_path / "later", names).made and kept.made


def test_a_certificate_of_other_names_is_made_anew(tmp_path):
    first = self_signed_tls(tmp_path, ServerNames.of(["localhost"]))
    wider = self_signed_tls(tmp_path, ServerNames.of(["localhost", "192.0.2.7", "[2001:db8::5]"]))
    assert wider.made and wider.fingerprint != first.fingerprint
    assert {"localhost", "192.0.2.7", "2001:db8::5"} <= set(wider.names)


@pytest.mark.parametrize("damage", ["cert.pem", "key.pem", "ca.pem"])
def test_damaged_or_foreign_certificates_are_made_anew(tmp_path, damage):
    names = ServerNames.of(["localhost"])
    first = self_signed_tls(tmp_path, names)
    other = self_signed_tls(tmp_path / "other", names)  # valid, but not this pair's
    (tmp_path / damage).write_bytes((tmp_path / "other" / damage).read_bytes())
    again = self_signed_tls(tmp_path, names)
    assert again.made and again.fingerprint not in (first.fingerprint, other.fingerprint)
    (tmp_path / "cert.pem").write_text("garbage")
    assert self_signed_tls(tmp_path, names).made


def test_self_signed_prints_what_to_trust_and_keeps_it(box, tmp_path, capsys, no_serving):
    port = free_port()
    code, out, err = _review(capsys, *box, "--port", port, "--self-signed")
    ca = tmp_path / "review" / "review-tls" / "ca.pem"
    fingerprint = _load(ca).fingerprint(hashes.SHA256()).hex(":").upper()
    assert code == 0 and f"https: certificate {ca} (made now; SHA-256 {fingerprint}) for " in out, out + err
    assert f"{TRUST_HOW}\nopen https://127.0.0.1:{port}/\n" in out
    code, out, err = _review(capsys, *box, "--port", free_port(), "--self-signed")
    assert code == 0 and f"https: certificate {ca} (kept from an earlier start; SHA-256 {fingerprint})" in out


def test_a_given_certificate_is_served(box, tmp_path, capsys, no_serving):
    cert, key = _pem_pair(tmp_path)
    port = free_port()
    code, out, err = _review(capsys, *box, "--port", port, "--tls-cert", cert, "--tls-key", key)
    assert code == 0 and f"https: {cert}, valid until " in out and f"open https://127.0.0.1:{port}/\n" in out, err
    assert not (tmp_path / "review" / "review-tls").exists()


# -- --tls-cert and --tls-key: one line, before the port is bound ----------------------------------
def _bad_files(tmp_path, case):
    """(--tls-cert, --tls-key, the error's fragments) of a refused pair."""
    cert, key = _pem_pair(tmp_path)
    if case == "missing certificate":
        return tmp_path / "gone.pem", key, [f"{tmp_path / 'gone.pem'}: not found"]
    if case == "missing key":
        return cert, tmp_path / "gone.pem", [f"{tmp_path / 'gone.pem'}: not found"]
    if case == "a folder":
        return tmp_path, key, [f"{tmp_path}: is a folder"]
    if case == "no certificate":
        return key, key, [f"{key}: no PEM certificate in it"]
    if case == "no key":
        return cert, cert, [f"{cert}: no PEM private key in it"]
    if case == "another key":
        other, other_key = _pem_pair(tmp_path, "other")
        return cert, other_key, [f"{other_key}: is not the private key of {cert}"]
    if case == "expired":
        old, old_key = _pem_pair(tmp_path, "old", days=-2, start_days=-30)
        return old, old_key, [f"{old}: the certificate expired on {(utc_now() - timedelta(days=2)):%Y-%m-%d}"]
    if case == "not yet valid":
        early, early_key = _pem_pair(tmp_path, "early", days=30, start_days=3)
        return early, early_key, [f"{early}: the certificate is valid from "]
    assert case == "encrypted key"
    locked = tmp_path / "locked.pem"
    own = serialization.load_pem_private_key(key.read_bytes(), None)
    locked.write_bytes(_key_pem(own, serialization.BestAvailableEncryption(b"secret")))
    return cert, locked, [f"{locked}: the private key is encrypted"]


CASES = [
    "missing certificate",
    "missing key",
    "a folder",
    "no certificate",
    "no key",
    "another key",
    "expired",
    "not yet valid",
    "encrypted key",
]


@pytest.mark.parametrize("case", CASES)
def test_a_bad_certificate_or_key_is_one_line_before_the_port(box, tmp_path, capsys, case):
    cert, key, fragments = _bad_files(tmp_path, case)
    with socket.socket() as busy:  # a busy port: the files are checked before it is bound
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        code, out, err = _review(capsys, *box, "--port", busy.getsockname()[1], "--tls-cert", cert, "--tls-key", key)
    check_error(code, err, out, *fragments)
    assert list((tmp_path / "review").iterdir()) == []  # no database


@pytest.mark.parametrize(
    "options, fragment",
    [
        (["--tls-cert", "c.pem"], "--tls-cert and --tls-key go together"),
        (["--tls-key", "k.pem"], "--tls-cert and --tls-key go together"),
        (["--self-signed", "--tls-cert", "c.pem", "--tls-key", "k.pem"], "--self-signed makes its own certificate"),
        (["--tls-cert", "", "--tls-key", "k.pem"], "--tls-cert must not be empty"),
    ],
)
def test_options_that_do_not_go_together(box, tmp_path, capsys, options, fragment):
    code, out, err = _review(capsys, *box, "--port", free_port(), *options)
    check_error(code, err, out, fragment)
    assert list((tmp_path / "review").iterdir()) == []


# -- served: https and wss against the certificate printed ------------------------------------------
@contextlib.contextmanager
def _served(tmp_path):
    """The review of :func:`box` started with ``--self-signed`` and a token on 127.0.0.1 and
    served by uvicorn in a thread: yields the ReviewServer."""
    folder = tmp_path / "box"
    review = start(
        folder / "box.stl",
        shots_dir=folder / "shots",
        port=free_port(),
        db=tmp_path / "review" / "r.sqlite",
        token="secret",
        tls=TlsOptions(self_signed=True),
    )
    server = uvicorn.Server(review.config())
    thread = threading.Thread(target=server.run, kwargs={"sockets": [review.sock]}, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + 30
        while not server.started and thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert server.started
        yield review
    finally:
        server.should_exit = True
        thread.join(30)
        review.close()


def test_https_and_wss_answer_with_the_printed_certificate(box, tmp_path):
    import httpx
    from websockets.sync.client import connect

    with _served(tmp_path) as review:
        base = review.url.split("?")[0]
        assert review.url == f"{base}?token=secret" and base.startswith("https://127.0.0.1:")
        trusted = ssl.create_default_context(cafile=review.tls.trust)  # ca.pem only, as a tablet trusts it
        info = httpx.get(f"{base}api/info?token=secret", verify=trusted, timeout=30)
        assert info.status_code == 200 and "modes" in info.json()
        assert "secure" in info.headers["set-cookie"].lower()  # the token's cookie never goes over http
        with pytest.raises(httpx.ConnectError):  # not trusted without it: it is no public certificate
            httpx.get(f"{base}api/info?token=secret", timeout=30)
        wss = base.replace("https://", "wss://") + "api/view?token=secret"
        with connect(wss, ssl=trusted, open_timeout=30) as ws:
            ws.send(json.dumps({"id": 1, "shot": "nope"}))
            answer = json.loads(ws.recv(timeout=30))
        assert "nope" in answer["error"], answer


@pytest.mark.slow
@needs_chromium
def test_the_page_is_a_secure_context_with_a_camera_api(box, tmp_path):
    """Chromium told to trust the server certificate's key (as a tablet trusts ca.pem): the page is
    a secure context, so getUserMedia exists, and the page's WebSocket (wss:, the token in the
    cookie the page got) is answered."""
    sync_api = pytest.importorskip("playwright.sync_api")
    with _served(tmp_path) as review, sync_api.sync_playwright() as pw:
        spki = (
            _load(review.tls.cert)
            .public_key()
            .public_bytes(serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo)
        )
        pin = base64.b64encode(hashlib.sha256(spki).digest()).decode()
        browser = open_browser(pw, tmp_path, [f"--ignore-certificate-errors-spki-list={pin}"])
        page = browser.new_page()
        assert page.goto(review.url).ok
        assert page.evaluate("window.isSecureContext")
        assert page.evaluate("typeof navigator.mediaDevices?.getUserMedia") == "function"
        answer = page.evaluate(
            """() => new Promise((resolve, reject) => {
                const ws = new WebSocket(`wss://${location.host}/api/view`);
                ws.onopen = () => ws.send(JSON.stringify({id: 1, shot: "nope"}));
                ws.onmessage = (ev) => resolve(JSON.parse(ev.data));
                ws.onclose = (ev) => reject(new Error(`closed ${ev.code} ${ev.reason}`));
            })"""
        )
        assert "nope" in answer["error"], answer
        browser.close()
