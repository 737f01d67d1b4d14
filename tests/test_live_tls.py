"""Beyond loopback only with mutual TLS (docs/live.md, Threat model).

A real session served on `tls/127.0.0.1` with a CA made here admits only clients whose
certificate that CA signed: a client with no certificate, one from another CA, a self-signed
one, an expired one, a valid certificate with the wrong key, or no TLS at all cannot open a
Zenoh session with it, so it can neither reset an e-stop, restore a snapshot, nor run a task
(judged on the session: still ESTOPPED, no task, the arm where it was); a client with a
valid certificate can do all three. `serve` refuses a non-loopback endpoint without mutual
TLS, before building anything, naming the fix.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.access import AccessError, Credentials, ServerAccess, zenoh_config
from orchestrator.live.client import Client, LiveError
from orchestrator.live.protocol import STATES
from orchestrator.live.server import serve
from orchestrator.live.session import Session

from .live_attacks import free_port
from .tls_certs import Authority, Issued, self_signed

NAME = "mtls"


@dataclass
class Pki:
    """The session's CA and certificates, and the wrong kinds."""

    ca: Path
    session: Issued
    operator: Issued
    expired: Issued
    other_ca: Issued
    self_signed: Issued


def _pki(folder: Path) -> Pki:
    cell = Authority(folder, "cell")
    rogue = Authority(folder, "rogue")
    return Pki(cell.ca, cell.issue("session", server=True), cell.issue("operator"),
               cell.issue("stale", expired=True), rogue.issue("intruder"),
               self_signed(folder, "mallory"))  # fmt: skip


class Served:
    """A session with mutual TLS on tls/127.0.0.1, served from a thread, and an operator
    holding a valid certificate (no heartbeats: no watchdog either)."""

    def __init__(self, folder: Path) -> None:
        self.pki = pki = _pki(folder)
        self.port = free_port()
        self.endpoint = f"tls/127.0.0.1:{self.port}"
        self.session = Session("pick_place", NAME, seed=3, speed=0.0,
                               snapshot_dir=folder / "snaps")  # fmt: skip
        access = ServerAccess(tls_cert=pki.session.cert, tls_key=pki.session.key, tls_ca=pki.ca)
        self.stop = threading.Event()
        self.thread = threading.Thread(
            target=serve, args=(self.session, [self.endpoint]),
            kwargs={"stop": self.stop, "access": access},
        )  # fmt: skip
        self.thread.start()
        self.op = self.client(self.operator_credentials(), find_s=30.0)
        self.op.status()
        reply = self.op.command("snapshot", snapshot="before")  # for `restore` to find
        assert reply.accepted and reply.snapshot is not None, reply.reason
        written = Path(reply.snapshot)  # at the next tick: before any e-stop of the tests
        # written when the session says so (its writer reaped), not when the file appears: a
        # `restore` waits 2 s for a snapshot still being written, then refuses it (under load
        # the forked writer's exit came later than that)
        deadline = time.monotonic() + 30
        while (not written.is_file() or self.session.snapshots.busy_with(written)) and (
            time.monotonic() < deadline
        ):
            time.sleep(0.01)
        assert written.is_file() and not self.session.snapshots.busy_with(written)

    def operator_credentials(self) -> Credentials:
        return Credentials(tls_ca=self.pki.ca, tls_cert=self.pki.operator.cert,
                           tls_key=self.pki.operator.key)  # fmt: skip

    def client(self, creds: Credentials, endpoint: str | None = None,
               find_s: float = 0.5) -> Client:  # fmt: skip
        return Client(NAME, [endpoint or self.endpoint], name="tls-test", find_s=find_s,
                      credentials=creds, heartbeat_s=None)  # fmt: skip

    def wait_state(self, state: str, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while self.session.state != state and time.monotonic() < deadline:
            time.sleep(0.01)
        assert self.session.state == state

    def close(self) -> None:
        self.stop.set()
        self.thread.join(30)
        self.op.close()


@pytest.fixture(scope="module")
def served(tmp_path_factory) -> Iterator[Served]:
    folder = tmp_path_factory.mktemp("mtls")
    with pytest.MonkeyPatch.context() as mp:  # snapshots signed with a key made here
        mp.delenv(KEY_ENV, raising=False)
        mp.setenv("XDG_CONFIG_HOME", str(folder / "config"))
        served = Served(folder)
        yield served
        served.close()


def _without_valid_certificate(served: Served, case: str) -> tuple[Credentials, str]:
    pki, ca = served.pki, served.pki.ca
    if case == "no TLS":
        return Credentials(), f"tcp/127.0.0.1:{served.port}"
    cert, key = {
        "no certificate": (None, None),
        "another CA": (pki.other_ca.cert, pki.other_ca.key),
        "self-signed": (pki.self_signed.cert, pki.self_signed.key),
        "expired": (pki.expired.cert, pki.expired.key),
        # refused by whichever end checks first that the key is not the certificate's
        "valid certificate, wrong key": (pki.operator.cert, pki.other_ca.key),
    }[case]
    return Credentials(tls_ca=ca, tls_cert=cert, tls_key=key), served.endpoint


@pytest.mark.parametrize(
    "case",
    ["no certificate", "another CA",  # the default suite; the other kinds (~2 s each): slow
     *(pytest.param(c, marks=pytest.mark.slow)
       for c in ("self-signed", "expired", "valid certificate, wrong key", "no TLS"))],
)  # fmt: skip
def test_a_client_without_a_valid_certificate_can_neither_reset_restore_nor_run(served, case):
    assert served.op.estop().accepted
    served.wait_state("ESTOPPED")
    before = served.op.status()
    creds, endpoint = _without_valid_certificate(served, case)
    # a second of retries for the first attempt (a valid client is answered within tens of
    # milliseconds on loopback), then the link would long have been up: shorter
    with served.client(creds, endpoint, find_s=1.0) as intruder:
        attempts = {
            "reset": intruder.reset,
            "restore": lambda: intruder.command("restore", snapshot="before"),
            "run": lambda: intruder.run("home"),
        }
        for op, attempt in attempts.items():
            with pytest.raises(LiveError, match="no Zenoh session could be opened"):
                attempt()
            intruder.find_s = 0.3
            assert served.session.state == "ESTOPPED", op
        assert not intruder.alive and intruder.losses == 0  # never saw the session at all
    after = served.op.status()
    assert after["state"] == "ESTOPPED" and after["task"] is None
    assert after["last_result"] == before["last_result"]  # no task ran in between
    assert after["tcp"] == before["tcp"]  # the arm did not move
    assert served.op.reset().accepted
    served.wait_state("IDLE")


def test_a_client_with_a_valid_certificate_resets_restores_and_runs(served):
    assert served.op.estop().accepted
    served.wait_state("ESTOPPED")
    with served.client(served.operator_credentials(), find_s=10.0) as operator:
        assert operator.alive or operator.status()["state"] == "ESTOPPED"
        assert operator.reset().accepted
        served.wait_state("IDLE")
        reply = operator.command("restore", snapshot="before")
        assert reply.accepted, reply.reason
        reply, result = operator.run("home", wait=True, timeout=120)
        assert reply.accepted, reply.reason
        assert result is not None and result["outcome"] == "succeeded"


# -- the command line: options, environment, refusals ---------------------------------------


def test_send_and_watch_take_the_client_certificate_from_the_environment_or_options(
    served, cli, monkeypatch
):
    pki = served.pki
    monkeypatch.setenv("ORCHESTRATOR_TLS_CA", str(pki.ca))
    monkeypatch.setenv("ORCHESTRATOR_CLIENT_CERT", str(pki.operator.cert))
    monkeypatch.setenv("ORCHESTRATOR_CLIENT_KEY", str(pki.operator.key))
    res = cli("send", NAME, "status", "--json", "--connect", served.endpoint)
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["status"]["state"] in STATES
    monkeypatch.delenv("ORCHESTRATOR_CLIENT_CERT")
    monkeypatch.delenv("ORCHESTRATOR_CLIENT_KEY")
    res = cli("watch", NAME, "--for", "1", "--connect", served.endpoint,
              "--tls-cert", str(pki.operator.cert), "--tls-key", str(pki.operator.key))  # fmt: skip
    assert res.exit_code == 0, res.stdout  # heartbeats heard to the end
    res = cli("watch", NAME, "--for", "1", "--connect", served.endpoint,
              "--tls-cert", str(pki.other_ca.cert), "--tls-key", str(pki.other_ca.key))  # fmt: skip
    assert res.exit_code == 1 and "LOST" in res.stdout


@pytest.mark.parametrize(
    ("listen", "given", "says"),
    [
        ("tcp/0.0.0.0", (), ["is not TLS", "missing --tls-cert CERT, --tls-key KEY, --tls-ca CA"]),
        ("tls/0.0.0.0", ("cert", "key"), ["missing --tls-ca CA"]),
        ("tcp/0.0.0.0", ("cert", "key", "ca", "users"), ["tcp/0.0.0.0:", "is not TLS"]),
        ("tls/[::]", ("users",), ["missing --tls-cert CERT, --tls-key KEY, --tls-ca CA"]),
        ("tls/cell1.example.com", ("ca",), ["missing --tls-cert CERT, --tls-key KEY"]),
    ],
    ids=["plain tcp", "no CA", "users over tcp", "users alone", "CA alone"],
)
def test_serve_beyond_loopback_without_mutual_tls_exits_2_naming_the_fix(
    cli, tmp_path, monkeypatch, listen, given, says
):
    for var in ("TLS_CERT", "TLS_KEY", "TLS_CA", "USERS"):  # never a full set by chance
        monkeypatch.delenv(f"ORCHESTRATOR_{var}", raising=False)
    files = {"cert": tmp_path / "c.pem", "key": tmp_path / "k.pem", "ca": tmp_path / "ca.pem",
             "users": tmp_path / "users"}  # fmt: skip
    files["users"].write_text("op:secret\n")
    files["users"].chmod(0o600)
    options = {"cert": "--tls-cert", "key": "--tls-key", "ca": "--tls-ca", "users": "--users"}
    args = [a for g in given for a in (options[g], str(files[g]))]
    res = cli("serve", "pick_place", "--session", "x", "--listen", f"{listen}:{free_port()}",
              *args)  # fmt: skip
    assert res.exit_code == 2 and res.exception is None, res.stderr
    text = " ".join(res.stderr.split())
    assert "can be reached from other machines" in text and "mutual TLS" in text
    assert "docs/live.md, Threat model" in text and "tcp/127.0.0.1" in text
    for part in says:
        assert part in text


def test_a_non_loopback_tls_endpoint_with_certificate_key_and_ca_is_admitted(tmp_path):
    cell = Authority(tmp_path, "cell")
    mine = cell.issue("session", server=True)
    access = ServerAccess(tls_cert=mine.cert, tls_key=mine.key, tls_ca=cell.ca)
    assert access.mutual and access.check(["tls/0.0.0.0:7447"], ["tls/10.0.0.2:7447"]) == []
    # a session on loopback joining a router elsewhere: its certificate goes there
    assert access.check(["tcp/127.0.0.1:7447"], ["tls/10.0.0.2:7447"]) == []
    with pytest.raises(AccessError, match="--tls-cert given but no tls/ endpoint"):
        access.check(["tcp/127.0.0.1:7447"], [])
    conf = zenoh_config(["tls/127.0.0.1:7447"], server=access, session="x")
    tls = json.loads(conf.get_json("transport/link/tls"))
    assert tls["enable_mtls"] is True and tls["root_ca_certificate"] == str(cell.ca)
    assert tls["listen_certificate"] == str(mine.cert)
    assert tls["connect_certificate"] == str(mine.cert)  # what it presents to --connect
    assert json.loads(conf.get_json("scouting/multicast/enabled")) is False
    assert json.loads(conf.get_json("scouting/gossip/enabled")) is False


def test_certificate_and_key_files_are_checked_before_connecting(tmp_path, cli):
    cell = Authority(tmp_path, "cell")
    mine = cell.issue("operator")
    with pytest.raises(AccessError, match="certificate and its key go together"):
        Credentials.resolve(tls_cert=mine.cert)
    not_a_key = tmp_path / "not-a-key.pem"
    not_a_key.write_bytes(cell.ca.read_bytes())
    not_a_key.chmod(0o600)
    with pytest.raises(AccessError, match=r"--tls-key .*: no PEM private key"):
        Credentials.resolve(tls_ca=cell.ca, tls_cert=mine.cert, tls_key=not_a_key)
    with pytest.raises(AccessError, match=r"--tls-ca .*: no such file"):
        Credentials.resolve(tls_ca=tmp_path / "missing.pem")
    mine.key.chmod(0o644)
    res = cli("ask", NAME, "go home", "--connect", f"tls/127.0.0.1:{free_port()}",
              "--tls-cert", str(mine.cert), "--tls-key", str(mine.key))  # fmt: skip
    assert res.exit_code == 2 and res.exception is None
    assert "readable by others (mode 644)" in res.stderr and "chmod 600" in res.stderr
    res = cli("send", NAME, "status", "--tls-cert", str(mine.cert))
    assert res.exit_code == 2 and "give both --tls-cert and --tls-key" in res.stderr
