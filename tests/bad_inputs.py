"""A generated corpus of malformed inputs for every loader and upload path (see
``tests/test_bad_input.py``).

Each generator yields ``(case, payload, expected)``: a short name of the mutation, the bytes or
arrays to feed, and a lowercase fragment the refusal must contain (it names the problem), or ""
where any clear message will do (random bytes). Everything is deterministic: mutations of valid
files made by the studio's own writers, so the corpus follows the formats as they change.
"""

from __future__ import annotations

import io
import json
import math
import warnings
import zipfile
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

Case = tuple[str, Any, str]


# ------------------------------------------------------------------------------ bytes


def truncations(content: bytes, n: int = 6) -> Iterator[bytes]:
    """``content`` cut at ``n`` places spread over its length (never whole, never empty)."""
    for k in range(1, n + 1):
        cut = max(1, min(len(content) - 1, (k * len(content)) // (n + 1)))
        yield content[:cut]


def random_bytes(seed: int, n: int = 8) -> Iterator[bytes]:
    rng = np.random.default_rng(seed)
    for size in rng.integers(1, 4096, size=n):
        yield rng.integers(0, 256, size=int(size), dtype=np.uint8).tobytes()


def zip_of(members: dict[str, bytes], *, symlink: str | None = None) -> bytes:
    """A zip archive of ``members`` (name -> bytes), names written as given (``../x`` too);
    ``symlink`` names a member stored as a symbolic link."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            info = zipfile.ZipInfo(name, date_time=(2024, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            mode = 0o120777 if name == symlink else 0o100644
            info.external_attr = mode << 16
            archive.writestr(info, data)
    return buffer.getvalue()


def zip_with_duplicate(name: str, first: bytes, second: bytes, others: dict[str, bytes]) -> bytes:
    """A zip of ``others`` with ``name`` in it exactly twice (``first``, then ``second``)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for member, data in others.items():
            if member != name:
                archive.writestr(member, data)
        archive.writestr(name, first)
        with warnings.catch_warnings():  # zipfile warns about the duplicate: that is the point
            warnings.simplefilter("ignore")
            archive.writestr(name, second)
    return buffer.getvalue()


# ------------------------------------------------------------------------------ model JSON

BAD_VALUES: dict[str, tuple[Any, str]] = {
    # JSON value replacing a field -> what the refusal must mention
    "a string": ("oops", ""),
    "null": (None, ""),
    "an object": ({"a": 1}, ""),
    "a boolean": (True, ""),
    "an empty list": ([], ""),
}


def _json(obj: Any) -> bytes:
    return json.dumps(obj, allow_nan=True).encode("utf-8")


def model_cases(valid: bytes) -> Iterator[Case]:
    """Malformed model files derived from ``valid`` (a model the studio wrote)."""
    data = json.loads(valid)
    yield "0 bytes", b"", "empty"
    yield "not UTF-8", b"\xff\xfe\x00{" + valid[:50], "utf-8"
    yield "a JSON list", b"[1, 2, 3]", "json object"
    yield "a JSON number", b"42", "json object"
    yield "nested too deeply", b"[" * 100_000 + b"]" * 100_000, ""
    for i, part in enumerate(truncations(valid)):
        yield f"truncated #{i}", part, "json"
    for i, part in enumerate(random_bytes(seed=1)):
        yield f"random bytes #{i}", part, ""
    yield "wrong format tag", _json({**data, "format": "something-else"}), "format"
    yield "unknown version", _json({**data, "version": 99}), "version"
    for key in data:
        if key in ("report",):
            continue
        yield f"no {key!r}", _json({k: v for k, v in data.items() if k != key}), key
    for key in ("layout", "settings", "primitives", "sample_period"):
        for what, (value, _) in BAD_VALUES.items():
            yield f"{key} is {what}", _json({**data, key: value}), ""
    yield "sample_period NaN", _json({**data, "sample_period": math.nan}), "sample_period"
    yield "sample_period negative", _json({**data, "sample_period": -0.01}), "sample_period"
    prim = data["primitives"][0]
    for key, value in prim.items():
        if key == "name":
            continue
        others = data["primitives"][1:]

        def with_field(v: Any, key: str = key, others: list = others) -> bytes:
            return _json({**data, "primitives": [{**prim, key: v}, *others]})

        yield f"primitive without {key!r}", _json(
            {**data, "primitives": [{k: v for k, v in prim.items() if k != key}, *others]}
        ), key
        if isinstance(value, list) and value and not isinstance(value[0], list):
            yield f"{key} with NaN", with_field([math.nan, *value[1:]]), key
            yield f"{key} with inf", with_field([math.inf, *value[1:]]), key
            yield f"{key} with 1e400", with_field([1e400, *value[1:]]), key
            if key != "alphas":  # the training alphas: as many as there were demonstrations
                yield f"{key} one short", with_field(value[:-1]), key
            yield f"{key} of strings", with_field(["x"] * len(value)), ""
        elif isinstance(value, list) and value and isinstance(value[0], list):
            yield f"{key} ragged", with_field([value[0][:-1], *value[1:]]), ""
            yield f"{key} with NaN", with_field([[math.nan] * len(value[0]), *value[1:]]), key
            yield f"{key} one row short", with_field(value[:-1]), key
        for what, (bad, _) in BAD_VALUES.items():
            if bad == value or (what == "an empty list" and value == []):
                continue
            yield f"{key} is {what}", with_field(bad), ""
    twin = dict(data["primitives"][0])
    yield "duplicated primitive names", _json({**data, "primitives": [prim, twin]}), "duplicate"
    for name in ("../escape", "a/b", "", "é" * 50, "名前/x", "con\x00"):
        yield f"primitive named {name!r}", _json(
            {**data, "primitives": [{**prim, "name": name}, *data["primitives"][1:]]}
        ), "name"


# ------------------------------------------------------------------------------ CSV demos


def csv_text(rows: list[list[Any]], header: list[str]) -> str:
    lines = [",".join(header)] + [",".join(str(v) for v in row) for row in rows]
    return "\n".join(lines) + "\n"


def csv_cases(valid: str) -> Iterator[Case]:
    """Malformed CSV demonstrations derived from ``valid`` (``t,<columns>`` and samples)."""
    lines = valid.strip().splitlines()
    header, rows = lines[0], lines[1:]
    n_cols = header.count(",") + 1
    yield "empty", "", "empty"
    yield "header only", header + "\n", "no samples"
    yield "one sample", "\n".join([header, rows[0]]), "2 samples"
    yield "no t column", "\n".join([header.replace("t,", "time,", 1), *rows]), "'t'"
    yield "ragged row", "\n".join([header, rows[0], rows[1] + ",1", *rows[2:]]), "values"
    yield "short row", "\n".join([header, rows[0].rsplit(",", 1)[0], *rows[1:]]), "values"
    for token in ("abc", "", "1,5", "0x1G"):
        bad = ",".join(["0.5"] * (n_cols - 1) + [token]) if token != "1,5" else rows[1] + ",5"
        yield f"cell {token!r}", "\n".join([header, rows[0], bad, *rows[2:]]), ""
    for token, expected in (("nan", "nan"), ("inf", "infinite"), ("-inf", "infinite"),
                            ("1e400", "infinite"), ("1e300", "magnitude")):  # fmt: skip
        cells = rows[1].split(",")
        cells[-1] = token
        yield f"a value {token}", "\n".join([header, rows[0], ",".join(cells), *rows[2:]]), expected
    yield "times repeat", "\n".join([header, rows[0], rows[0], *rows[1:]]), "increasing"
    yield "times backwards", "\n".join([header, *reversed(rows)]), "increasing"
    cells = header.split(",")
    yield "duplicated column", "\n".join([",".join([*cells[:-1], cells[1]]), *rows]), "duplicate"
    for i, k in enumerate(range(1, len(rows), max(1, len(rows) // 5))):
        # Cut inside a row, after its first cell: a ragged last row. (A cut that leaves whole
        # rows, or whole numbers, is a valid shorter demonstration and cannot be told apart.)
        first = rows[k].split(",")[0]
        yield f"truncated in row {k} (#{i})", "\n".join([header, *rows[:k], first + ","]), "values"


# ------------------------------------------------------------------------------ NPZ demos


def npz_bytes(**arrays: Any) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def npz_cases(times: np.ndarray, values: np.ndarray, columns: tuple[str, ...]) -> Iterator[Case]:
    cols = np.array(columns, dtype=str)
    yield "0 bytes", b"", "npz"
    yield "a single .npy", _npy(values), "npz"
    yield "object arrays (pickle)", npz_bytes(
        times=times, values=np.array([object()] * len(times), dtype=object), columns=cols
    ), "object arrays"
    yield "no values", npz_bytes(times=times, columns=cols), "values"
    yield "no times", npz_bytes(values=values, columns=cols), "times"
    yield "string values", npz_bytes(
        times=times, values=np.full(values.shape, "x"), columns=cols
    ), "numeric"
    yield "NaN", npz_bytes(times=times, values=_with(values, np.nan), columns=cols), "nan"
    yield "inf", npz_bytes(times=times, values=_with(values, np.inf), columns=cols), "infinite"
    yield "1e300", npz_bytes(times=times, values=_with(values, 1e300), columns=cols), "magnitude"
    yield "3-D values", npz_bytes(times=times, values=values[:, :, None], columns=cols), "2-d"
    yield "rows != times", npz_bytes(times=times[:-1], values=values, columns=cols), "rows"
    yield "one sample", npz_bytes(times=times[:1], values=values[:1], columns=cols), "2 samples"
    yield "empty", npz_bytes(times=times[:0], values=values[:0], columns=cols), "2 samples"
    yield "columns short", npz_bytes(times=times, values=values, columns=cols[:-1]), "column"
    yield "times backwards", npz_bytes(times=times[::-1], values=values, columns=cols), "increasing"
    for i, part in enumerate(truncations(npz_bytes(times=times, values=values, columns=cols))):
        yield f"truncated #{i}", part, "npz"


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _with(values: np.ndarray, bad: float) -> np.ndarray:
    out = np.array(values, dtype=float)
    out[len(out) // 2, 0] = bad
    return out


# ------------------------------------------------------------------------------ lab records


def record_cases(valid: str) -> Iterator[Case]:
    """Malformed lab records (13 whitespace-separated columns) derived from ``valid``."""
    lines = valid.strip().splitlines()
    yield "0 bytes", "", "empty"
    yield "one line", lines[0] + "\n", "2 samples"
    yield "12 columns", "\n".join(line.rsplit(None, 1)[0] for line in lines), "13 columns"
    yield "14 columns", "\n".join(line + " 1.0" for line in lines), "13 columns"
    yield "a word", "\n".join([lines[0], lines[1].replace(lines[1].split()[3], "abc"),
                               *lines[2:]]), "lab record"  # fmt: skip
    yield "ragged", "\n".join([lines[0], lines[1] + " 2", *lines[2:]]), "lab record"
    for token, expected in (("nan", "nan"), ("inf", "infinite"), ("1e300", "magnitude")):
        cells = lines[1].split()
        cells[11] = token
        yield f"a value {token}", "\n".join([lines[0], " ".join(cells), *lines[2:]]), expected
    yield "times backwards", "\n".join(reversed(lines)), "increasing"
    yield "binary", "\x00\x01\x02garbage\n" * 3, "lab record"


# ------------------------------------------------------------------------------ archives


def workspace_zip_cases(
    valid: dict[str, bytes], make_csv: Callable[[int], bytes]
) -> Iterator[Case]:
    """Malformed workspace archives from ``valid`` (member name -> bytes of a valid one)."""
    index_name = next(n for n in valid if n.endswith("studio.json"))
    index = json.loads(valid[index_name])
    demo_name = next(n for n in valid if n.endswith(".csv"))
    whole = zip_of(valid)
    yield "0 bytes", b"", "empty"
    for i, part in enumerate(truncations(whole, 4)):
        yield f"truncated #{i}", part, "zip"
    for i, part in enumerate(random_bytes(seed=2, n=4)):
        yield f"random bytes #{i}", part, "zip"
    without_index = {k: v for k, v in valid.items() if k != index_name}
    yield "no studio.json", zip_of(without_index), "studio.json"
    yield "zip slip ../", zip_of({**valid, "../evil.csv": b"t,x\n0,1\n1,2\n"}), ".."
    yield "absolute path", zip_of({**valid, "/etc/evil": b"x"}), "absolute"
    yield "symbolic link", zip_of({**valid, "demos/link": b"/etc/passwd"},
                                  symlink="demos/link"), "link"  # fmt: skip
    yield "duplicated member", zip_with_duplicate(demo_name, valid[demo_name], make_csv(7),
                                                  valid), "twice"  # fmt: skip
    yield "unknown member", zip_of({**valid, "notes.txt": b"hello"}), "unexpected"
    yield "unicode demo name", zip_of({**valid, demo_name.rsplit("/", 1)[0] + "/démo é.csv":
                                      make_csv(3)}), "name"  # fmt: skip
    yield "demo of an unlisted primitive", zip_of({**valid, "demos/ghost/g.csv": make_csv(3)}), (
        "not listed"
    )
    yield "0-byte demo", zip_of({**valid, demo_name: b""}), "empty"
    yield "NaN in a demo", zip_of({**valid, demo_name: _csv_with(valid[demo_name], "nan")}), "nan"
    yield "1e300 in a demo", zip_of({**valid, demo_name: _csv_with(valid[demo_name], "1e300")}), (
        "magnitude"
    )
    yield "a demo without a column", zip_of({**valid, demo_name: _drop_last_column(
        valid[demo_name])}), "column"  # fmt: skip
    yield "studio.json not JSON", zip_of({**valid, index_name: b"{not json"}), "json"
    yield "studio.json a list", zip_of({**valid, index_name: b"[]"}), "studio workspace"
    yield "studio.json unknown setting", zip_of({**valid, index_name: _json(
        {**index, "settings": {"warp": 9}})}), "unknown setting"  # fmt: skip
    yield "studio.json basis 0", zip_of({**valid, index_name: _json(
        {**index, "settings": {"n_basis": 0}})}), "settings"  # fmt: skip
    yield "studio.json duplicated primitive", zip_of({**valid, index_name: _json(
        {**index, "primitives": index["primitives"] * 2})}), "twice"  # fmt: skip
    yield "studio.json primitive ../x", zip_of({**valid, index_name: _json(
        {**index, "primitives": [{"name": "../x", "color": [1, 2, 3]}]})}), "name"  # fmt: skip
    yield "studio.json colour 300", zip_of({**valid, index_name: _json(
        {**index, "primitives": [{**index["primitives"][0], "color": [300, 0, 0]}]})}), "colour"
    yield "not UTF-8 studio.json", zip_of({**valid, index_name: b"\xff\xfe" + valid[index_name]}), (
        "utf-8"
    )
    score = {"primitive": "a", "demo": "d", "score": -0.3, "percentile": 1.5, "coverage": 1.0}
    yield "studio.json typicality 150th pct", zip_of({**valid, index_name: _json(
        {**index, "checks": {"typicality": {"given": [score]}}})}), "percentile"  # fmt: skip
    yield "studio.json typicality not a list", zip_of({**valid, index_name: _json(
        {**index, "checks": {"typicality": {"pending": "a/d"}}})}), "pending"  # fmt: skip


def dataset_zip_cases(make_csv: Callable[[int], bytes], record: bytes) -> Iterator[Case]:
    """Malformed dataset uploads (a zip of a CSV folder or of lab records)."""
    good = {f"{p}/d{i}.csv": make_csv(10 * k + i) for k, p in enumerate("ab") for i in range(3)}
    yield "0 bytes", b"", "empty"
    yield "random bytes", next(random_bytes(seed=3, n=1)), "zip"
    yield "truncated", zip_of(good)[: len(zip_of(good)) // 2], "zip"
    yield "an empty zip", zip_of({}), "no .csv or .txt"
    yield "only folders", zip_of({"a/": b"", "b/": b""}), "no .csv or .txt"
    yield "non-numeric files", zip_of({"a/x.csv": b"hello,world\nfoo,bar\n",
                                      "a/y.csv": b"t,x\nzz,1\n2,3\n"}), ""  # fmt: skip
    yield "a class of one demonstration", zip_of({**good, "c/only.csv": make_csv(99)}), "c"
    yield "zip slip ../", zip_of({**good, "../../evil.csv": make_csv(5)}), ".."
    yield "absolute path", zip_of({**good, "/tmp/evil.csv": make_csv(5)}), "absolute"
    yield "symbolic link", zip_of({**good, "a/link.csv": b"/etc/passwd"}, symlink="a/link.csv"), (
        "link"
    )
    yield "names equal but for case", zip_of({**good, "a/D0.csv": make_csv(4)}), "twice"
    yield "a 0-byte demo", zip_of({**good, "a/d0.csv": b""}), "empty"
    yield "NaN in a demo", zip_of({**good, "a/d0.csv": _csv_with(good["a/d0.csv"], "nan")}), "nan"
    yield "1e300 in a demo", zip_of({**good, "a/d1.csv": _csv_with(good["a/d1.csv"], "1e300")}), (
        "magnitude"
    )
    yield "records of 12 columns", zip_of({f"k/r{i}.txt": _record_drop_column(record)
                                          for i in range(3)}), "13 columns"  # fmt: skip


def _csv_with(content: bytes, token: str) -> bytes:
    lines = content.decode().strip().splitlines()
    cells = lines[2].split(",")
    cells[-1] = token
    lines[2] = ",".join(cells)
    return ("\n".join(lines) + "\n").encode()


def _drop_last_column(content: bytes) -> bytes:
    lines = content.decode().strip().splitlines()
    return ("\n".join(line.rsplit(",", 1)[0] for line in lines) + "\n").encode()


def _record_drop_column(content: bytes) -> bytes:
    lines = content.decode().strip().splitlines()
    return ("\n".join(line.rsplit(None, 1)[0] for line in lines) + "\n").encode()


# ------------------------------------------------------------------------------ rig recordings


def rig_cases(recordings: dict[str, tuple[dict[str, bytes], str, str]]) -> Iterator[Case]:
    """Malformed rig recordings: each format's session (``{format: ({path: bytes}, the file
    to spoil, the mapping)}``, a dataset folder's files) with that file truncated at six places
    or replaced by random bytes. The refusal must name the file."""
    for format, (files, target, mapping) in recordings.items():
        name = target.rpartition("/")[2].lower()
        for i, part in enumerate(truncations(files[target])):
            yield f"{format}: truncated #{i}", (format, {**files, target: part}, mapping), name
        for i, part in enumerate(random_bytes(seed=5, n=3)):
            yield f"{format}: random bytes #{i}", (format, {**files, target: part}, mapping), name


# ------------------------------------------------------------------------------ videos


def video_cases(valid: bytes) -> Iterator[Case]:
    yield "0 bytes", b"", ""
    for i, part in enumerate(truncations(valid, 3)):
        yield f"truncated #{i}", part[: max(64, len(part) // 50)], ""
    for i, part in enumerate(random_bytes(seed=4, n=3)):
        yield f"random bytes #{i}", part, ""
    yield "a text file", b"this is not a video\n" * 100, ""
    yield "a zip", zip_of({"a.txt": b"x"}), ""


# ------------------------------------------------------------------------------ observations


def observation_cases(n_dims: int) -> Iterator[Case]:
    """(times, values, modalities) triples the engine must refuse."""
    t = np.linspace(0.0, 0.5, 11)
    v = np.zeros((11, n_dims))
    yield "empty", (t[:0], v[:0], ("hand",)), "empty"
    yield "NaN value", (t, _with(v, np.nan), ("hand",)), "nan"
    yield "inf value", (t, _with(v, np.inf), ("hand",)), "infinite"
    yield "NaN time", (np.where(np.arange(11) == 3, np.nan, t), v, ("hand",)), "nan"
    yield "1e300 value", (t, _with(v, 1e300), ("hand",)), "magnitude"
    yield "times repeat", (np.zeros(11), v, ("hand",)), "increasing"
    yield "values 1-D", (t, v[:, 0], ("hand",)), "shape"
    yield "rows != times", (t, v[:-1], ("hand",)), "shape"
    yield "no modality", (t, v, ()), "modality"
    yield "unknown modality", (t, v, ("tail",)), "unknown modality"
    yield "too many columns", (t, np.zeros((11, n_dims + 2)), ("hand",)), "column"


# ------------------------------------------------------------------------------ live sessions


def live_input_cases() -> Iterator[Case]:
    """``--in`` specs a live session over a hand (x, y, z in m) model must refuse."""
    yield "no '='", "hand", "name=stream:field"
    yield "no name", "=S:0,1,2", "name=stream:field"
    yield "bad name", "1hand=S:0,1,2", "invalid modality name"
    yield "no stream", "hand=0,1,2", "names its stream"
    yield "no field", "hand=S:", "names no field"
    yield "unbalanced braces", "hand=S:p.{x,y", "unbalanced braces"
    yield "a field twice", "hand=S:0,0,1", "names a field twice"
    yield "'@' without unit", "hand=S:0,1,2@", "followed by a unit"
    yield "unknown selector", "hand=kind=Mocap:0,1,2", "unknown stream selector 'kind'"
    yield "empty selector", "hand=type=:0,1,2", "no stream named"
    yield "unknown modality", "tail=S:0,1,2", "unknown modality 'tail'"
    yield "too few channels", "hand=S:0,1", "maps 2 channel(s)"
    yield "too many channels", "hand=S:0,1,2,3", "maps 4 channel(s)"
    yield "an angle for a position", "hand=S:0,1,2@deg", "is in 'deg'"


def journal_cases(valid: bytes) -> Iterator[Case]:
    """Journal files :func:`promp.live.journal.read_journal` must refuse (a journal is what a
    killed recording leaves: torn at any byte, a last line cut short is left out)."""
    header, _, rest = valid.partition(b"\n")
    columns, _, rows = rest.partition(b"\n")
    first = rows.split(b"\n")[0]
    yield "empty", b"", "not a promp-live journal"
    yield "a CSV demonstration", rest, "not a promp-live journal"
    yield "broken header", header[:-5] + b"\n" + rest, "header is broken"
    yield "header without name", b'# promp-live journal 1 {"label": ""}\n' + rest, "header"
    yield "no rows", header + b"\n" + columns + b"\n", "no samples"
    yield "one row", header + b"\n" + columns + b"\n" + first + b"\n", "at least 2"
    yield "NaN value", valid.replace(first, first.rsplit(b",", 1)[0] + b",nan"), "nan"
    yield "time goes back", valid + first + b"\n", "increasing"
    yield "ragged row", valid + b"0.5,1\n", "values like the header"
    yield "text value", valid + b"9,a,b,c\n", "non-numeric"
    yield "not UTF-8", header + b"\n\xff\xfe" + rest, "cannot read"
    for k, cut in enumerate(truncations(header + b"\n" + columns + b"\n" + first + b"\n")):
        if cut.count(b"\n") < 3:
            yield f"torn before its rows #{k}", cut, ""


def live_sample_cases(n_channels: int) -> Iterator[Case]:
    """Chunks a live stream may send, ``(times, values)`` after a valid first chunk at
    t = 0 ... 0.09 s: a session must leave them out with a status, never raise."""
    t = 0.1 + np.arange(10) * 0.01
    v = np.zeros((10, n_channels))
    yield "NaN value", (t, _with(v, np.nan)), "bad values"
    yield "inf value", (t, _with(v, np.inf)), "bad values"
    yield "1e300 value", (t, _with(v, 1e300)), "bad values"
    yield "NaN time", (np.where(np.arange(10) == 3, np.nan, t), v), "bad values"
    yield "fewer channels", (t, v[:, :-1]), "wrong channels"
    yield "more channels", (t, np.zeros((10, n_channels + 2))), "wrong channels"
    yield "1-D values", (t, v[:, 0]), "wrong channels"
    yield "rows != times", (t, v[:-1]), "wrong channels"
    yield "times repeat", (np.zeros(10) + 0.05, v), ""
    yield "time far back", (t - 100.0, v), "clock jumped"
    yield "time far ahead", (t + 1e6, v), "clock jumped"
