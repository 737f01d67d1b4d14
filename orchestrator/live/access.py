"""Who may reach a live session, and with what: Zenoh's own TLS, authentication and access control.

A session that listens only on loopback needs nothing (the default, `tcp/127.0.0.1:7447`).
One that other machines can reach must use **mutual TLS**: a `tls/HOST:PORT` endpoint,
`serve --tls-cert/--tls-key` (the session's certificate) and `--tls-ca` (the CA whose
certificates it admits); Zenoh's TLS transport then refuses, in the handshake, every client
that does not present a certificate signed by that CA (`transport/link/tls/enable_mtls`).
Clients present theirs with `--tls-cert/--tls-key` and verify the session's with `--tls-ca`.
On top, `serve --users FILE` turns on Zenoh's user/password authentication
(`transport/auth/usrpwd`, the file in Zenoh's own dictionary format, one `user:password` a
line) and its access control (`access_control`): every user in the file is an *operator*
(commands, heartbeats, e-stop) unless named with `--viewer` (status, events and e-stop only:
an e-stop is everyone's, a `reset` is not).

Clients take their credentials from options, environment variables or a credentials file
(`user:password`, readable by its owner only), in that order of precedence.
"""

from __future__ import annotations

import ipaddress
import json
import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..exceptions import OrchestratorError

__all__ = [
    "LEASE_MS",
    "MAX_MESSAGE_BYTES",
    "AccessError",
    "Credentials",
    "ServerAccess",
    "acl",
    "is_loopback",
    "read_user_file",
    "zenoh_config",
]

LEASE_MS = 1000
"""Zenoh link lease [ms]: a peer silent this long (no data, no keep-alive) is gone. Zenoh's
default is 10 s; 1 s lets a client notice a lost session within about a second even when
the network, not the process, failed (a killed process closes its socket: noticed at once)."""
KEEP_ALIVES = 4
"""Keep-alive messages per lease (Zenoh's advice: four)."""
MAX_MESSAGE_BYTES = 64 * 2**20
"""Largest message a session reassembles [bytes] (Zenoh's default: 1 GiB). A command is a
few hundred bytes and is refused by name above 64 KiB; a payload this large is still
answered `too large`; a larger one is dropped by Zenoh unanswered, so no client can make the
session allocate more than this per link."""
_LOCAL_PROTOCOLS = ("unixsock-stream", "unixpipe", "vsock")
_WATCH = ("status", "heartbeat", "events", "alive")
_OPERATE = ("command", "clients/heartbeat")


class AccessError(OrchestratorError):
    """Credentials or access settings are unusable: the message names the file or option."""


def is_loopback(endpoint: str) -> bool:
    """True if `endpoint` (`tcp/127.0.0.1:7447`, `tls/[::1]:7447`, `unixsock-stream/...`)
    can only be reached from this machine."""
    proto, _, rest = endpoint.partition("/")
    if proto in _LOCAL_PROTOCOLS:
        return True
    host = rest.split("#", 1)[0].split("?", 1)[0].rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # a host name other than localhost: it may resolve anywhere
        return False


def _private_file(path: Path, what: str, holds: str = "passwords") -> str:
    """The text of a secret file, refused when others may read it (as ssh does)."""
    try:
        mode = path.stat().st_mode
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise AccessError(f"{what} {path}: cannot read it ({reason})") from None
    if os.name == "posix" and mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise AccessError(
            f"{what} {path}: readable by others (mode {stat.S_IMODE(mode):o}); "
            f"it holds {holds}: chmod 600 {path}"
        )
    return text


def _pem(path: Path, option: str, kind: str) -> None:
    """Refuse a certificate or key file that is missing or holds no PEM `kind` block
    (`CERTIFICATE`, `PRIVATE KEY`), naming the option; a key readable by others too."""
    if not path.is_file():
        raise AccessError(f"{option} {path}: no such file")
    if kind == "PRIVATE KEY":
        text = _private_file(path, option, "a private key")
    else:
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
            raise AccessError(f"{option} {path}: cannot read it ({reason})") from None
    if f"{kind}-----" not in text:
        raise AccessError(f"{option} {path}: no PEM {kind.lower()} in it (expected a "
                          f"'-----BEGIN ...{kind}-----' block)")  # fmt: skip


def read_user_file(path: Path, what: str = "users file") -> list[tuple[str, str]]:
    """The `user:password` lines of a file (blank lines skipped), in Zenoh's dictionary format.

    Raises:
        AccessError: Unreadable, readable by others, or a line that is not `user:password`
            (the error names the line, never its content).
    """
    entries = []
    for n, raw in enumerate(_private_file(path, what).splitlines(), 1):
        if not raw.strip():
            continue
        user, colon, password = raw.strip().partition(":")
        if not colon or not user.strip() or not password.strip():
            raise AccessError(f"{path}:{n}: expected user:password (both non-empty)")
        entries.append((user.strip(), password.strip()))
    if not entries:
        raise AccessError(f"{path}: no user:password line")
    return entries


@dataclass(frozen=True)
class Credentials:
    """What a client presents: a user and password (Zenoh usrpwd), and for `tls/` endpoints
    the CA it trusts and its own certificate (mutual TLS).

    Attributes:
        user: The user name (None: no authentication).
        password: Its password.
        tls_ca: PEM file of the CA that signed the session's certificate (`tls/` endpoints).
        tls_cert: PEM certificate this client presents (signed by the CA the session admits).
        tls_key: Its private key (PEM, readable by its owner only).
    """

    user: str | None = None
    password: str | None = None
    tls_ca: Path | None = None
    tls_cert: Path | None = None
    tls_key: Path | None = None

    @property
    def mutual(self) -> bool:
        """Whether this client presents a certificate."""
        return self.tls_cert is not None

    @classmethod
    def resolve(
        cls,
        user: str | None = None,
        password: str | None = None,
        credentials_file: Path | None = None,
        tls_ca: Path | None = None,
        tls_cert: Path | None = None,
        tls_key: Path | None = None,
    ) -> Credentials:
        """Options first, then the credentials file (`user:password`, owner-readable only).

        The CLI maps `ORCHESTRATOR_USER`, `ORCHESTRATOR_PASSWORD`, `ORCHESTRATOR_CREDENTIALS`,
        `ORCHESTRATOR_TLS_CA`, `ORCHESTRATOR_CLIENT_CERT` and `ORCHESTRATOR_CLIENT_KEY` onto
        these arguments.

        Raises:
            AccessError: The file is unusable, only one of user and password is given, only
                one of certificate and key, or a certificate or key file is unusable.
        """
        if credentials_file is not None:
            entries = read_user_file(credentials_file, "credentials file")
            if len(entries) != 1:
                raise AccessError(f"{credentials_file}: one user:password line expected")
            file_user, file_password = entries[0]
            user = user or file_user
            password = password or file_password
        if bool(user) != bool(password):
            missing = "password" if user else "user"
            raise AccessError(
                f"a {'user' if user else 'password'} without a {missing}: give both "
                "(--user and --password, ORCHESTRATOR_USER and ORCHESTRATOR_PASSWORD, or "
                "--credentials FILE with a user:password line)"
            )
        if (tls_cert is None) != (tls_key is None):
            raise AccessError(
                "a client certificate and its key go together: give both --tls-cert and "
                "--tls-key (or ORCHESTRATOR_CLIENT_CERT and ORCHESTRATOR_CLIENT_KEY)"
            )
        for path, option, kind in ((tls_ca, "--tls-ca", "CERTIFICATE"),
                                   (tls_cert, "--tls-cert", "CERTIFICATE"),
                                   (tls_key, "--tls-key", "PRIVATE KEY")):  # fmt: skip
            if path is not None:
                _pem(path, option, kind)
        return cls(user or None, password or None, tls_ca, tls_cert, tls_key)


@dataclass(frozen=True)
class ServerAccess:
    """How a session admits clients.

    Attributes:
        users_file: `user:password` lines (Zenoh's dictionary file); None: no authentication.
        viewers: Users of that file who may only watch (and e-stop).
        tls_cert: PEM certificate `tls/` listeners present (and `tls/` connections, with
            mutual TLS).
        tls_key: Its private key (PEM).
        tls_ca: PEM CA whose certificates the session admits (mutual TLS: a client without
            one is refused in the handshake); it also verifies routers on `connect`.
    """

    users_file: Path | None = None
    viewers: tuple[str, ...] = ()
    tls_cert: Path | None = None
    tls_key: Path | None = None
    tls_ca: Path | None = None

    @property
    def mutual(self) -> bool:
        """Whether `tls/` links ask the peer for a certificate signed by `tls_ca`."""
        return None not in (self.tls_cert, self.tls_key, self.tls_ca)

    def mutual_out(self, connect: list[str]) -> bool:
        """Whether the session presents its certificate to a `tls/` endpoint it connects to."""
        return self.mutual and any(e.startswith("tls/") for e in connect)

    def check(self, listen: list[str], connect: list[str]) -> list[str]:
        """Refuse settings that would expose a session without mutual TLS, or cannot work.

        Returns:
            The users of the users file (empty without one).

        Raises:
            AccessError: With the fix: a non-loopback endpoint that is not `tls/` or without
                certificate, key and CA; a viewer not in the file; TLS options without a
                `tls/` endpoint or the reverse; an unusable certificate or key file.
        """
        users = [u for u, _ in read_user_file(self.users_file)] if self.users_file else []
        exposed = [e for e in [*listen, *connect] if not is_loopback(e)]
        if exposed:
            _refuse_unless_mutual(exposed, self)
        unknown = [v for v in self.viewers if v not in users]
        if unknown:
            raise AccessError(
                f"--viewer {', '.join(unknown)}: not in the users file"
                + (f" (users: {', '.join(users)})" if users else " (no --users given)")
            )
        if len(set(users) - set(self.viewers)) == 0 and users:
            raise AccessError("every user is a --viewer: nobody could command the session")
        tls = [e for e in listen if e.startswith("tls/")]
        if (self.tls_cert is None) != (self.tls_key is None):
            raise AccessError("--tls-cert and --tls-key go together")
        if tls and self.tls_cert is None:
            raise AccessError(f"{tls[0]}: a tls/ endpoint needs --tls-cert and --tls-key")
        if self.tls_cert is not None and not tls and not self.mutual_out(connect):
            raise AccessError("--tls-cert given but no tls/ endpoint to --listen on (or, with "
                              "--tls-ca, to --connect to)")  # fmt: skip
        for path, option, kind in ((self.tls_ca, "--tls-ca", "CERTIFICATE"),
                                   (self.tls_cert, "--tls-cert", "CERTIFICATE"),
                                   (self.tls_key, "--tls-key", "PRIVATE KEY")):  # fmt: skip
            if path is not None:
                _pem(path, option, kind)
        return users


def _refuse_unless_mutual(exposed: list[str], access: ServerAccess) -> None:
    """Other machines can reach `exposed`: only `tls/` with certificate, key and CA will do."""
    plain = [e for e in exposed if not e.startswith("tls/")]
    given = (("--tls-cert CERT", access.tls_cert), ("--tls-key KEY", access.tls_key),
             ("--tls-ca CA", access.tls_ca))  # fmt: skip
    missing = [option for option, path in given if path is None]
    if not plain and not missing:
        return
    why = []
    if plain:
        why.append(f"{', '.join(plain)} {'is' if len(plain) == 1 else 'are'} not TLS "
                   "(use tls/HOST:PORT)")  # fmt: skip
    if missing:
        why.append(f"missing {', '.join(missing)}")
    raise AccessError(
        f"{', '.join(exposed)} can be reached from other machines, which is allowed only with "
        f"mutual TLS: {'; '.join(why)}. Pass --tls-cert CERT --tls-key KEY (the session's "
        "certificate) and --tls-ca CA (the CA that signs your clients' certificates) with a "
        "tls/ endpoint (see docs/live.md, Threat model), or listen on tcp/127.0.0.1"
    )


def _rule(rid: str, flow: str, messages: list[str], keys: list[str]) -> dict[str, Any]:
    return {"id": rid, "permission": "allow", "flows": [flow], "messages": messages,
            "key_exprs": keys}  # fmt: skip


def acl(session: str, users: list[str], viewers: tuple[str, ...]) -> dict[str, Any]:
    """Zenoh's `access_control` for a session: deny by default; everyone may watch
    (subscribe to status, heartbeat, events; query `status`; see the liveliness token) and
    e-stop; operators may also command and send heartbeats. Nobody may publish on the
    session's own keys (no forged status or events)."""
    watched = [f"orchestrator/{session}/{leaf}" for leaf in _WATCH]
    estop = [f"orchestrator/{session}/estop"]
    operate = [f"orchestrator/{session}/{leaf}" for leaf in _OPERATE]
    operators = [u for u in users if u not in viewers]
    rules = [
        _rule("watch_in", "ingress", ["declare_subscriber", "query",
              "declare_liveliness_subscriber", "liveliness_query"], watched),
        _rule("watch_out", "egress", ["put", "declare_queryable", "reply", "liveliness_token"],
              watched),
        _rule("estop_in", "ingress", ["query", "put"], estop),
        _rule("estop_out", "egress", ["declare_queryable", "declare_subscriber", "reply"], estop),
        _rule("operate_in", "ingress", ["query", "put"], operate),
        _rule("operate_out", "egress", ["declare_queryable", "declare_subscriber", "reply"],
              operate),
    ]  # fmt: skip
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [
            {"id": "everyone", "usernames": users},
            {"id": "operators", "usernames": operators},
        ],
        "policies": [
            {"rules": ["watch_in", "watch_out", "estop_in", "estop_out"], "subjects": ["everyone"]},
            {"rules": ["operate_in", "operate_out"], "subjects": ["operators"]},
        ],
    }


_TLS = "transport/link/tls/"


def _client_tls(credentials: Credentials) -> dict[str, Any]:
    """Zenoh's TLS settings for a client: the CA it trusts, and its certificate (mTLS)."""
    entries: dict[str, Any] = {}
    if credentials.tls_ca is not None:
        entries[_TLS + "root_ca_certificate"] = str(credentials.tls_ca)
    if credentials.mutual:
        entries[_TLS + "enable_mtls"] = True
        entries[_TLS + "connect_certificate"] = str(credentials.tls_cert)
        entries[_TLS + "connect_private_key"] = str(credentials.tls_key)
    return entries


def _server_tls(server: ServerAccess, credentials: Credentials | None) -> dict[str, Any]:
    """Zenoh's TLS settings for a session: its certificate on `tls/` listeners; with a CA,
    mutual TLS (a client must present a certificate that CA signed; a link closes when its
    certificate expires), the session presenting its own certificate on `tls/` connections
    unless `credentials` name another."""
    entries: dict[str, Any] = {}
    if server.tls_cert is not None:
        entries[_TLS + "listen_certificate"] = str(server.tls_cert)
        entries[_TLS + "listen_private_key"] = str(server.tls_key)
    if server.tls_ca is not None:
        entries[_TLS + "root_ca_certificate"] = str(server.tls_ca)
    if server.mutual:
        entries[_TLS + "enable_mtls"] = True
        entries[_TLS + "close_link_on_expiration"] = True
        if credentials is None or not credentials.mutual:
            entries[_TLS + "connect_certificate"] = str(server.tls_cert)
            entries[_TLS + "connect_private_key"] = str(server.tls_key)
    return entries


def zenoh_config(
    listen: list[str] | None = None,
    connect: list[str] | None = None,
    credentials: Credentials | None = None,
    server: ServerAccess | None = None,
    session: str | None = None,
) -> Any:
    """A Zenoh configuration: multicast and gossip scouting off, explicit endpoints, a 1 s
    lease, and the TLS (mutual with a CA), authentication and access control asked for.

    Args:
        listen: Endpoints to listen on (a session), e.g. `tcp/127.0.0.1:7447`.
        connect: Endpoints to connect to (a client, or a session joining a router).
        credentials: The user and certificate this node presents, the CA it trusts
            (clients; a session connecting out).
        server: How a session admits clients (with `session`, its name, for the ACL).
        session: The session's name (needed with `server.users_file`).

    Raises:
        AccessError: Unusable settings (see `ServerAccess.check`).
    """
    import zenoh

    listen, connect = list(listen or []), list(connect or [])
    entries: dict[str, Any] = {
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
        "listen/endpoints": listen,
        "connect/endpoints": connect,
        "transport/link/tx/lease": LEASE_MS,
        "transport/link/tx/keep_alive": KEEP_ALIVES,
    }
    if credentials is not None and credentials.user:
        entries["transport/auth/usrpwd/user"] = credentials.user
        entries["transport/auth/usrpwd/password"] = credentials.password
    if credentials is not None:
        entries.update(_client_tls(credentials))
    if server is not None:
        entries["transport/link/rx/max_message_size"] = MAX_MESSAGE_BYTES
        users = server.check(listen, connect)
        if server.users_file is not None:
            if session is None:
                raise ValueError("zenoh_config: a session name is needed for access control")
            entries["transport/auth/usrpwd/dictionary_file"] = str(server.users_file)
            entries["access_control"] = acl(session, users, server.viewers)
        entries.update(_server_tls(server, credentials))
    conf = zenoh.Config()
    for path, value in entries.items():
        conf.insert_json5(path, json.dumps(value))
    return conf
