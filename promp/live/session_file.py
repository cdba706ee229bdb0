"""``python -m promp.live ... --session FILE.mcap`` and ``python -m promp.live --replay
FILE.mcap --model M``: a live session recorded, and replayed through the predictor bit for bit.

**What is recorded.** The pipeline is a pure step (:func:`promp.live.pipeline.step`): the same
model, inputs, options and start, stepped on the same :class:`promp.live.pipeline.Arrivals`,
give the same predictions, to the last bit. So a session file keeps what every step that did
anything ran on (its arrivals: the session clock's time, the streams a look opened with their
descriptions, every batch pulled with its samples' times on the session's clock, their values
and the clock correction added to the sender's stamps, a lost stream, the Record calls and the
runner's notes), and beside them every published prediction and every event. A step that
neither received nor gave anything is not kept: it changes nothing but the clock. Numbers are
kept as JSON, whose shortest round-trip decimal gives back every double exactly (NaN and the
infinities as the strings ``"nan"``, ``"inf"``, ``"-inf"``).

**Safe against a kill.** While the session runs, each step's records are appended to a
journal (``FOLDER/.sessions/NAME.journal``, :class:`promp.live.journal.AppendFile`, the
takes' journal: one write per step, acknowledged when it returns, fsync-ed every second) by a
sink on its own thread (:mod:`promp.live.sinks`: lossless, so a slow disk folds steps rather
than losing them, and never stalls the prediction). When the session ends, the journal becomes
the MCAP file ``FILE`` (written whole, never over a file) and goes. A journal that a kill left
is made into ``FOLDER/recovered/NAME.mcap`` by the next ``--session`` in that folder (a record
cut short by the kill, never acknowledged, left out).

**The MCAP file** (the ``mcap`` package's writer; JSON messages, for Foxglove's raw message
view and for :func:`read_session`): ``/arrivals`` (one message per step, at its time),
``/predictions`` (the numbers a robot reads: probabilities, phase, duration, time left with
their intervals, the remainder), ``/events``; metadata ``session``: the format, the model's
SHA-256 (of its JSON), the inputs' mappings, the options, the session's start.

**Replayed.** :func:`replay_session` builds the pipeline from the file's header and steps it
on the recorded arrivals, at their timing or as fast as it can, and compares every prediction
with the recorded one (:func:`prediction_record`: every number published). A model other than
the recorded one is refused: its predictions could not be the same.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from promp.live.journal import AppendFile
from promp.live.options import LiveOptions
from promp.live.pipeline import Arrivals, Call, build, step
from promp.live.predictor import LivePrediction
from promp.live.sinks import Output
from promp.live.source import Opened, Pulled
from promp.live.status import LiveEvent
from promp.live.transport import StreamDescription
from promp.model import ProMPModel
from promp.viewers.new_file import check_new, write_new

__all__ = [
    "decode_arrivals", "encode_arrivals", "FORMAT", "journal_for", "JOURNALS", "MAGIC",
    "check_recorded_with", "model_sha256", "TOPICS",
    "prediction_record", "read_session", "recover_sessions", "Replayed", "replay_session",
    "SessionRecord", "SessionSink", "write_session_file",
]  # fmt: skip

FORMAT = 1
MAGIC = "# promp-live session 1 "
JOURNALS = ".sessions"
TOPICS = {"a": "/arrivals", "p": "/predictions", "e": "/events"}


# ------------------------------------------------------------------------------- numbers


def _number(x: float) -> float | str:
    return x if math.isfinite(x) else str(x)


def _array(values) -> dict:
    array = np.asarray(values, dtype=float)
    return {"shape": list(array.shape), "data": [_number(x) for x in array.ravel().tolist()]}


def _unarray(record: dict) -> np.ndarray:
    return np.array([float(x) for x in record["data"]], dtype=float).reshape(record["shape"])


def model_sha256(model: ProMPModel) -> str:
    """The SHA-256 of ``model``'s JSON (:func:`promp.io.model_to_dict`, keys sorted)."""
    from promp.io import model_to_dict

    text = json.dumps(model_to_dict(model), sort_keys=True, allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# ------------------------------------------------------------------------------- records


def encode_arrivals(arrivals: Arrivals) -> dict:
    """``arrivals`` as JSON-ready values (exact: :func:`decode_arrivals` gives them back)."""
    pulled = {}
    for feed, p in arrivals.pulled.items():
        markers = isinstance(p.values, list)
        pulled[str(feed)] = {"times": _array(p.times), "lost": p.lost,
                             "offset": _number(float(p.offset)),
                             "values": list(p.values) if markers else _array(p.values)}  # fmt: skip
    opened = [{"feed": o.feed, "problem": o.problem,
               "stream": None if o.stream is None else dataclasses.asdict(o.stream)}
              for o in arrivals.opened]  # fmt: skip
    return {"now": _number(arrivals.now), "opened": opened, "pulled": pulled,
            "calls": [[c.kind, c.time, c.label] for c in arrivals.calls],
            "notes": [[n.time, n.text] for n in arrivals.notes]}  # fmt: skip


def decode_arrivals(record: dict) -> Arrivals:
    """The :class:`promp.live.pipeline.Arrivals` :func:`encode_arrivals` gave ``record`` of."""
    pulled = {}
    for feed, p in record["pulled"].items():
        values = p["values"] if isinstance(p["values"], list) else _unarray(p["values"])
        pulled[int(feed)] = Pulled(_unarray(p["times"]), values, bool(p["lost"]),
                                   float(p["offset"]))  # fmt: skip
    opened = []
    for o in record["opened"]:
        s = o["stream"]
        stream = None if s is None else StreamDescription(
            **{**s, "labels": tuple(s["labels"]), "units": tuple(s["units"])})  # fmt: skip
        opened.append(Opened(int(o["feed"]), stream, str(o["problem"])))
    return Arrivals(float(record["now"]), tuple(opened), MappingProxyType(pulled),
                    tuple(Call(k, float(t), str(label)) for k, t, label in record["calls"]),
                    tuple(LiveEvent(float(t), str(text)) for t, text in record["notes"]))


def _estimate(e) -> list:
    return [_number(e.value), _number(e.low), _number(e.high)]


def prediction_record(p: LivePrediction) -> dict:
    """Every number ``p`` publishes (its compute time aside), JSON-ready: what a replay must
    give again, bit for bit."""
    r = p.remainder
    remainder = None if r is None else {"modality": r.modality, "after": _array(r.after),
                                        "mean": _array(r.mean), "std": _array(r.std)}  # fmt: skip
    committed = None if p.committed is None else p.committed.primitive
    return {"seq": p.seq, "movement": p.movement, "start": _number(p.start),
            "last": _number(p.last), "n_observed": p.n_observed,
            "probabilities": _array(p.probabilities), "primitive": p.primitive,
            "phase": _estimate(p.phase), "duration": _estimate(p.duration),
            "remaining": _estimate(p.remaining), "remainder": remainder,
            "committed": committed}  # fmt: skip


def _options_record(options: LiveOptions) -> dict:
    record = dataclasses.asdict(options)
    rule = options.decide
    record["decide"] = None if rule is None else {"threshold": rule.threshold,
                                                   "window": rule.window}  # fmt: skip
    return record


def _options(record: dict) -> LiveOptions:
    from promp.decision import CommitRule

    rule = record.get("decide")
    return LiveOptions(**{**record, "decide": None if rule is None else CommitRule(**rule)})


# ------------------------------------------------------------------------------- recording


def journal_for(path: Path) -> Path:
    """The journal a session file ``path`` is kept in while its session runs."""
    path = Path(path)
    return path.parent / JOURNALS / f"{path.stem}.journal"


class SessionSink:
    """A live session's sink recording it (see the module docstring): the journal while it
    runs, the MCAP file ``path`` when it is closed.

    Parameters
    ----------
    path : Path or str
        A new ``.mcap`` file.
    model : ProMPModel
    inputs : sequence of str
        The inputs' mappings, as given to the session (``hand=MocapHand:0,1,2@mm``).
    options : LiveOptions
    start : float
        The session's start on its clock (:class:`promp.live.session.LiveSession`'s ``now``).

    Raises
    ------
    ValueError
        ``path`` exists, does not end in ``.mcap``, or its journal exists; the ``mcap``
        package is missing.
    """

    name = "session file"
    lossless = True

    def __init__(self, path: Path | str, model: ProMPModel, inputs: Sequence[str],
                 options: LiveOptions, start: float):  # fmt: skip
        _needs_mcap()
        self.path = check_new(path, ".mcap")
        self.journal = journal_for(self.path)
        if self.journal.exists():
            raise ValueError(f"{self.journal} exists: a session of that name is being recorded, "
                             "or was interrupted (the next --session recovers it)")  # fmt: skip
        header = {"format": FORMAT, "model_sha256": model_sha256(model),
                  "inputs": [str(i) for i in inputs], "options": _options_record(options),
                  "start": float(start)}  # fmt: skip
        self._file = AppendFile(self.journal, f"{MAGIC}{json.dumps(header)}\n")

    def view(self, output: Output) -> Output | None:
        return output if output.arrivals or output.predictions or output.events else None

    def take(self, output: Output) -> tuple:
        lines = [{"k": "a", **encode_arrivals(a)} for a in output.arrivals]
        lines += [{"k": "p", **prediction_record(p)} for p in output.predictions]
        lines += [{"k": "e", "time": _number(e.time), "text": e.text} for e in output.events]
        if lines:
            self._file.write("".join(json.dumps(line) + "\n" for line in lines))
        return ()

    def close(self) -> None:
        """Close the journal and make it the session file (the journal stays if that fails)."""
        self._file.close()
        write_session_file(self.journal, self.path)
        self.journal.unlink()


@dataclass(frozen=True, eq=False)
class SessionRecord:
    """A session file's content: its ``header`` (format, model_sha256, inputs, options,
    start) and its records in order (``kind`` "a", "p" or "e", and the JSON object)."""

    header: dict
    records: tuple[tuple[str, dict], ...]

    def of(self, kind: str) -> list[dict]:
        return [r for k, r in self.records if k == kind]


def _read_journal(path: Path) -> SessionRecord:
    text = Path(path).read_bytes().decode("utf-8", errors="replace")
    if not text.startswith(MAGIC):
        raise ValueError(f"{path}: not a promp-live session journal")
    first, _, rest = text.partition("\n")
    header = json.loads(first[len(MAGIC):])
    if not rest.endswith("\n"):
        rest = rest[: rest.rfind("\n") + 1]  # a record cut short by a kill: never acknowledged
    records = []
    for number, line in enumerate(rest.splitlines(), start=2):
        try:
            record = json.loads(line)
            records.append((record.pop("k"), record))
        except (json.JSONDecodeError, KeyError, AttributeError, TypeError) as exc:
            raise ValueError(f"{path}: line {number} is not a record ({exc})") from None
    return SessionRecord(header, tuple(records))


def _needs_mcap():
    try:
        from mcap.writer import Writer
    except ImportError:
        raise ValueError("session files need the optional extra: pip install "
                         "'icub-intention-studio[mcap]' (mcap)") from None  # fmt: skip
    return Writer


def _nanoseconds(seconds: float) -> int:
    return max(int(round(seconds * 1e9)), 0) if math.isfinite(seconds) else 0


def write_session_file(journal: Path, path: Path) -> Path:
    """The session journal ``journal`` as the new MCAP file ``path`` (module docstring)."""
    writer_class = _needs_mcap()
    session = _read_journal(journal)

    def write(target: Path) -> None:
        with open(target, "wb") as handle:
            writer = writer_class(handle)
            writer.start(profile="", library="promp-live")
            schema = writer.register_schema(name="promp.live.Record", encoding="jsonschema",
                                            data=b'{"type": "object"}')  # fmt: skip
            channels = {kind: writer.register_channel(topic=topic, message_encoding="json",
                                                      schema_id=schema)  # fmt: skip
                        for kind, topic in TOPICS.items()}
            writer.add_metadata("session", {"header": json.dumps(session.header)})
            for kind, record in session.records:
                at = record.get("now", record.get("last", record.get("time", 0.0)))
                ns = _nanoseconds(float(at))
                writer.add_message(channels[kind], log_time=ns, publish_time=ns,
                                   data=json.dumps(record).encode("utf-8"))  # fmt: skip
            writer.finish()

    return write_new(path, ".mcap", write)


def recover_sessions(folder: Path) -> list[tuple[Path, Path | str]]:
    """The session journals a kill left in ``folder/.sessions``, each made into
    ``folder/recovered/NAME.mcap`` (a free name) and removed: (journal, file), or (journal,
    why it could not be read) for one left as it is."""
    out: list[tuple[Path, Path | str]] = []
    found = Path(folder) / JOURNALS
    for journal in sorted(found.glob("*.journal")) if found.is_dir() else []:
        target = Path(folder) / "recovered" / f"{journal.stem}.mcap"
        k = 1
        while target.exists():
            k += 1
            target = target.with_name(f"{journal.stem}-{k}.mcap")
        try:
            write_session_file(journal, target)
        except (ValueError, OSError, UnicodeDecodeError) as exc:
            out.append((journal, f"{type(exc).__name__}: {exc}"))
            continue
        journal.unlink()
        out.append((journal, target))
    return out


def read_session(path: Path | str) -> SessionRecord:
    """A session file's header and records (the ``mcap`` package's reader).

    Raises
    ------
    ValueError
        Not a session file of this format.
    """
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    _needs_mcap()
    kinds = {topic: kind for kind, topic in TOPICS.items()}
    try:
        with open(path, "rb") as handle:
            reader = make_reader(handle)
            header = None
            for record in reader.iter_metadata():
                if record.name == "session":
                    header = json.loads(record.metadata["header"])
            records = [(kinds[channel.topic], json.loads(message.data))
                       for _, channel, message in reader.iter_messages(log_time_order=False)
                       if channel.topic in kinds]  # fmt: skip
    except (OSError, McapError, json.JSONDecodeError, KeyError) as exc:
        raise ValueError(f"{path}: not a readable session file ({type(exc).__name__}: "
                         f"{exc})") from None  # fmt: skip
    if header is None or header.get("format") != FORMAT:
        raise ValueError(f"{path}: not a promp-live session file (no 'session' metadata of "
                         f"format {FORMAT})")  # fmt: skip
    return SessionRecord(header, tuple(records))


# ------------------------------------------------------------------------------- replay


@dataclass(frozen=True, eq=False)
class Replayed:
    """What a replay gave: its ``steps``, its predictions, its outputs' events, the
    recorded predictions' records, and the first difference ('' when every prediction is
    the recorded one, bit for bit)."""

    steps: int
    predictions: tuple[LivePrediction, ...]
    events: tuple[LiveEvent, ...]
    recorded: tuple[dict, ...]
    difference: str

    @property
    def equal(self) -> bool:
        return not self.difference


def check_recorded_with(model: ProMPModel, header: dict, path: Path | str) -> None:
    """Refuse ``model`` unless the session file ``path`` (its ``header``) was recorded with
    it, and its inputs' mappings unless ``model`` observes them.

    Raises
    ------
    ValueError
        Another model (both SHA-256s named: its predictions could not be the same), or
        inputs the model has no modality for.
    """
    from promp.live.options import live_inputs

    ours, theirs = model_sha256(model), str(header.get("model_sha256", ""))
    if ours != theirs:
        raise ValueError(f"{path} was recorded with another model (SHA-256 {theirs[:12]}..., "
                         f"this one's is {ours[:12]}...): its predictions cannot be "
                         "reproduced with this one")  # fmt: skip
    live_inputs(model, header["inputs"])


def replay_session(model: ProMPModel, path: Path | str, paced: bool = False,
                   on_output: Callable[[Output], object] | None = None,
                   sleep: Callable[[float], object] = time.sleep) -> Replayed:  # fmt: skip
    """The session file ``path`` replayed through the pipeline of ``model`` (module
    docstring): at the recorded timing with ``paced``, else as fast as it goes; each step's
    :class:`promp.live.sinks.Output` handed to ``on_output`` (a viewer file's sink, the
    studio's view). ``sleep(seconds)`` waits between paced steps (the studio's replay waits on
    its Stop, and its ``on_output`` raises to end the replay there).

    Raises
    ------
    ValueError
        Not a session file, or ``model`` is not the model it was recorded with.
    """
    session = read_session(path)
    header = session.header
    check_recorded_with(model, header, path)
    # in one process: a helper's numbers are the same (promp.live.helper), and a replay
    # checks that too
    options = dataclasses.replace(_options(header["options"]), helper=False)
    state = build(model, header["inputs"], options, float(header["start"]))
    predictions, events = [], []
    arrivals = [decode_arrivals(r) for r in session.of("a")]
    began, first = time.monotonic(), arrivals[0].now if arrivals else 0.0
    for a in arrivals:
        if paced:
            sleep(max(0.0, (a.now - first) - (time.monotonic() - began)))
        state, stepped, boundaries, made = step(state, a)
        predictions += made
        events += stepped
        if on_output is not None:
            on_output(Output(a.now, stepped, boundaries, made, state.segmenter.movement, (a,)))
    recorded = tuple(session.of("p"))
    return Replayed(len(arrivals), tuple(predictions), tuple(events), recorded,
                    _difference([prediction_record(p) for p in predictions], recorded))


def _difference(replayed: list[dict], recorded: Sequence[dict]) -> str:
    for got, kept in zip(replayed, recorded, strict=False):
        if got != kept:
            fields = [k for k in kept if got.get(k) != kept[k]]
            return f"prediction {kept['seq']} differs in {', '.join(fields)}"
    if len(replayed) != len(recorded):
        return f"{len(replayed)} predictions replayed, {len(recorded)} recorded"
    return ""
