"""``--self-signed``: HTTPS certificates for this machine, made once and kept in ``review-tls/``
beside the review database, so that a tablet that trusted them once keeps trusting them.

Two certificates, as local development CAs make them: ``ca.pem``, which the tablet installs and
trusts, and the server's own ``cert.pem`` (key ``key.pem``), signed by it. One self-signed
certificate cannot be both: Android (11 on) installs as a "CA certificate" only one that says
basicConstraints CA:TRUE, and iOS offers full trust only to such a one, while a server's own
certificate is to say CA:FALSE (the CA/Browser Forum's baseline requirements; Chrome's strict
verification refuses one that does not). ca.pem's private key is never written: it signs
cert.pem and is dropped, so a tablet that trusts ca.pem trusts this server's certificate and
nothing else anyone could sign.

Both are kept while they are valid for :data:`RENEW_BEFORE` more and cert.pem names every name
and address the server answers to (:func:`server_names`); else both are made anew (and must be
trusted anew). Both are EC P-256 with ECDSA-SHA256, valid :data:`VALIDITY`: what Android, iOS
(at most 825 days for a server certificate) and the browsers take."""

from __future__ import annotations

import ipaddress
import socket
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

from cryptography import x509
from cryptography.exceptions import InvalidSignature, UnsupportedAlgorithm
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from mrcheck.apps.names import TLS_CA, TLS_CERT, TLS_KEY
from mrcheck.apps.review.guard import LOOPBACK_NAMES, host_names, machine_names
from mrcheck.apps.review.tls import Tls, fingerprint, same_key, utc_now
from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import write_bytes

VALIDITY = timedelta(days=365)
RENEW_BEFORE = timedelta(days=7)  # a certificate that ends sooner is made anew at start-up
CLOCK_SKEW = timedelta(hours=1)  # valid from an hour ago: a tablet whose clock is a little behind
# where the default routes lead: connecting a UDP socket sends nothing, it only picks the source address
ROUTE_PROBES = ((socket.AF_INET, "192.0.2.1"), (socket.AF_INET6, "2001:db8::1"))  # documentation addresses


@dataclass(frozen=True)
class ServerNames:
    """What the server certificate must name: DNS names (lower case) and IP addresses."""

    dns: frozenset = frozenset()
    ips: frozenset = frozenset()

    @classmethod
    def of(cls, names) -> ServerNames:
        """Of host names and addresses as a Host header gives them (IPv6 in brackets)."""
        dns, ips = set(), set()
        for name in names:
            try:
                ips.add(ipaddress.ip_address(name.strip("[]")))
            except ValueError:
                if name.isascii() and name:  # a DNS name in a certificate is ASCII
                    dns.add(name.lower())
        return cls(frozenset(dns), frozenset(ips))

    def alternative_names(self) -> x509.SubjectAlternativeName:
        return x509.SubjectAlternativeName(
            [*map(x509.DNSName, sorted(self.dns)), *(x509.IPAddress(ip) for ip in _sorted(self.ips))]
        )

    def covered_by(self, cert: x509.Certificate) -> bool:
        covered = certificate_names(cert)
        return self.dns <= covered.dns and self.ips <= covered.ips

    def listed(self) -> tuple:
        return (*sorted(self.dns), *map(str, _sorted(self.ips)))


def _sorted(ips) -> list:
    return sorted(ips, key=lambda ip: (ip.version, ip))


def certificate_names(cert: x509.Certificate) -> ServerNames:
    """The names in a certificate's subjectAltName (none without one)."""
    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return ServerNames()
    return ServerNames(
        frozenset(n.lower() for n in san.get_values_for_type(x509.DNSName)),
        frozenset(san.get_values_for_type(x509.IPAddress)),
    )


def server_names(bound: str) -> ServerNames:
    """What a server bound to ``bound`` answers to (:func:`.guard.host_names`): always localhost,
    127.0.0.1, ::1 and the machine's names; bound to every interface (0.0.0.0, ::), also the
    machine's addresses (:func:`machine_addresses`), which a tablet that cannot look the
    machine's name up opens."""
    hosts = host_names(bound)
    names = ServerNames.of({*hosts.names, *LOOPBACK_NAMES, *machine_names()})
    if hosts.any_address:
        names = ServerNames(names.dns, names.ips | machine_addresses())
    return names


def machine_addresses() -> frozenset:
    """This machine's addresses, found without sending anything: those its name resolves to
    (/etc/hosts) and the source addresses of its default routes; not link-local ones (a URL
    cannot carry them without a zone)."""
    found = set()
    try:
        found |= {info[4][0] for info in socket.getaddrinfo(socket.gethostname(), None)}
    except (OSError, UnicodeError):
        pass
    for family, probe in ROUTE_PROBES:
        try:
            with socket.socket(family, socket.SOCK_DGRAM) as udp:
                udp.connect((probe, 9))
                found.add(udp.getsockname()[0])
        except OSError:  # no such route (offline, no IPv6)
            pass
    addresses = {ipaddress.ip_address(str(a).split("%")[0]) for a in found}
    return frozenset(a for a in addresses if not (a.is_link_local or a.is_unspecified))


def self_signed_tls(folder: Path, names: ServerNames, now: datetime | None = None) -> Tls:
    """The certificates in ``folder`` (ca.pem, cert.pem, key.pem), kept or made anew (see the
    module); a folder that cannot be written is a :class:`MrcheckError`."""
    now = now or utc_now()
    return _kept(Path(folder), names, now) or _make(Path(folder), names, now)


def _kept(folder: Path, names: ServerNames, now: datetime) -> Tls | None:
    """The certificates of an earlier start if they still serve, else None."""
    try:
        ca = x509.load_pem_x509_certificate((folder / TLS_CA).read_bytes())
        cert = x509.load_pem_x509_certificate((folder / TLS_CERT).read_bytes())
        key = serialization.load_pem_private_key((folder / TLS_KEY).read_bytes(), password=None)
        cert.verify_directly_issued_by(ca)
    except (OSError, ValueError, TypeError, InvalidSignature, UnsupportedAlgorithm):
        return None  # none yet, or damaged or replaced by hand: made anew
    starts = max(ca.not_valid_before_utc, cert.not_valid_before_utc)
    ends = min(ca.not_valid_after_utc, cert.not_valid_after_utc)
    if starts > now or ends - now < RENEW_BEFORE or not names.covered_by(cert) or not same_key(cert, key):
        return None
    return _tls(folder, ca, cert, made=False)


def _make(folder: Path, names: ServerNames, now: datetime) -> Tls:
    ca_key, key = ec.generate_private_key(ec.SECP256R1()), ec.generate_private_key(ec.SECP256R1())
    ca = _ca_certificate(ca_key, now)
    cert = _server_certificate(key, ca, ca_key, names, now)
    pem = serialization.Encoding.PEM
    try:
        folder.mkdir(mode=0o700, exist_ok=True)  # it holds a private key
    except OSError as exc:
        raise MrcheckError(f"cannot write the review's certificates ({exc.strerror})", folder) from None
    # the key first: a start that dies half-way leaves a cert.pem of another key, which is made anew
    private = key.private_bytes(pem, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    write_bytes(folder / TLS_KEY, private, mode=0o600)
    write_bytes(folder / TLS_CERT, cert.public_bytes(pem))
    write_bytes(folder / TLS_CA, ca.public_bytes(pem))
    return _tls(folder, ca, cert, made=True)


def _tls(folder: Path, ca: x509.Certificate, cert: x509.Certificate, made: bool) -> Tls:
    return Tls(
        cert=folder / TLS_CERT,
        key=folder / TLS_KEY,
        not_after=cert.not_valid_after_utc,
        trust=folder / TLS_CA,
        fingerprint=fingerprint(ca),
        names=certificate_names(cert).listed(),
        made=made,
    )


def _builder(subject: x509.Name, issuer: x509.Name, public_key, now: datetime) -> x509.CertificateBuilder:
    return (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(public_key)
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - CLOCK_SKEW)
        .not_valid_after(now + VALIDITY)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(public_key), critical=False)
    )


def _usage(**allowed: bool) -> x509.KeyUsage:
    uses = ("digital_signature", "content_commitment", "key_encipherment", "data_encipherment", "key_agreement")
    uses += ("key_cert_sign", "crl_sign")
    return x509.KeyUsage(**{use: allowed.get(use, False) for use in uses}, encipher_only=False, decipher_only=False)


def _ca_certificate(ca_key, now: datetime) -> x509.Certificate:
    # the name a tablet lists it by among its trusted certificates
    name = x509.Name(
        [
            x509.NameAttribute(NameOID.COMMON_NAME, f"mrcheck review {socket.gethostname()[:30]} {now:%Y-%m-%d}"),
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "mrcheck review (signs one server certificate only)"),
        ]
    )
    return (
        _builder(name, name, ca_key.public_key(), now)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(_usage(key_cert_sign=True, crl_sign=True), critical=True)
        .sign(ca_key, hashes.SHA256())
    )


def _server_certificate(key, ca: x509.Certificate, ca_key, names: ServerNames, now: datetime) -> x509.Certificate:
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, names.listed()[0][:64])])
    return (
        _builder(subject, ca.subject, key.public_key(), now)
        .add_extension(names.alternative_names(), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(_usage(digital_signature=True), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False)
        .sign(ca_key, hashes.SHA256())
    )


__all__ = ["ServerNames", "certificate_names", "server_names", "machine_addresses", "self_signed_tls"]
