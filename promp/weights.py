"""Per-demonstration weights by ridge regression on the phase basis (paper Eq. 2).

A demonstration is a continuous movement known at its samples; between two samples it is taken
to move in a straight line. Its weights minimise the squared error **integrated over the phase**
(plus the ridge), computed on ``n`` evenly spaced phases (``n`` its number of samples) where the
straight lines are read: for an evenly sampled demonstration those are its own samples, so
nothing changes; for one whose logger paused (a gap) or skipped samples, every part of the
phase is weighted by how long it lasts, not by how many samples it happened to get. Fitted at the
samples themselves, a 20 s logging pause leaves the basis functions of the gap unconstrained and
their weights reach metres for a hand that spans 20 cm (``tests/test_promp_quality.py``).
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from promp._recent import per_object, recent
from promp.basis import RBFBasis
from promp.data import Demonstration, Layout
from promp.scale import modality_scale
from promp.timing import demo_phases

__all__ = [
    "DemoStatistics", "RIDGE_GRID", "WeightFits", "demo_statistics", "fit_all_weights",
    "fit_weights", "uniform_phase_values"
]  # fmt: skip


def fit_weights(
    basis: RBFBasis, times: np.ndarray, values: np.ndarray, ridge: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ridge regression of one demonstration on the basis (paper Eq. 2).

    Parameters
    ----------
    times : array, shape (n_samples,)
    values : array, shape (n_samples, n_dims)

    Returns
    -------
    weights : array, shape (n_dims * n_basis,)
        Dimension-major.
    residuals : array, shape (n_samples, n_dims)
    """
    phi = basis(demo_phases(times))
    gram = phi.T @ phi
    lam = ridge * np.trace(gram) / gram.shape[0]
    chol = np.linalg.cholesky(gram + (lam + 1e-12) * np.eye(gram.shape[0]))
    w = np.linalg.solve(chol.T, np.linalg.solve(chol, phi.T @ values))  # (n_basis, n_dims)
    return w.T.reshape(-1), values - phi @ w


RIDGE_GRID = np.logspace(-10, 1, 23)


@dataclass
class WeightFits:
    """Per-demonstration weights (Eq. 2) of a set of demonstrations.

    Attributes
    ----------
    weights : list of arrays, shape (n_dims * n_basis,)
    residuals : list of arrays, shape (n_samples_j, n_dims)
    dof : list of arrays, shape (n_dims,)
        Residual degrees of freedom, ``n_j - trace(hat matrix)``.
    ridge : array, shape (n_dims,)
        The relative ridge strength used for each dimension.
    scale : array, shape (n_dims,)
        The squared scale of each dimension's modality (:func:`promp.scale.modality_scale`),
        what every floor of the fit is relative to.
    sse, lagged : array, shape (n_dims,)
        The residuals' squares and their products with the previous sample of the same
        demonstration, summed over every demonstration.
    """

    weights: list[np.ndarray]
    residuals: list[np.ndarray]
    dof: list[np.ndarray]
    ridge: np.ndarray
    scale: np.ndarray
    sse: np.ndarray
    lagged: np.ndarray


def uniform_phase_values(demo: Demonstration, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """The layout's values of ``demo`` read on ``n`` evenly spaced phases, straight lines
    between samples: (phases (n,), values (n, n_dims)); its own samples when they are evenly
    spaced. Kept per demonstration and layout (both immutable): every fit of the automatic
    settings' search reads the same demonstrations."""
    def make() -> tuple[np.ndarray, np.ndarray]:
        values = layout.extract(demo)
        phases = np.linspace(0.0, 1.0, demo.n_samples)
        own = demo_phases(demo.times)
        if float(np.abs(own - phases).max()) > 1e-9:
            values = np.column_stack([np.interp(phases, own, v) for v in values.T])
            values.setflags(write=False)
        return phases, values

    return per_object(_UNIFORM, demo, layout, make)


_UNIFORM: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class DemoStatistics:
    """What the ridge fit of one demonstration needs under one basis, whatever the other
    demonstrations: the basis at its evenly spaced phases ``phi`` (n, M), the eigenvalues
    ``eig`` (M,) and eigenvectors ``vec`` (M, M) of ``Phi^T Phi``, and ``proj = vec^T Phi^T y``
    (M, D)."""

    phi: np.ndarray
    eig: np.ndarray
    vec: np.ndarray
    proj: np.ndarray


def demo_statistics(basis: RBFBasis, demo: Demonstration, layout: Layout) -> DemoStatistics:
    """:class:`DemoStatistics` of ``demo``, kept per demonstration, basis and layout (all
    immutable): the folds of a leave-one-out sweep share all but one demonstration, and the
    automatic settings fit the same demonstrations under the same candidate bases in every
    fold, so each is computed once. (Bounded by the bases tried: a few per demonstration.)"""
    def make() -> DemoStatistics:
        phases, values = uniform_phase_values(demo, layout)
        phi = basis(phases)
        eig, vec = np.linalg.eigh(phi.T @ phi)
        return DemoStatistics(phi, np.maximum(eig, 0.0), vec, vec.T @ (phi.T @ values))

    return per_object(_STATISTICS, demo, (basis, layout), make)


_STATISTICS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def fit_all_weights(
    basis: RBFBasis,
    demos: Sequence[Demonstration],
    layout: Layout,
    ridge: float | None,
) -> WeightFits:
    """Ridge weights of every demonstration (on evenly spaced phases, see the module docstring;
    the residuals are there too); the ridge per modality by pooled GCV if None. The last few
    fits are kept (the same demonstrations, basis and ridge give the same fit: the settings
    chosen from candidate fits are fitted again at once); treat the result as read-only.

    Generalised cross-validation (Golub, Heath & Wahba 1979), pooled over demonstrations:
    ``sum_j n_j RSS_j(lambda) / (n_j - df_j(lambda))^2`` summed over a modality's dimensions,
    minimised over a log grid of relative strengths. Computed through the eigendecomposition of
    each ``Phi_j^T Phi_j``, so every candidate costs O(M D) per demonstration.
    """
    return recent(
        _FITS, (basis, layout, ridge), demos, lambda: _fit_all_weights(basis, demos, layout, ridge)
    )


def _fit_all_weights(
    basis: RBFBasis, demos: Sequence[Demonstration], layout: Layout, ridge: float | None
) -> WeightFits:
    n_dims = layout.n_dims
    stack = _stack(demos, layout)
    stats = [demo_statistics(basis, demo, layout) for demo in demos]
    eig = np.stack([st.eig for st in stats])  # (N, M)
    vec = np.stack([st.vec for st in stats])  # (N, M, M)
    scale = eig.sum(axis=1) / eig.shape[1]  # mean diagonal of Phi^T Phi, (N,)
    proj = np.stack([st.proj for st in stats])  # (N, M, D)
    yy, n = stack.yy, stack.n

    rel = np.full(n_dims, ridge if ridge is not None else 0.0)
    if ridge is None:
        grid = RIDGE_GRID[:, None, None]
        shrink = 1.0 / (eig + (grid + 1e-12) * scale[:, None])  # (G, N, M)
        # RSS = |y|^2 - 2 sum proj^2 shrink + sum proj^2 shrink^2 eig, per (G, N, D)
        gain = shrink * (2.0 - shrink * eig)  # (G, N, M)
        rss = yy - np.einsum("gnm,nmd->gnd", gain, proj**2)
        df = (eig * shrink).sum(axis=2)  # (G, N)
        scores = n[:, None] * np.maximum(rss, 0.0) / np.maximum(n - df, 1e-3)[..., None] ** 2
        scores = scores.sum(axis=1)  # (G, D)
        for modality in layout.modalities:
            dims = layout.dims([modality.name])
            rel[dims] = RIDGE_GRID[int(np.argmin(scores[:, dims].sum(axis=1)))]
    shrink = 1.0 / (eig[:, :, None] + (rel[None, None, :] + 1e-12) * scale[:, None, None])
    w_all = vec @ (proj * shrink)  # (N, M, D)
    # every demonstration's residuals in one array (one dimension at a time: bounded memory)
    phi = np.concatenate([st.phi for st in stats])  # (rows, M)
    residuals = np.empty_like(stack.values)
    for d in range(n_dims):
        residuals[:, d] = stack.values[:, d] - (phi * w_all[stack.segment, :, d]).sum(axis=1)
    lagged = residuals[1:] * residuals[:-1]
    return WeightFits(
        weights=list(w_all.transpose(0, 2, 1).reshape(len(demos), -1)),
        residuals=np.split(residuals, stack.offsets[1:-1]),
        dof=list(n[:, None] - (eig[:, :, None] * shrink).sum(axis=1)),
        ridge=rel,
        scale=stack.scale,
        sse=(residuals**2).sum(axis=0),
        lagged=lagged[stack.within].sum(axis=0),
    )


@dataclass(frozen=True, eq=False)
class _Stack:
    """The layout's values of a list of demonstrations on their evenly spaced phases, end to
    end: ``values`` (rows, D), each row's demonstration ``segment`` (rows,), where each
    demonstration starts (``offsets``, N + 1), which consecutive rows belong to the same one
    (``within``, rows - 1), each one's samples ``n`` and squared sums ``yy`` (N, D), and the
    modalities' scales (:func:`promp.scale.modality_scale`)."""

    values: np.ndarray
    segment: np.ndarray
    offsets: np.ndarray
    within: np.ndarray
    n: np.ndarray
    yy: np.ndarray
    scale: np.ndarray


def _stack(demos: Sequence[Demonstration], layout: Layout) -> _Stack:
    """:class:`_Stack` of ``demos``, kept for the last few lists seen (the candidate bases of
    one choice of settings fit the same list)."""
    return recent(_STACKS, (layout,), demos, lambda: _make_stack(demos, layout))


def _make_stack(demos: Sequence[Demonstration], layout: Layout) -> _Stack:
    values = [uniform_phase_values(demo, layout)[1] for demo in demos]
    n = np.array([v.shape[0] for v in values])
    offsets = np.concatenate([[0], np.cumsum(n)])
    stacked = np.concatenate(values)
    within = np.ones(max(stacked.shape[0] - 1, 0), dtype=bool)
    within[offsets[1:-1] - 1] = False
    return _Stack(
        values=stacked,
        segment=np.repeat(np.arange(len(demos)), n),
        offsets=offsets,
        within=within,
        n=n.astype(float),
        yy=np.stack([(v**2).sum(axis=0) for v in values]),
        scale=modality_scale(values, layout),
    )


_STACKS: list = []
_FITS: list = []  # the last few fits (the settings chosen are fitted again at once)
