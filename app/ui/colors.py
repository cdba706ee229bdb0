"""Colours of the GUI's charts: (r, g, b) triples in 0-255, checked, and as CSS strings."""

from __future__ import annotations

from collections.abc import Sequence

RGB = tuple[int, int, int]


def check_color(what: str, color: Sequence[int]) -> RGB:
    """``color`` as an (r, g, b) tuple of ints.

    Raises
    ------
    ValueError
        Not three integers in 0-255 (``what`` says whose colour).
    """
    rgb = tuple(int(c) for c in color)
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise ValueError(f"{what}: a colour is three integers in 0-255, got {color!r}")
    return rgb  # type: ignore[return-value]


def css(color: Sequence[int], alpha: float = 1.0) -> str:
    """CSS colour string of an (r, g, b) triple in 0-255 with opacity ``alpha``."""
    r, g, b = (int(c) for c in color)
    return f"rgba({r}, {g}, {b}, {alpha:g})"
