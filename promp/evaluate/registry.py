"""The methods the evaluation can compare, by the name ``--method`` takes.

=============  ==========================================================================
``ours``       this project's multi-modal ProMP engine (:class:`promp.evaluate.methods.ProMPEngine`)
``seed``       the authors' 2017 Matlab toolbox, reproduced (:mod:`promp.evaluate.seed`)
``dtw``        open-end DTW 1-NN, relative to the start (:mod:`promp.evaluate.baselines`)
``prefix-nn``  prefix 1-NN with a phase search, relative to the start (same module)
=============  ==========================================================================

Several run in one sweep on the same folds (:func:`promp.evaluate.sweep.run_sweep`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

from promp.data import Layout
from promp.evaluate.baselines import SCALINGS, DTWBaseline, PrefixBaseline
from promp.evaluate.methods import ProMPEngine
from promp.evaluate.seed import ToolboxBaseline
from promp.model import Settings

__all__ = ["method_factories", "METHOD_TITLES", "METHODS", "RECOGNITION_ONLY"]

METHODS = ("ours", "seed", "dtw", "prefix-nn")
# How tables name them where a reader needs more than the name.
METHOD_TITLES = {
    "ours": "ours",
    "seed": "toolbox (2017)",
    "dtw": "DTW 1-NN",
    "prefix-nn": "prefix 1-NN",
}
# The methods that predict no trajectory, speed or duration (their errors are "n/a").
RECOGNITION_ONLY = ("dtw", "prefix-nn")


def method_factories(
    names: Sequence[str],
    layout: Layout,
    settings: Settings | None = None,
    scaling: str = "modality",
) -> dict[str, Callable[[], object]]:
    """A factory of a fresh, unfitted engine for each of ``names``, in that order (what
    :func:`promp.evaluate.sweep.run_sweep` takes).

    Parameters
    ----------
    names : sequence of str
        Method names of :data:`METHODS`, each once.
    layout : Layout
    settings : Settings, optional
        The learning settings of ``ours`` (default: the automatic ones).
    scaling : {"modality", "column", "none"}
        How the baselines scale the columns (:mod:`promp.evaluate.baselines`).

    Raises
    ------
    ValueError
        No name, an unknown or repeated one, or an unknown scaling.
    """
    names = list(names)
    if not names:
        raise ValueError(f"name at least one method of {', '.join(METHODS)}")
    unknown = [n for n in names if n not in METHODS]
    if unknown:
        raise ValueError(f"unknown method {unknown[0]!r}; the methods are {', '.join(METHODS)}")
    if len(set(names)) != len(names):
        raise ValueError(f"each method once, got {names}")
    if scaling not in SCALINGS:
        raise ValueError(f"the baselines' scaling must be one of {SCALINGS}, got {scaling!r}")
    makers = {
        "ours": functools.partial(ProMPEngine, layout, settings or Settings()),
        "seed": functools.partial(ToolboxBaseline, layout),
        "dtw": functools.partial(DTWBaseline, layout, scaling),
        "prefix-nn": functools.partial(PrefixBaseline, layout, scaling),
    }
    return {name: makers[name] for name in names}
