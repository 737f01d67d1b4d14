"""Who may hand us a snapshot: the user's own key signs every snapshot, and only a snapshot
signed with it is ever unpickled.

A snapshot is a pickle, and loading a pickle runs whatever code it names: a snapshot from
someone else is a program from someone else. So every snapshot file carries an HMAC-SHA256 of
its bytes under a per-user secret key, and `run --from` checks it before anything is
unpickled; a file it does not verify is refused (exit 2) with the reason. The key is
`$ORCHESTRATOR_SNAPSHOT_KEY` (a shared secret for a team or a batch cluster) if set, else the
file `snapshot.key` in `$XDG_CONFIG_HOME/orchestrator` (default `~/.config/orchestrator`), made
on first use: 32 random bytes, readable by its owner only. A key file that others can read or
write is refused: anyone who can read it can forge snapshots.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import stat
from pathlib import Path

from .pickler import SnapshotError

__all__ = ["KEY_ENV", "NoKeyError", "key_path", "sign", "signing_key", "verify"]

KEY_ENV = "ORCHESTRATOR_SNAPSHOT_KEY"
"""Environment variable holding the signing key itself (any text; overrides the key file)."""
_KEY_BYTES = 32


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
        return env.encode()
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
    key = path.read_bytes()
    if len(key) < 16:
        raise SnapshotError(f"{path}: the snapshot key is too short ({len(key)} bytes)")
    return key


def _make_key(path: Path) -> None:
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:  # another process made it meanwhile
        return
    except OSError as exc:
        raise SnapshotError(f"cannot make the snapshot key {path}: {exc}") from None
    with os.fdopen(fd, "wb") as f:
        f.write(secrets.token_bytes(_KEY_BYTES))


def sign(data: bytes, key: bytes | None = None) -> str:
    """HMAC-SHA256 of `data` under `key` (default: the user's), in hex."""
    return hmac.new(key if key is not None else signing_key(), data, hashlib.sha256).hexdigest()


def verify(data: bytes, signature: str, key: bytes | None = None) -> bool:
    """`signature` is `data`'s under `key` (default: the user's, never made here)."""
    expected = sign(data, key if key is not None else signing_key(create=False))
    return hmac.compare_digest(expected, signature)
