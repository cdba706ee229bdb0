"""The Infer tab's text: the probability bars and the status lines of a scrub step, as HTML.

Pure functions of a :class:`app.live.inference.ScrubResult`; lengths and angles in the display
units of
:mod:`app.ui.display`, user text escaped by :mod:`app.ui.text`.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence

from app.live.inference import ScrubResult, error_modality
from app.ui.display import shown
from app.ui.text import escape_html

# Right padding: viser's panel scrollbar lies over the last pixels of a full-width element.
PAD = "padding-right:14px;box-sizing:border-box"
ALPHA_HELP = (
    "α, the time modulation: 100 / the number of samples of the whole movement (higher is "
    "faster). × typical: relative to the primitive's usual speed (1 = typical, > 1 faster)."
)
LEGEND_HTML = (
    f'<div style="font-size:0.72em;color:#555;margin-top:4px;{PAD}">'
    'Charts: bands ±2σ: <b style="color:#7d7d7d">prior</b> · <b>posterior</b> (recognised '
    "primitive's colour) · ● observed · ╌ truth</div>"
)


def seconds(value: float, digits: int = 2) -> str:
    return "—" if not math.isfinite(value) else f"{value:.{digits}f} s"


def probabilities_html(
    result: ScrubResult, color_of: Callable[[str], tuple[int, int, int]]
) -> str:
    """One bar per primitive (its probability, in its colour); the recognised one in bold.
    Each row carries ``data-primitive`` and ``data-p`` for tests and tools."""
    rows = []
    for k, (name, p) in enumerate(zip(result.names, result.probabilities, strict=True)):
        r, g, b = color_of(name)
        weight = "700" if k == result.recognition.index else "400"
        rows.append(
            f'<div data-primitive="{escape_html(name)}" data-p="{p:.6f}" '
            'style="display:flex;align-items:center;gap:6px;margin:3px 0">'
            f'<span style="width:92px;overflow:hidden;text-overflow:ellipsis;'
            f'white-space:nowrap;font-weight:{weight}">{escape_html(name)}</span>'
            '<span style="flex:1;height:11px;background:#e9ecef;border-radius:3px;'
            'overflow:hidden">'
            f'<span style="display:block;width:{100 * p:.1f}%;height:100%;'
            f'background:rgb({r},{g},{b})"></span></span>'
            '<span style="width:48px;text-align:right;font-variant-numeric:tabular-nums">'
            f"{100 * p:.1f} %</span></div>"
        )
    return f'<div style="font-size:0.8em;margin:2px 0 4px 0;{PAD}">' + "".join(rows) + "</div>"


def timing_text(scrub_ms: float, recent_ms: Sequence[float], fit_ms: float) -> str:
    """The server-side time of the latest scrub step (and of a held-out fit it needed)."""
    text = (
        f"step {scrub_ms:.1f} ms (server; median of the last {len(recent_ms)}: "
        f"{statistics.median(recent_ms):.1f} ms)"
    )
    if fit_ms > 0:
        text += f" · held-out fit {fit_ms:.0f} ms"
    return text


def failure_html(message: str, timing: str) -> str:
    return (
        f'<div style="font-size:0.8em;color:#a33;{PAD}">{escape_html(message)}</div>'
        f'<div style="font-size:0.72em;color:#777;{PAD}">{timing}</div>'
    )


def alpha_html(result: ScrubResult) -> str:
    """``α = 0.688 (0.97 × typical)``, explained on hover."""
    relative = result.relative_speed
    typical = f" ({relative:.2f} × typical)" if math.isfinite(relative) else ""
    return (
        f'<span title="{escape_html(ALPHA_HELP)}" style="text-decoration:underline dotted">'
        f"α = {result.alpha:.3f}{typical}</span>"
    )


def status_html(
    result: ScrubResult, truth_primitive: str | None, model_note: str, timing: str
) -> str:
    """What was recognised, how much was observed, with which model, the predicted and true
    durations and the errors (against ``truth_primitive``, the test demonstration's, if any)."""
    obs, truth = result.observation, result.truth
    if truth is not None:
        if truth_primitive is None:
            mark = ""
        elif truth_primitive == result.primitive:
            mark = ' <span style="color:#2b8a3e">✓</span>'
        else:
            mark = (
                f' <span style="color:#c92a2a">✗ (truth: {escape_html(truth_primitive)})</span>'
            )
        seen = f"{obs.n_observed} / {truth.n_samples} samples, {result.observed_until:.2f} s"
    else:
        mark = ""
        seen = f"{obs.n_observed} samples, {result.observed_until:.2f} s"
    measured = error_modality(result.layout)
    lines = [
        f"<b>Recognised: {escape_html(result.primitive)}</b>{mark} · {alpha_html(result)}",
        f"Observed: {seen} ({' + '.join(obs.modalities)})",
        f"Model: {escape_html(model_note)}",
        f"Duration: predicted {result.duration:.2f} s · true {seconds(result.true_duration)}",
        f"Errors: remainder {shown(result.position_error_m, measured)} · goal "
        f"{shown(result.goal_error_m, measured)} · duration "
        f"{seconds(result.duration_error_s)}",
    ]
    return (
        f'<div style="font-size:0.8em;line-height:1.55;{PAD}">' + "<br>".join(lines) + "</div>"
        f'<div style="font-size:0.72em;color:#777;{PAD}">{timing}</div>'
    )
