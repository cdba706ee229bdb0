"""The Live source's mapping: which stream and channels each of the workspace's modalities
comes from, in the rig formats' syntax (``hand=MocapHand:0,1,2@mm``, one modality a line), as
the Infer tab shows it: guessed from the streams found (:func:`guess_mapping`), edited by the
user, checked before a session starts (:func:`parse_mapping`). Pure: no LSL, no viser.

The guess, per modality of the workspace, prefers a stream whose channel labels name its
columns (``hand_x``, ``hand.x``, or ``x`` in a stream named or typed after the modality), then
a stream named or typed after it with enough channels (its first ones); a single stream with
exactly the layout's channels is read in the layout's order. No unit is guessed: the stream's
own channel units are converted when it states them (``@UNIT`` overrides them).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from promp.data import Layout, Modality
from promp.live.session import check_inputs
from promp.live.source import LiveInput, channels_of
from promp.live.transport import StreamDescription
from promp.model import ProMPModel

__all__ = [
    "guess_mapping", "MappingCheck", "parse_mapping", "safe_out_name", "selector_text",
    "stream_table",
]  # fmt: skip

EXAMPLE = "hand=MocapHand:0,1,2@mm"


def _label_forms(modality: str, column: str) -> tuple[str, ...]:
    m, c = modality.lower(), column.lower()
    return (f"{m}_{c}", f"{m}.{c}", f"{m}{c}", f"{m}:{c}", f"{m}-{c}")


def _mentions(stream: StreamDescription, modality: str) -> bool:
    m = modality.lower()
    return m in stream.name.lower() or m in stream.type.lower()


def _by_labels(modality: Modality, stream: StreamDescription) -> tuple[int, list[str]] | None:
    """(score, labels) when ``stream``'s labels name every column of ``modality``."""
    labels = [label.lower() for label in stream.labels]
    if not all(labels) or len(set(labels)) != len(labels):
        return None
    chosen, score = [], 3
    for column in modality.columns:
        prefixed = next((f for f in _label_forms(modality.name, column) if f in labels), None)
        if prefixed is None and column.lower() in labels and _mentions(stream, modality.name):
            prefixed, score = column.lower(), 2
        if prefixed is None:
            return None
        chosen.append(stream.labels[labels.index(prefixed)])
    return score, chosen


def selector_text(stream: StreamDescription, found: Sequence[StreamDescription]) -> str:
    """How a mapping names ``stream``: its name, unless another stream found has it too (then
    its source id, when that is unique)."""
    if sum(s.name == stream.name for s in found) == 1 or not stream.source_id:
        return stream.name
    if sum(s.source_id == stream.source_id for s in found) == 1:
        return f"source_id={stream.source_id}"
    return stream.name


def _guess_one(modality: Modality, streams: Sequence[StreamDescription],
               found: Sequence[StreamDescription]) -> str | None:  # fmt: skip
    best: tuple[float, str] | None = None
    width = len(modality.columns)
    for stream in streams:
        labelled = _by_labels(modality, stream)
        if labelled is not None:
            score, fields = labelled
        elif _mentions(stream, modality.name) and stream.n_channels >= width:
            score, fields = 1, [str(i) for i in range(width)]
        else:
            continue
        if best is None or score > best[0]:
            best = (score, f"{modality.name}={selector_text(stream, found)}:{','.join(fields)}")
    return None if best is None else best[1]


def guess_mapping(layout: Layout, found: Sequence[StreamDescription]) -> str:
    """A mapping of ``layout``'s modalities to the streams ``found``, one modality a line; a
    modality without a likely stream is a commented line to complete (see the module
    docstring)."""
    streams = [s for s in found if not s.is_markers and s.n_channels > 0]
    lines = {m.name: _guess_one(m, streams, found) for m in layout.modalities}
    if not any(lines.values()) and len(streams) == 1 and \
            streams[0].n_channels == len(layout.columns):  # fmt: skip
        stream, start = streams[0], 0
        for m in layout.modalities:
            fields = ",".join(str(i) for i in range(start, start + len(m.columns)))
            lines[m.name] = f"{m.name}={selector_text(stream, found)}:{fields}"
            start += len(m.columns)
    out = []
    for m in layout.modalities:
        indices = ",".join(str(i) for i in range(len(m.columns)))
        out.append(lines[m.name] or f"# {m.name}=STREAM:{indices}  (no stream found for it)")
    return "\n".join(out)


@dataclass(frozen=True)
class MappingCheck:
    """A mapping read and checked against a model and the streams found.

    Attributes
    ----------
    inputs : tuple of LiveInput
        One per mapped modality, in the text's order.
    waiting : tuple of str
        The streams it names that are not found yet (a session waits for them).
    """

    inputs: tuple[LiveInput, ...]
    waiting: tuple[str, ...]

    @property
    def modalities(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.inputs)

    def specs(self) -> list[str]:
        return [i.modality.spec() for i in self.inputs]


def _lines(text: str) -> list[str]:
    parts = (p.split("#", 1)[0].strip() for line in str(text).splitlines()
             for p in line.split(";"))  # fmt: skip
    return [p for p in parts if p]


def parse_mapping(
    text: str, model: ProMPModel, found: Sequence[StreamDescription] = ()
) -> MappingCheck:
    """The inputs ``text`` maps, checked.

    Raises
    ------
    ValueError
        Nothing mapped, the syntax's errors (with the line), a modality mapped twice or that
        the model lacks, channels that are not as many as the modality's columns, a unit that
        does not convert to the modality's, or a found stream without the channels named
        (by label when its labels are known, else by index) or that is a marker stream.
    """
    lines = _lines(text)
    if not lines:
        raise ValueError(
            f"map at least one of the model's modalities {list(model.layout.names)}, one a "
            f"line: NAME=STREAM:CHANNEL,...[@UNIT], e.g. {EXAMPLE}"
        )
    inputs = []
    for line in lines:
        try:
            inputs.append(LiveInput.parse(line))
        except ValueError as exc:
            raise ValueError(f"{line!r}: {exc}") from None
    names = [i.name for i in inputs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"modality {twice[0]!r} is mapped twice: one line each")
    unknown = [n for n in names if n not in model.layout.names]
    if unknown:
        raise ValueError(
            f"the model has no modality {unknown[0]!r}; its modalities are "
            f"{list(model.layout.names)}"
        )
    check_inputs(model, inputs)
    waiting = []
    for live_input in inputs:
        matches = [s for s in found if live_input.selector.matches(s)]
        if not matches:
            waiting.append(live_input.stream)
        for stream in matches:
            named = [f for f in live_input.modality.fields if not f.isdigit()]
            if named and not any(stream.labels):
                continue  # its labels are not known yet: the session checks them
            try:
                channels_of(live_input, stream)
            except ValueError as exc:
                raise ValueError(f"{live_input.modality.spec()}: {exc}") from None
    return MappingCheck(tuple(inputs), tuple(dict.fromkeys(waiting)))


def _channel_list(stream: StreamDescription) -> str:
    labels = [label or str(i) for i, label in enumerate(stream.labels)]
    shown = ", ".join(labels[:12]) + (", ..." if len(labels) > 12 else "")
    return shown or "none"


def stream_table(found: Sequence[StreamDescription]) -> list[tuple[str, str, str, str, str]]:
    """One row per stream found: name, type, rate, channels (count, and their labels), host;
    sorted by name."""
    rows = []
    for s in sorted(found, key=lambda s: (s.name.lower(), s.source_id)):
        rate = "irregular" if s.rate <= 0 else f"{s.rate:g} Hz"
        if s.is_markers:
            channels = "markers"
        else:
            labels = [label for label in s.labels if label]
            channels = f"{s.n_channels}" + (f" ({_channel_list(s)})" if labels else "")
        rows.append((s.name, s.type, rate, channels, s.host))
    return rows


def safe_out_name(text: str) -> str:
    """The outputs' name as typed, checked: a word of letters, digits, '-', '_' or '.'."""
    text = str(text).strip()
    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,60}", text):
        raise ValueError(
            f"the output streams' name must be 1-60 letters, digits, '-', '_' or '.', got "
            f"{text!r} (the streams are NAME-probabilities, NAME-timing, ...)"
        )
    return text
