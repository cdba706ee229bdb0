"""Row-wise versions of three one-dimensional numerics, each equal bit for bit to the call it
replaces on every row: ``np.interp``, scipy's ``PchipInterpolator`` (built and evaluated) and
:func:`promp.duration.weighted_quantiles`.

Why: the duration temperature's choice (:func:`promp.duration.choose_temperature`) ran them
once per held-out trial, and per trial and temperature: about 20,000 small calls per fit, most of
its cost. Row-wise, each is a handful of array operations over every trial at once. Being the
same to the last bit (the same operations in the same order, element by element) keeps every
choice, report and table unchanged; ``tests/test_promp_rows.py`` checks it against the
one-row calls.
"""

from __future__ import annotations

import numpy as np

__all__ = ["interp_rows", "pchip_rows", "quantiles_rows"]


def _intervals(x: np.ndarray, xp: np.ndarray) -> np.ndarray:
    """Per row, the index ``j`` of the last ``xp[j] <= x`` (-1 below the first); ``xp`` rows
    ascending."""
    # counts of xp <= x per point: the same as searchsorted(side="right") row by row
    return (xp[:, None, :] <= x[:, :, None]).sum(axis=2) - 1


def interp_rows(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp(x[r], xp[r], fp[r])`` for every row ``r`` (``xp`` rows ascending, at least
    two points each; values outside take the end values)."""
    n = xp.shape[1]
    j = _intervals(x, xp)
    inner = np.clip(j, 0, n - 2)
    x0 = np.take_along_axis(xp, inner, axis=1)
    x1 = np.take_along_axis(xp, inner + 1, axis=1)
    y0 = np.take_along_axis(fp, inner, axis=1)
    y1 = np.take_along_axis(fp, inner + 1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        slope = (y1 - y0) / (x1 - x0)
        out = slope * (x - x0) + y0
        retry = np.isnan(out)
        if retry.any():  # as numpy does: from the other end, then the level value
            other = slope * (x - x1) + y1
            out = np.where(retry, other, out)
            out = np.where(np.isnan(out) & (y0 == y1), y0, out)
    out = np.where(x == x0, y0, out)
    out = np.where(j >= n - 1, fp[:, -1:], out)
    return np.where(j < 0, fp[:, :1], out)


def _edge(h0, h1, m0, m1):
    """scipy's one-sided three-point end slope of a PCHIP, element-wise."""
    d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    mask = np.sign(d) != np.sign(m0)
    mask2 = (np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0))
    d = np.where(mask, 0.0, d)
    return np.where(~mask & mask2, 3.0 * m0, d)


def _slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """scipy's PCHIP slopes at the knots, row-wise (rows of at least two knots)."""
    hk = x[:, 1:] - x[:, :-1]
    mk = (y[:, 1:] - y[:, :-1]) / hk
    if y.shape[1] == 2:
        return np.concatenate([mk, mk], axis=1)
    smk = np.sign(mk)
    condition = (smk[:, 1:] != smk[:, :-1]) | (mk[:, 1:] == 0) | (mk[:, :-1] == 0)
    w1 = 2 * hk[:, 1:] + hk[:, :-1]
    w2 = hk[:, 1:] + 2 * hk[:, :-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        whmean = (w1 / mk[:, :-1] + w2 / mk[:, 1:]) / (w1 + w2)
        inner = np.where(condition, 0.0, 1.0 / whmean)
    first = _edge(hk[:, 0], hk[:, 1], mk[:, 0], mk[:, 1])
    last = _edge(hk[:, -1], hk[:, -2], mk[:, -1], mk[:, -2])
    return np.concatenate([first[:, None], inner, last[:, None]], axis=1)


def pchip_rows(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``PchipInterpolator(x[r], y[r])(at[r])`` for every row ``r`` (knots ascending, at least
    two per row). Points outside a row's knots are extrapolated from its end pieces, as scipy
    does; callers mask them."""
    dk = _slopes(x, y)
    dx = np.diff(x, axis=1)
    slope = np.diff(y, axis=1) / dx
    t = (dk[:, :-1] + dk[:, 1:] - 2 * slope) / dx
    coefficients = (t / dx, (slope - dk[:, :-1]) / dx - t, dk[:, :-1], y[:, :-1])
    piece = np.clip(_intervals(at, x), 0, x.shape[1] - 2)
    c0, c1, c2, c3 = (np.take_along_axis(c, piece, axis=1) for c in coefficients)
    with np.errstate(over="ignore", invalid="ignore"):
        s = at - np.take_along_axis(x, piece, axis=1)
        s2 = s * s
        # scipy's evaluate_poly1, term by term in its order
        return ((0.0 + c3 + c2 * s) + c1 * s2) + c0 * (s2 * s)


def quantiles_rows(values: np.ndarray, masses: np.ndarray, qs: np.ndarray) -> np.ndarray:
    """``weighted_quantiles(values[r], masses[r], qs)`` for every row ``r`` (rows strictly
    ascending, at least two values each): (rows, len(qs))."""
    w = masses / masses.sum(axis=1, keepdims=True)
    edges = np.concatenate(
        [values[:, :1], 0.5 * (values[:, 1:] + values[:, :-1]), values[:, -1:]], axis=1
    )
    cdf = np.concatenate([np.zeros((w.shape[0], 1)), np.cumsum(w, axis=1)], axis=1)
    return interp_rows(np.broadcast_to(qs, (w.shape[0], len(qs))), cdf, edges)
