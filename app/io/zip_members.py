"""What an uploaded zip may hold, checked member by member before anything is extracted or
parsed: safe names (no absolute paths, ``..``, links or encrypted members), bounded counts and
sizes (:class:`Limits`, against zip bombs), members read within the remaining budget. Used by
the workspace archives (:mod:`app.io.exchange`) and the dataset uploads
(:mod:`app.io.dataset_import`).
"""

from __future__ import annotations

import stat
import zipfile
import zlib
from dataclasses import dataclass

MAX_UPLOAD_BYTES = 20 * 2**20  # an upload (model or archive) larger than this is refused
MAX_MEMBERS = 10_000  # files in a workspace archive
MAX_UNCOMPRESSED_BYTES = 256 * 2**20  # sum of the archive's uncompressed sizes

@dataclass(frozen=True)
class Limits:
    """Bounds on what an upload may hold (see the module constants)."""

    max_upload_bytes: int = MAX_UPLOAD_BYTES
    max_members: int = MAX_MEMBERS
    max_uncompressed_bytes: int = MAX_UNCOMPRESSED_BYTES


def format_size(n_bytes: int) -> str:
    """``"1.5 MB"``-style size (powers of 1024)."""
    if n_bytes < 1024:
        return f"{n_bytes} bytes"
    if n_bytes < 1024**2:
        return f"{n_bytes / 1024:.1f} KB"
    return f"{n_bytes / 1024**2:.1f} MB"


def check_member(info: zipfile.ZipInfo) -> str:
    """The member's name if it is safe to read, else ValueError."""
    name = info.filename
    if "\\" in name or "\x00" in name:
        raise ValueError(f"{name!r}: a member name with a backslash or NUL is refused")
    if name.startswith("/") or (len(name) > 1 and name[1] == ":"):
        raise ValueError(f"{name}: absolute paths are refused")
    parts = name.rstrip("/").split("/")
    if any(part in ("", ".", "..") for part in parts):
        raise ValueError(f"{name}: '..', '.' and empty path components are refused")
    mode = info.external_attr >> 16
    if stat.S_ISLNK(mode):
        raise ValueError(f"{name}: symbolic links are refused")
    if info.flag_bits & 0x1:
        raise ValueError(f"{name}: encrypted members are refused")
    return name


def read_member(
    archive: zipfile.ZipFile, info: zipfile.ZipInfo, label: str, budget: list[int]
) -> bytes:
    """A member's bytes, never more than its declared size nor the remaining budget."""
    try:
        with archive.open(info) as handle:
            data = handle.read(min(info.file_size, budget[0]) + 1)
    except (
        zipfile.BadZipFile,
        zlib.error,
        NotImplementedError,
        RuntimeError,
        EOFError,
        OSError,
        ValueError,
    ) as exc:
        raise ValueError(f"{label}: cannot be read from the archive ({exc})") from None
    if len(data) > info.file_size or len(data) > budget[0]:
        raise ValueError(f"{label}: larger than the archive declares")
    budget[0] -= len(data)
    return data


def member_text(data: bytes, label: str) -> str:
    """A member's bytes as UTF-8 text (a byte-order mark dropped), or ValueError naming it."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{label}: not UTF-8 text ({exc})") from None
