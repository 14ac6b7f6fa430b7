"""TLS for headsets on the LAN: WebXR needs a secure context except on localhost.

``--tls auto`` creates a self-signed certificate for this machine's names and addresses once, keeps it in
``--tls-dir``, and reuses it while it covers the same names and stays valid for 30 more days (so a headset
that accepted it once keeps accepting it). ``--tls-cert``/``--tls-key`` use the operator's own.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import logging
import socket
import ssl
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

logger = logging.getLogger(__name__)

CERT_NAME = "xr-relay-cert.pem"
KEY_NAME = "xr-relay-key.pem"
VALIDITY_DAYS = 397  # browsers refuse longer-lived server certificates


def local_names(extra: tuple[str, ...] = ()) -> tuple[list[str], list[str]]:
    """(DNS names, IP addresses) this relay can be reached by: localhost, the host name, its addresses."""
    hostname = socket.gethostname()
    dns = {"localhost", hostname, f"{hostname}.local"}
    ips = {"127.0.0.1", "::1"}
    try:
        for info in socket.getaddrinfo(hostname, None):
            ips.add(str(info[4][0]).split("%")[0])
    except OSError:
        pass  # no resolver entry for our own name: localhost and the extras still work
    for name in extra:
        try:
            ips.add(str(ipaddress.ip_address(name)))
        except ValueError:
            dns.add(name)
    ips.discard("0.0.0.0")
    ips.discard("::")
    return sorted(dns), sorted(ips)


def fingerprint(cert_path: Path) -> str:
    cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
    digest = cert.fingerprint(hashes.SHA256()).hex().upper()
    return ":".join(digest[i : i + 2] for i in range(0, len(digest), 2))


def _covers(cert_path: Path, dns: list[str], ips: list[str]) -> bool:
    try:
        cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        sans = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except (OSError, ValueError, x509.ExtensionNotFound):
        return False
    have_dns = set(sans.get_values_for_type(x509.DNSName))
    have_ips = {str(ip) for ip in sans.get_values_for_type(x509.IPAddress)}
    fresh = cert.not_valid_after_utc - dt.datetime.now(dt.UTC) > dt.timedelta(days=30)
    return fresh and set(dns) <= have_dns and set(ips) <= have_ips


def ensure_certificate(directory: Path, extra_names: tuple[str, ...] = ()) -> tuple[Path, Path]:
    """The self-signed certificate and key in ``directory``, created or renewed when needed."""
    directory.mkdir(parents=True, exist_ok=True)
    cert_path, key_path = directory / CERT_NAME, directory / KEY_NAME
    dns, ips = local_names(extra_names)
    if cert_path.is_file() and key_path.is_file() and _covers(cert_path, dns, ips):
        return cert_path, key_path
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"xr-relay on {socket.gethostname()}")])
    now = dt.datetime.now(dt.UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=VALIDITY_DAYS))
        .add_extension(
            x509.SubjectAlternativeName(
                [x509.DNSName(d) for d in dns] + [x509.IPAddress(ipaddress.ip_address(i)) for i in ips]
            ),
            critical=False,
        )
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage([x509.oid.ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .sign(key, hashes.SHA256())
    )
    key_path.write_bytes(
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    )
    key_path.chmod(0o600)
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    logger.info("created a self-signed certificate for %s", ", ".join(dns + ips))
    return cert_path, key_path


def server_context(cert_path: Path, key_path: Path) -> ssl.SSLContext:
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(cert_path, key_path)
    return context
