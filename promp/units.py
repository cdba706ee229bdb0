"""Numbers with their units, written once for the studio and the command lines.

The engine keeps metres, radians and seconds; a person reads centimetres or millimetres,
degrees and seconds. Every message that gives a size or a time (the checks' findings, the
import's preview, the studio's readouts, the evaluation's figures) writes it with these
functions, so ``python -m promp.evaluate`` and the browser say the same "2.07 mm", "24.4 cm",
"12°", "0.4 s".

* :func:`display_unit`: the unit a value is shown in and the factor from the engine's unit
  (metres as cm, angles in radians as degrees, anything else as recorded);
* :func:`shown`: a value with a fixed number of decimals in that unit (charts, readouts);
* :func:`amount`: a size in words, three significant digits, a length below 1 cm in mm
  (findings, where sizes span orders of magnitude);
* :func:`seconds`: a time or a duration, three significant digits.

A value whose data has no unit is written as it is: nothing is invented (the mapping's
``@m``, ``@mm``, ``@deg`` give one).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

__all__ = [
    "amount",
    "display_unit",
    "DISPLAY_UNITS",
    "MISSING",
    "seconds",
    "shown",
    "unitless_note",
    "with_unit",
]

# (engine unit, kind) -> (shown unit, factor from the engine's unit).
DISPLAY_UNITS = {("m", "linear"): ("cm", 100.0), ("rad", "angle"): ("°", 180.0 / math.pi)}
MISSING = "—"  # a value that is not a finite number


def display_unit(unit: str, kind: str = "linear") -> tuple[str, float]:
    """(shown unit, factor from the engine's unit) of values in ``unit`` of ``kind``."""
    return DISPLAY_UNITS.get((unit, kind), (unit, 1.0))


def with_unit(number: str, unit: str) -> str:
    """``number`` followed by ``unit``: ``12°`` (no space before a degree sign), ``1.2 cm``,
    ``0.5`` (no unit)."""
    if not unit:
        return number
    return number + (unit if unit == "°" else f" {unit}")


def shown(
    value: float, unit: str, kind: str = "linear", digits: int = 1, signed: bool = False
) -> str:
    """``value`` (in ``unit``) in its shown unit with ``digits`` decimals, e.g. ``1.2 cm`` or
    ``+12°``; ``—`` when it is not finite."""
    if not math.isfinite(value):
        return MISSING
    shown_unit, scale = display_unit(unit, kind)
    return with_unit(f"{value * scale:{'+' if signed else ''}.{digits}f}", shown_unit)


def _significant(value: float) -> str:
    return f"{value:.3g}"


def amount(value: float, unit: str) -> str:
    """A size in words, three significant digits: metres as cm (mm below 1 cm), radians as
    degrees, seconds as seconds, any other unit as recorded; ``—`` when not finite.

    Examples
    --------
    >>> amount(0.00207, "m"), amount(0.244, "m"), amount(math.pi / 4, "rad")
    ('2.07 mm', '24.4 cm', '45°')
    """
    if not math.isfinite(value):
        return MISSING
    if unit == "m":
        if abs(value) < 0.01:
            return with_unit(_significant(1000.0 * value), "mm")
        return with_unit(_significant(100.0 * value), "cm")
    if unit == "rad":
        return with_unit(_significant(math.degrees(value)), "°")
    return with_unit(_significant(value), unit)


def seconds(value: float) -> str:
    """A time or a duration in seconds, three significant digits: ``0.4 s``, ``13.7 s``,
    ``135 s``."""
    return amount(value, "s")


def unitless_note(modalities: Iterable) -> str:
    """What to say of the modalities (objects with ``name`` and ``unit``) whose data has no
    unit, once, beside the sizes written without one; '' when every modality has one."""
    names = [m.name for m in modalities if not m.unit]
    if not names:
        return ""
    one = len(names) == 1
    return (
        f"{', '.join(names)} {'has' if one else 'have'} no unit: {'its' if one else 'their'} "
        "sizes are numbers as recorded (a recording's mapping gives one: @m, @mm, @deg; a "
        "column named x, y, z is in metres, roll, pitch, yaw in radians)"
    )
