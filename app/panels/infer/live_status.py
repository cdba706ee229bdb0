"""What the Infer tab's Live source says, as HTML (pure functions): the streams found, each
input's condition and the session's news, and the streams it publishes. User text (stream
names, details) is escaped."""

from __future__ import annotations

from collections.abc import Sequence

from app.live.lsl_mapping import stream_table
from app.ui.text import GREEN, GREY, ORANGE, RED, escape_html
from promp.live.session import LiveSnapshot
from promp.live.status import Condition, StreamStatus
from promp.live.transport import StreamDescription

__all__ = ["commitment_html", "CONDITION_COLORS", "outputs_html", "session_html",
           "streams_html"]

SMALL = "font-size:0.78em;line-height:1.45;padding-right:14px;box-sizing:border-box"
CONDITION_COLORS = {
    Condition.OK: GREEN, Condition.WAITING: GREY, Condition.BACK: GREEN,
    Condition.RESTARTED: GREEN, Condition.RATE_CHANGED: ORANGE, Condition.BAD_VALUES: ORANGE,
    Condition.CLOCK_JUMP: ORANGE, Condition.STALLED: RED, Condition.VANISHED: RED,
    Condition.WRONG_CHANNELS: RED,
}  # fmt: skip
EVENTS_SHOWN = 6


def streams_html(unavailable: str, found: Sequence[StreamDescription], watching: bool,
                 ours: Sequence[str] = ()) -> str:  # fmt: skip
    """The streams on the network (name, type, rate, channel count; their labels and host on
    hover; ``ours``, the studio's own outputs, greyed), or why LSL cannot be used here and
    what to do."""
    if unavailable:
        return (f'<div style="{SMALL};color:{RED}"><b>The live source cannot be used here.</b> '
                f"{escape_html(unavailable)}</div>")  # fmt: skip
    if not found:
        what = "Looking for LSL streams on the network..." if watching else ""
        return f'<div style="{SMALL};color:{GREY}">{what or "No stream found."}</div>'
    rows = []
    for name, kind, rate, channels, host in stream_table(found):
        count, _, labels = channels.partition(" (")
        title = escape_html(f"{name} on {host}" + (f": {labels.rstrip(')')}" if labels else ""))
        style = f"color:{GREY}" if name in ours else ""
        cells = "".join(f'<td style="padding:0 6px 0 0;word-break:break-all">{escape_html(v)}'
                        "</td>" for v in (name, kind, rate, count))  # fmt: skip
        rows.append(f'<tr title="{title}" style="{style}">{cells}</tr>')
    cells = "".join(rows)
    head = "".join(f'<th style="text-align:left;padding:0 6px 0 0">{h}</th>'
                   for h in ("stream", "type", "rate", "channels"))  # fmt: skip
    return (f'<div style="{SMALL}"><b>{len(found)} stream(s) on the network</b>'
            f'<table data-streams="{len(found)}" style="border-collapse:collapse;width:100%">'
            f"<tr>{head}</tr>{cells}</table></div>")  # fmt: skip


def status_line(status: StreamStatus, now: float) -> str:
    color = CONDITION_COLORS.get(status.condition, GREY)
    return (f'<div data-stream="{escape_html(status.stream)}" '
            f'data-condition="{escape_html(status.condition.value)}">'
            f'<span style="color:{color};font-weight:600">● {escape_html(status.stream)}: '
            f"{escape_html(status.condition.value)}</span> for {max(0.0, now - status.since):.1f} s"
            + (f" ({escape_html(status.detail)})" if status.detail else "") + "</div>")  # fmt: skip


def session_html(snap: LiveSnapshot, now: float, rate: float, refused: str = "",
                 start: str = "") -> str:  # fmt: skip
    """Each input's condition, the movement under way, the predictions a second and the
    latest events (newest first); ``now`` on the session's clock, ``start`` how movements
    start (in words)."""
    lines = [status_line(s, now) for s in snap.statuses]
    movement = snap.movement
    if movement is not None and len(movement):
        lines.append(f"<b>Movement {movement.number} under way</b>: {len(movement)} samples, "
                     f"{now - movement.start:.1f} s")  # fmt: skip
    else:
        last = f" (last: movement {snap.ended[-1].number})" if snap.ended else ""
        lines.append(f"Waiting for a movement to start{escape_html(start)}{last}")
    lines.append(f"Predictions: {snap.predictions} ({rate:.1f} a second)")
    committed = commitment_html(snap)
    if committed:
        lines.append(committed)
    events = list(snap.events)[-EVENTS_SHOWN:][::-1]
    if events:
        lines.append('<span style="color:#555">' + "<br>".join(
            f"{max(0.0, now - e.time):5.1f} s ago: {escape_html(e.text)}" for e in events
        ) + "</span>")  # fmt: skip
    if refused:
        lines.insert(0, f'<span style="color:{RED}">{escape_html(refused)}</span>')
    return f'<div style="{SMALL}">' + "<br>".join(lines) + "</div>"


def commitment_html(snap: LiveSnapshot) -> str:
    """``committed to 'top' at 0.42 s (35 %)``: the commitment of the latest prediction's
    movement, once made (empty before, and without the commit rule)."""
    p = snap.prediction
    c = None if p is None else p.committed
    if c is None:
        return ""
    return (f'<span data-committed="{c.index}"><b>Movement {c.movement}: committed to '
            f"{escape_html(c.primitive)}</b> at {c.time:.2f} s ({100.0 * c.phase:.0f} %), "
            f"p {c.probability:.2f}</span>")  # fmt: skip


def idle_html(refused: str) -> str:
    """Before Start (and after Stop)."""
    text = ("Map the workspace's modalities to the streams (one a line, "
            "NAME=STREAM:CHANNEL,...[@UNIT]), then Start.")  # fmt: skip
    if refused:
        text = f'<span style="color:{RED}">{escape_html(refused)}</span><br>' + text
    return f'<div style="{SMALL}">{text}</div>'


def outputs_html(names: Sequence[str]) -> str:
    """The streams the studio publishes (none: nothing)."""
    if not names:
        return ""
    listed = ", ".join(f"<b>{escape_html(n)}</b>" for n in names)
    return (f'<div style="{SMALL}">Publishing {listed} (layouts: docs/live.md, '
            "The output streams)</div>")  # fmt: skip
