"""Who wrote a snapshot, and is it unchanged: the user's own key signs every snapshot.

A snapshot is data (snapfile.py): reading one cannot run code, signed or not. The signature
is integrity and provenance: a file changed, cut or made by someone else is refused with the
reason, and `orchestrator snapshot trust FILE` signs one the user has decided to take. Every
snapshot file carries an HMAC-SHA256 of its bytes under a per-user secret key: the key is
`$ORCHESTRATOR_SNAPSHOT_KEY` (a shared secret for a team or a batch cluster: at least
`MIN_KEY_BYTES` bytes, else refused) if set, else the file `snapshot.key` in
`$XDG_CONFIG_HOME/orchestrator` (default `~/.config/orchestrator`), made on first use: 32
random bytes, readable by its owner only. A key file that others can read or write, or that is
shorter than `MIN_KEY_BYTES`, is refused.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import stat
from pathlib import Path

from .errors import SnapshotError

__all__ = ["KEY_ENV", "MIN_KEY_BYTES", "NoKeyError", "key_path", "sign", "signing_key", "verify"]

KEY_ENV = "ORCHESTRATOR_SNAPSHOT_KEY"
"""Environment variable holding the signing key itself (overrides the key file)."""
_KEY_BYTES = 32
MIN_KEY_BYTES = 32
"""The shortest key taken [bytes]: a short key is guessed, and then snapshots are forged."""


class NoKeyError(SnapshotError):
    """This user has no snapshot key yet (has written no snapshot)."""


def key_path() -> Path:
    """Where the user's key file is (it may not exist yet)."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "orchestrator" / "snapshot.key"


def signing_key(create: bool = True) -> bytes:
    """The user's snapshot key (made if missing and `create`).

    Raises:
        SnapshotError: The key file is readable or writable by others, or cannot be made.
    """
    env = os.environ.get(KEY_ENV)
    if env:
        key = env.encode("utf-8", "surrogateescape")
        if len(key) < MIN_KEY_BYTES:
            raise SnapshotError(
                f"${KEY_ENV} is {len(key)} bytes long: a snapshot key must be at least "
                f"{MIN_KEY_BYTES} bytes (e.g. {KEY_ENV}=$(openssl rand -hex 32)), or unset it "
                f"to use your own key file ({key_path()})"
            )
        return key
    path = key_path()
    if not path.exists():
        if not create:
            raise NoKeyError(f"no snapshot key at {path}: this user has written no snapshot")
        _make_key(path)
    mode = path.stat().st_mode
    if mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise SnapshotError(
            f"{path}: the snapshot key is open to other users (mode {stat.filemode(mode)}): "
            f"anyone who reads it can forge snapshots; chmod 600 {path}"
        )
    with open(path, "rb") as f:
        key = f.read(4096)
    if len(key) < MIN_KEY_BYTES:
        raise SnapshotError(
            f"{path}: the snapshot key is {len(key)} bytes long, at least {MIN_KEY_BYTES} are "
            f"needed: remove the file and a new one is made with the next snapshot"
        )
    return key


def _make_key(path: Path) -> None:
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:  # another process made it meanwhile
        return
    except OSError as exc:
        raise SnapshotError(f"cannot make the snapshot key {path}: {exc}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(secrets.token_bytes(_KEY_BYTES))
    except OSError as exc:  # a full disk: no half key is left to sign with
        path.unlink(missing_ok=True)
        raise SnapshotError(f"cannot make the snapshot key {path}: {exc.strerror or exc}") from None


def sign(data: bytes, key: bytes | None = None) -> str:
    """HMAC-SHA256 of `data` under `key` (default: the user's), in hex."""
    return hmac.new(key if key is not None else signing_key(), data, hashlib.sha256).hexdigest()


def verify(data: bytes, signature: str, key: bytes | None = None) -> bool:
    """`signature` is `data`'s under `key` (default: the user's, never made here)."""
    expected = sign(data, key if key is not None else signing_key(create=False))
    return hmac.compare_digest(expected, signature)
