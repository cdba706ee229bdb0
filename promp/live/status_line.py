"""A session's state in one line of text (the headless command's status line)."""

from __future__ import annotations

from promp.live.session import LiveSnapshot

__all__ = ["status_line"]


def status_line(snap: LiveSnapshot, predictions_per_s: float) -> str:
    """``movement 3 (1.24 s, 310 rows): top 0.91 · phase 0.62 [0.55-0.70] · ends in 0.48 s
    [0.31-0.70] · 58 predictions/s · streams ok`` (or what is wrong with a stream or a
    sink)."""
    unhealthy = [s.message(snap.time) for s in snap.statuses if not s.healthy]
    unhealthy += [f"sink {s.name!r} " + (f"failing ({s.error})" if s.failing else "behind")
                  for s in snap.sinks if not s.healthy]  # fmt: skip
    streams = "streams ok" if not unhealthy else "; ".join(unhealthy)
    p = snap.prediction
    if snap.movement is None:
        what = "waiting for a movement"
    else:
        m = snap.movement
        span = float(m.times[-1] - m.times[0]) if len(m) else 0.0
        what = f"movement {m.number} ({span:.2f} s, {len(m)} rows)"
        if p is not None and p.movement == m.number:
            k = p.inference.index
            phase, left = p.phase, p.remaining
            what += (
                f": {p.primitive} {p.probabilities[k]:.2f} · phase {phase.value:.2f} "
                f"[{phase.low:.2f}-{phase.high:.2f}] · ends in {left.value:.2f} s "
                f"[{left.low:.2f}-{left.high:.2f}]"
            )
    return f"{what} · {predictions_per_s:.0f} predictions/s · {streams}"
