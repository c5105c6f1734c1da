"""HTTPS for ``mrcheck review``. Off localhost a browser gives a page the camera
(``getUserMedia``, the live check through a tablet) only in a secure context, that is a page
served over https. :class:`TlsOptions` is what the command line asked for: the planner's own
certificate and key (``--tls-cert``/``--tls-key``, checked by :func:`given_tls` before the port
is bound, as uvicorn will load them) or one made for this machine (``--self-signed``,
:mod:`.selfsigned`). :class:`Tls` is what the server then serves with."""

from __future__ import annotations

import ssl
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from cryptography import x509
from cryptography.exceptions import UnsupportedAlgorithm
from cryptography.hazmat.primitives import hashes, serialization

from mrcheck.core.errors import MrcheckError, os_reason

TRUST_HOW = (
    "trust it once on the tablet: Android: Settings > Security > Encryption & credentials > Install a "
    "certificate > CA certificate; iPad: send the .pem, install the profile, then Settings > General > "
    "About > Certificate Trust Settings"
)


@dataclass(frozen=True)
class TlsOptions:
    """The command line's HTTPS options; none of them: plain http."""

    cert: str | None = None  # --tls-cert
    key: str | None = None  # --tls-key
    self_signed: bool = False  # --self-signed

    @property
    def wanted(self) -> bool:
        return self.self_signed or self.cert is not None

    def check(self) -> None:
        """The options' combination (the files: :func:`given_tls`)."""
        for option, value in (("--tls-cert", self.cert), ("--tls-key", self.key)):
            if value is not None and not str(value).strip():
                raise MrcheckError(f"{option} must not be empty")
        if self.self_signed and (self.cert is not None or self.key is not None):
            raise MrcheckError("--self-signed makes its own certificate: give it or --tls-cert and --tls-key, not both")
        if (self.cert is None) != (self.key is None):
            raise MrcheckError("--tls-cert and --tls-key go together: the certificate and its private key")


@dataclass(frozen=True)
class Tls:
    """The certificate the server serves HTTPS with."""

    cert: Path  # the server's certificate (PEM; a chain: the server's own first)
    key: Path  # its private key (PEM)
    not_after: datetime  # the server certificate's expiry (UTC)
    trust: Path | None = None  # --self-signed: the certificate a tablet installs (it signed cert)
    fingerprint: str = ""  # SHA-256 of trust, as a tablet shows it (AB:CD:...)
    names: tuple = ()  # --self-signed: the names and addresses cert is valid for
    made: bool = False  # --self-signed: made at this start (else kept from an earlier one)

    def uvicorn_options(self) -> dict:
        return {"ssl_certfile": str(self.cert), "ssl_keyfile": str(self.key)}

    def lines(self) -> list[str]:
        """What start-up says about the certificate; for --self-signed, what to trust and how."""
        until = f"valid until {self.not_after:%Y-%m-%d}"
        if self.trust is None:
            return [f"https: {self.cert}, {until}"]
        made = "made now" if self.made else "kept from an earlier start"
        names = ", ".join(self.names)
        return [f"https: certificate {self.trust} ({made}; SHA-256 {self.fingerprint}) for {names}, {until}", TRUST_HOW]


def given_tls(options: TlsOptions, now: datetime | None = None) -> Tls | None:
    """``--tls-cert`` and ``--tls-key`` checked as the server will load them (None without them):
    a file that cannot be read or holds no PEM certificate or key, a key of another certificate,
    a certificate out of its validity, or anything else OpenSSL refuses, is a
    :class:`MrcheckError` naming the file."""
    if options.cert is None or options.key is None:
        return None
    cert, key = Path(options.cert), Path(options.key)
    leaf = read_certificates(cert)[0]
    if not same_key(leaf, read_private_key(key)):
        raise MrcheckError(f"is not the private key of {cert} (the certificate is for another key)", key)
    check_validity(leaf, cert, now or utc_now())
    try:  # what OpenSSL itself refuses, as uvicorn loads the files
        ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER).load_cert_chain(cert, key)
    except (ssl.SSLError, OSError) as exc:
        reason = getattr(exc, "reason", None) or exc
        raise MrcheckError(f"cannot serve it with the key {key} ({reason})", cert) from None
    return Tls(cert, key, leaf.not_valid_after_utc)


def read_certificates(path: Path) -> list[x509.Certificate]:
    try:
        return x509.load_pem_x509_certificates(_read(path))
    except ValueError:
        raise MrcheckError("no PEM certificate in it (-----BEGIN CERTIFICATE-----)", path) from None


def read_private_key(path: Path):
    try:
        return serialization.load_pem_private_key(_read(path), password=None)
    except TypeError:  # cryptography's word for a key that needs a password
        raise MrcheckError("the private key is encrypted: give it without a passphrase (and chmod 600)", path) from None
    except (ValueError, UnsupportedAlgorithm):
        raise MrcheckError("no PEM private key in it (-----BEGIN PRIVATE KEY-----)", path) from None


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise MrcheckError(os_reason(exc), path) from None


def same_key(cert: x509.Certificate, private_key) -> bool:
    spki = (serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo)
    return cert.public_key().public_bytes(*spki) == private_key.public_key().public_bytes(*spki)


def check_validity(cert: x509.Certificate, path: Path, now: datetime) -> None:
    if cert.not_valid_after_utc <= now:
        ended = f"{cert.not_valid_after_utc:%Y-%m-%d}"
        raise MrcheckError(f"the certificate expired on {ended}: give a current one (or --self-signed)", path)
    if cert.not_valid_before_utc > now:
        raise MrcheckError(
            f"the certificate is valid from {cert.not_valid_before_utc:%Y-%m-%d %H:%M} UTC on (is this machine's "
            "clock right?)",
            path,
        )


def fingerprint(cert: x509.Certificate) -> str:
    """SHA-256 of the certificate, as Android and iOS show it (colon-separated hex)."""
    return cert.fingerprint(hashes.SHA256()).hex(":").upper()


def utc_now() -> datetime:
    return datetime.now(timezone.utc)


__all__ = [
    "TlsOptions",
    "Tls",
    "TRUST_HOW",
    "given_tls",
    "read_certificates",
    "read_private_key",
    "same_key",
    "check_validity",
    "fingerprint",
    "utc_now",
]
