#!/usr/bin/env python3
"""Generate a throw-away certificate authority and one certificate per bus identity, for TESTS and demos.

    python scripts/gen_test_certs.py OUT_DIR --names router,ground,planner-d0,d0,d1 [--hosts router,localhost]

Writes ``OUT_DIR/ca.pem`` (the root every side trusts, Zenoh's ``root_ca_certificate``) and, per name,
``OUT_DIR/<name>.pem`` + ``OUT_DIR/<name>-key.pem`` (PKCS#8, mode 0600). A certificate's common name is
the identity the router's access control matches (``cert_common_names``, docs/network.md); its
subject alternative names are the name itself plus ``--hosts`` and 127.0.0.1, so a TLS client that
checks the server's name (Zenoh's ``verify_name_on_connect``) accepts ``tls/localhost:…`` and
``tls/<name>:…``. Existing files are kept (``--force`` regenerates), so compose can run it at every start.

The CA's private key is NOT kept: nobody can sign another identity later. Never use these for a
real deployment: issue real certificates from your own PKI (same layout, same common names).
Sources: ``cryptography`` X.509 tutorial (https://cryptography.io/en/latest/x509/tutorial/);
rustls/webpki needs a CA with ``basicConstraints CA:TRUE`` and end-entity certificates that are not CAs.
"""

from __future__ import annotations

import argparse
import datetime as dt
import ipaddress
import logging
import os
import re
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

log = logging.getLogger("gen_test_certs")

VALID_DAYS = 365
CA_NAME = "llmland-test-ca"
NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,62}$")
LOOPBACK = ipaddress.ip_address("127.0.0.1")


def _key() -> ec.EllipticCurvePrivateKey:
    return ec.generate_private_key(ec.SECP256R1())


def _write_key(path: Path, key: ec.EllipticCurvePrivateKey) -> None:
    data = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "LLM-Land test"),
                      x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def generate(out: Path, names: list[str], hosts: list[str] | None = None, force: bool = False) -> list[Path]:
    """Write the CA and a certificate + key per name into ``out``; returns the files written."""
    for n in [*names, *(hosts or [])]:
        if not NAME_RE.match(n):
            raise ValueError(f"invalid identity or host name {n!r}: letters, digits, '_', '.', '-' only")
    out.mkdir(parents=True, exist_ok=True)
    wanted = [out / "ca.pem", *(out / f"{n}.pem" for n in names)]
    if not force and all(p.exists() for p in wanted):
        log.info("certificates already in %s (use --force to regenerate)", out)
        return []
    now = dt.datetime.now(dt.UTC)
    ca_key = _key()
    ca = (x509.CertificateBuilder().subject_name(_name(CA_NAME)).issuer_name(_name(CA_NAME))
          .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
          .not_valid_before(now - dt.timedelta(minutes=5)).not_valid_after(now + dt.timedelta(days=VALID_DAYS))
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(x509.KeyUsage(digital_signature=False, content_commitment=False, key_encipherment=False,
                                       data_encipherment=False, key_agreement=False, key_cert_sign=True,
                                       crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
          .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()), critical=False)
          .sign(ca_key, hashes.SHA256()))
    written = [out / "ca.pem"]
    written[0].write_bytes(ca.public_bytes(serialization.Encoding.PEM))
    for name in names:
        key = _key()
        sans: list[x509.GeneralName] = [x509.DNSName(h) for h in dict.fromkeys([name, "localhost", *(hosts or [])])]
        sans.append(x509.IPAddress(LOOPBACK))
        cert = (x509.CertificateBuilder().subject_name(_name(name)).issuer_name(ca.subject)
                .public_key(key.public_key()).serial_number(x509.random_serial_number())
                .not_valid_before(now - dt.timedelta(minutes=5)).not_valid_after(now + dt.timedelta(days=VALID_DAYS))
                .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                .add_extension(x509.SubjectAlternativeName(sans), critical=False)
                .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH,
                                                      ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
                .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()),
                               critical=False)
                .sign(ca_key, hashes.SHA256()))
        (out / f"{name}.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        _write_key(out / f"{name}-key.pem", key)
        written += [out / f"{name}.pem", out / f"{name}-key.pem"]
    log.info("wrote a test CA and %d certificates to %s", len(names), out)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("out", type=Path)
    parser.add_argument("--names", required=True, help="comma-separated identities (certificate common names)")
    parser.add_argument("--hosts", default="", help="comma-separated extra DNS names for every certificate")
    parser.add_argument("--force", action="store_true", help="regenerate even if the files exist")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname).1s %(name)s: %(message)s")
    split = [s.strip() for s in args.names.split(",") if s.strip()]
    hosts = [s.strip() for s in args.hosts.split(",") if s.strip()]
    generate(args.out, split, hosts, force=args.force)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
