"""Certificates made inside a test (never committed): a CA, certificates it signs, and the
wrong kinds (another CA's, self-signed, expired), written as PEM files, keys chmod 600.

Uses `cryptography` (already in the environment: tests/test_access.py makes its certificates
with it too); EC P-256 keys, which Zenoh's TLS (rustls) reads as PKCS#8.
"""

from __future__ import annotations

import datetime
import ipaddress
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["Authority", "Issued", "self_signed"]

_HOUR = datetime.timedelta(hours=1)


@dataclass(frozen=True)
class Issued:
    """A certificate and its key, as files."""

    cert: Path
    key: Path


def _key() -> Any:
    from cryptography.hazmat.primitives.asymmetric import ec

    return ec.generate_private_key(ec.SECP256R1())


def _name(common_name: str) -> Any:
    from cryptography import x509
    from cryptography.x509.oid import NameOID

    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _write(folder: Path, stem: str, cert: Any, key: Any) -> Issued:
    from cryptography.hazmat.primitives import serialization

    pem = serialization.Encoding.PEM
    cert_path, key_path = folder / f"{stem}.pem", folder / f"{stem}.key"
    cert_path.write_bytes(cert.public_bytes(pem))
    key_path.write_bytes(key.private_bytes(pem, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))  # fmt: skip
    key_path.chmod(0o600)
    return Issued(cert_path, key_path)


def _builder(subject: str, issuer: Any, public_key: Any, expired: bool = False) -> Any:
    from cryptography import x509

    now = datetime.datetime.now(datetime.UTC)
    start, end = (now - 3 * _HOUR, now - _HOUR) if expired else (now - _HOUR, now + 2 * _HOUR)
    return (
        x509.CertificateBuilder().subject_name(_name(subject)).issuer_name(issuer)
        .public_key(public_key).serial_number(x509.random_serial_number())
        .not_valid_before(start).not_valid_after(end)
    )  # fmt: skip


def _leaf(builder: Any, server: bool) -> Any:
    """A server's (serverAuth, names localhost and 127.0.0.1) or a client's (clientAuth)."""
    from cryptography import x509
    from cryptography.x509.oid import ExtendedKeyUsageOID

    usage = ExtendedKeyUsageOID.SERVER_AUTH if server else ExtendedKeyUsageOID.CLIENT_AUTH
    builder = builder.add_extension(x509.BasicConstraints(ca=False, path_length=None), True)
    builder = builder.add_extension(x509.ExtendedKeyUsage([usage]), False)
    if server:
        sans = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
        builder = builder.add_extension(x509.SubjectAlternativeName(sans), False)
    return builder


class Authority:
    """A CA in `folder` (`<stem>-ca.pem`) that signs server and client certificates."""

    def __init__(self, folder: Path, stem: str) -> None:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes

        self.folder, self.stem, self._key = folder, stem, _key()
        self._name = _name(f"{stem} CA")
        cert = (
            _builder(f"{stem} CA", self._name, self._key.public_key())
            .add_extension(x509.BasicConstraints(ca=True, path_length=None), True)
            .sign(self._key, hashes.SHA256())
        )
        self.ca = _write(folder, f"{stem}-ca", cert, self._key).cert

    def issue(self, stem: str, server: bool = False, expired: bool = False) -> Issued:
        """A server's or a client's certificate signed by this CA (`expired`: it ended an
        hour ago)."""
        from cryptography.hazmat.primitives import hashes

        key = _key()
        builder = _leaf(_builder(stem, self._name, key.public_key(), expired), server)
        return _write(self.folder, stem, builder.sign(self._key, hashes.SHA256()), key)


def self_signed(folder: Path, stem: str) -> Issued:
    """A client certificate that signs itself (no CA vouches for it)."""
    from cryptography.hazmat.primitives import hashes

    key = _key()
    builder = _leaf(_builder(stem, _name(stem), key.public_key()), server=False)
    return _write(folder, stem, builder.sign(key, hashes.SHA256()), key)
