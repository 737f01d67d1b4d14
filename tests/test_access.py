"""Access to a live session: Zenoh's user/password authentication, access control and TLS,
checked on real connections on 127.0.0.1 (certificates made here, never committed)."""

from __future__ import annotations

import datetime
import ipaddress
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from orchestrator.live.access import (
    AccessError,
    Credentials,
    ServerAccess,
    is_loopback,
    read_user_file,
)
from orchestrator.live.client import Client, LiveError
from orchestrator.live.protocol import key
from orchestrator.live.server import serve
from orchestrator.live.session import Session

from .live_attacks import free_port


def _secret(path: Path, text: str, mode: int = 0o600) -> Path:
    path.write_text(text)
    path.chmod(mode)
    return path


@pytest.mark.parametrize(
    ("endpoint", "loopback"),
    [
        ("tcp/127.0.0.1:7447", True),
        ("tcp/127.3.2.1:7447", True),
        ("tls/localhost:7447", True),
        ("tcp/[::1]:7447", True),
        ("unixsock-stream//tmp/s.sock", True),
        ("tcp/0.0.0.0:7447", False),
        ("tcp/[::]:7447", False),
        ("tcp/192.168.1.5:7447", False),
        ("tls/cell1.example.com:7447", False),
        ("tcp/127.0.0.1.evil.com:7447", False),
    ],
)
def test_only_loopback_endpoints_count_as_local(endpoint, loopback):
    assert is_loopback(endpoint) is loopback


def test_a_users_file_readable_by_others_is_refused_with_the_fix(tmp_path):
    users = _secret(tmp_path / "users.txt", "op:secret\n", mode=0o644)
    with pytest.raises(AccessError, match=r"readable by others \(mode 644\).*chmod 600"):
        read_user_file(users)


def test_a_bad_line_is_named_by_number_and_its_content_never_shown(tmp_path):
    users = _secret(tmp_path / "users.txt", "op:secret\nhunter2-no-colon\n\n")
    with pytest.raises(AccessError) as exc:
        read_user_file(users)
    assert str(exc.value) == f"{users}:2: expected user:password (both non-empty)"


def test_credentials_come_from_options_before_the_file(tmp_path):
    creds = _secret(tmp_path / "me", "alice:from-file\n")
    assert Credentials.resolve(credentials_file=creds) == Credentials("alice", "from-file")
    assert Credentials.resolve("bob", "opt", creds) == Credentials("bob", "opt")
    with pytest.raises(AccessError, match="a user without a password"):
        Credentials.resolve(user="bob")


def test_a_session_reachable_from_other_machines_needs_mutual_tls(tmp_path):
    with pytest.raises(AccessError, match=r"tcp/0\.0\.0\.0:7447 can be reached from other "
                       r"machines, which is allowed only with mutual TLS"):  # fmt: skip
        ServerAccess().check(["tcp/0.0.0.0:7447"], [])
    users = _secret(tmp_path / "users.txt", "op:secret\nwatcher:look\n")
    with pytest.raises(AccessError, match="only with mutual TLS"):  # users alone: not enough
        ServerAccess(users, ("watcher",)).check(["tcp/0.0.0.0:7447"], [])
    assert ServerAccess(users, ("watcher",)).check(["tcp/127.0.0.1:7447"], []) == ["op", "watcher"]
    with pytest.raises(AccessError, match="--viewer bob: not in the users file"):
        ServerAccess(users, ("bob",)).check([], [])
    with pytest.raises(AccessError, match="a tls/ endpoint needs --tls-cert and --tls-key"):
        ServerAccess(users).check(["tls/127.0.0.1:7447"], [])


def test_serve_refuses_a_non_loopback_listen_without_mutual_tls_before_building_anything(cli):
    res = cli("serve", "pick_place", "--session", "x", "--listen", f"tcp/0.0.0.0:{free_port()}")
    assert res.exit_code == 2 and "Traceback" not in res.stderr
    assert "can be reached from other machines" in res.stderr and "--tls-ca CA" in res.stderr


def test_send_with_half_the_credentials_exits_2(cli, monkeypatch):
    monkeypatch.setenv("ORCHESTRATOR_USER", "alice")
    res = cli("send", "x", "status", "--connect", f"tcp/127.0.0.1:{free_port()}")
    assert res.exit_code == 2 and "a user without a password" in res.stderr


# -- on the wire ------------------------------------------------------------------------------


def _make_certs(folder: Path) -> tuple[Path, Path, Path]:
    """A CA and a certificate for localhost/127.0.0.1 signed by it: (ca, cert, key)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    now = datetime.datetime.now(datetime.UTC)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "test CA")])
    ca = (
        x509.CertificateBuilder().subject_name(ca_name).issuer_name(ca_name)
        .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
        .not_valid_before(now).not_valid_after(now + datetime.timedelta(hours=1))
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    key_ = ec.generate_private_key(ec.SECP256R1())
    sans = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    cert = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "localhost")]))
        .issuer_name(ca_name).public_key(key_.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now).not_valid_after(now + datetime.timedelta(hours=1))
        .add_extension(x509.SubjectAlternativeName(sans), critical=False)
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    pem = serialization.Encoding.PEM
    (folder / "ca.pem").write_bytes(ca.public_bytes(pem))
    (folder / "cert.pem").write_bytes(cert.public_bytes(pem))
    key_pem = key_.private_bytes(
        pem, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )
    _secret(folder / "key.pem", key_pem.decode())
    return folder / "ca.pem", folder / "cert.pem", folder / "key.pem"


class Secured:
    """A session with users (an operator, a viewer) and TLS, served from a thread (no
    watchdog, and an operator without heartbeats: the test sends them by hand)."""

    def __init__(self, folder: Path) -> None:
        self.ca, cert, tls_key = _make_certs(folder)
        users = _secret(folder / "users.txt", "op:op-secret\nwatcher:look\n")
        self.name = "locked"
        self.endpoint = f"tls/localhost:{free_port()}"
        self.session = Session("pick_place", self.name, seed=3, speed=0.0)
        access = ServerAccess(users, ("watcher",), cert, tls_key)
        self.stop = threading.Event()
        self.thread = threading.Thread(
            target=serve, args=(self.session, [self.endpoint]),
            kwargs={"stop": self.stop, "access": access},
        )  # fmt: skip
        self.thread.start()
        self.op = self.client("op", "op-secret", find_s=30.0, heartbeat_s=None)
        self.op.status()

    def client(self, user: str | None, password: str | None, ca: bool = True,
               find_s: float = 1.0, heartbeat_s: float | None = 0.05) -> Client:  # fmt: skip
        creds = Credentials(user, password, self.ca if ca else None)
        return Client(self.name, [self.endpoint], name=user or "anon", find_s=find_s,
                      credentials=creds, heartbeat_s=heartbeat_s)  # fmt: skip

    def close(self) -> None:
        self.stop.set()
        self.thread.join(30)
        self.op.close()


@pytest.fixture(scope="module")
def secured(tmp_path_factory) -> Iterator[Secured]:
    served = Secured(tmp_path_factory.mktemp("secured"))
    yield served
    served.close()


@pytest.mark.parametrize(
    ("user", "password", "ca"),
    [(None, None, True), ("op", "wrong", True), ("mallory", "op-secret", True),
     ("op", "op-secret", False)],
    ids=["no credentials", "wrong password", "unknown user", "no CA"],
)  # fmt: skip
def test_a_connection_without_valid_credentials_and_ca_is_refused(secured, user, password, ca):
    with secured.client(user, password, ca) as c:
        with pytest.raises(LiveError, match="something listens there but no Zenoh session"):
            c.status()
        assert not c.alive


def test_a_viewer_watches_and_estops_but_cannot_command(secured):
    with secured.client("watcher", "look") as viewer:
        assert viewer.status()["state"] == "IDLE"
        with pytest.raises(LiveError, match="user 'watcher' may be a viewer"):
            viewer.command("run", "home")
        assert viewer.estop().accepted
        status = viewer.status()
        deadline = time.monotonic() + 5
        while status["state"] != "ESTOPPED" and time.monotonic() < deadline:
            status = viewer.status()
        assert status["state"] == "ESTOPPED"
        with pytest.raises(LiveError):
            viewer.reset()
    assert secured.op.reset().accepted


def test_an_operator_commands_and_a_viewers_heartbeats_never_reach_the_session(secured):
    with secured.client("watcher", "look") as viewer:
        for _ in range(5):
            viewer.z.put(key(secured.name, "clients/heartbeat"), secured.op.owner)
        time.sleep(0.3)
        assert secured.session.heartbeat_wall is None  # dropped by the access control
        secured.op.z.put(key(secured.name, "clients/heartbeat"), secured.op.owner)
        deadline = time.monotonic() + 5
        while secured.session.heartbeat_wall is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert secured.session.heartbeat_wall is not None
    reply, result = secured.op.run("home", wait=True)
    assert reply.accepted and result is not None and result["outcome"] == "succeeded"


def test_watch_shows_a_secured_session_to_a_viewer(secured):
    import io

    from rich.console import Console

    from orchestrator.live.watch import watch

    buffer = io.StringIO()
    code = watch(secured.name, [secured.endpoint], 1.0, Console(file=buffer, width=120),
                 Credentials("watcher", "look", secured.ca))  # fmt: skip
    assert code == 0 and "IDLE" in buffer.getvalue() and "LOST" not in buffer.getvalue()
    buffer = io.StringIO()
    code = watch(secured.name, [secured.endpoint], 1.0, Console(file=buffer, width=120),
                 Credentials("watcher", "wrong", secured.ca))  # fmt: skip
    assert code == 1 and "LOST" in buffer.getvalue()
