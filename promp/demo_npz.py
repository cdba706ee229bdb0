"""Demonstrations as NPZ archives (the studio's exchange of one demonstration): ``times`` (n,),
``values`` (n, D), ``columns`` (D,) unicode and ``name`` (). Read with ``allow_pickle=False``:
an archive of objects is refused, never unpickled."""

from __future__ import annotations

import io
import zipfile

import numpy as np

from promp.data import Demonstration

__all__ = ["demo_from_npz_bytes", "demo_to_npz_bytes"]


def demo_to_npz_bytes(demo: Demonstration) -> bytes:
    """NPZ with ``times`` (n,), ``values`` (n, D), ``columns`` (D,) unicode, ``name`` ()."""
    buffer = io.BytesIO()
    np.savez(
        buffer,
        times=demo.times,
        values=demo.values,
        columns=np.array(demo.columns, dtype=str),
        name=np.array(demo.name, dtype=str),
    )
    return buffer.getvalue()


def demo_from_npz_bytes(data: bytes, label: str = "demonstration") -> Demonstration:
    """Read :func:`demo_to_npz_bytes` output (never unpickles)."""
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise ValueError("a single array, not an archive")
        with npz:
            missing = {"times", "values", "columns"} - set(npz.files)
            if missing:
                raise ValueError(f"NPZ lacks {sorted(missing)}")
            times, values = npz["times"], npz["values"]
            columns = tuple(str(c) for c in npz["columns"].reshape(-1))
            name = str(npz["name"]) if "name" in npz.files else ""
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        # numpy's own message for object arrays suggests loading unsafely: never do that.
        reason = "object arrays are refused" if "pickle" in str(exc) else str(exc)
        raise ValueError(f"{label}: not an NPZ file of numeric arrays ({reason})") from None
    if times.dtype.kind not in "fiu" or values.dtype.kind not in "fiu":
        raise ValueError(f"{label}: times and values must be numeric")
    try:
        return Demonstration(times, values, columns, name=name)
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from exc
