"""Names of a conveyor cell's parcels: the recycled bodies and the parcels they carry."""

from __future__ import annotations

__all__ = ["parcel_id", "pool_body_name"]


def pool_body_name(i: int) -> str:
    """The scene name of the conveyor's `i`-th parcel body (0-based)."""
    return f"pool_parcel_{i}"


def parcel_id(k: int, shift: int) -> str:
    """The id of the `k`-th parcel (0-based) of a shift of `shift` parcels, as the task log
    lists it: `parcel_0007`, zero-padded so that ids sort in feed order."""
    return f"parcel_{k:0{max(2, len(str(shift - 1)))}d}"
