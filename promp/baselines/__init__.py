"""Standard early-classification baselines: nearest neighbours over movements relative to
their start, blind to the speed (the evaluation's ``--method dtw`` and ``--method prefix-nn``,
:mod:`promp.evaluate.baselines`).

* :class:`OpenEndDTW`, :func:`open_end_dtw`: open-end dynamic time warping, a growing
  observation against reference movements (:mod:`promp.baselines.dtw`);
* :func:`prefix_search`: the distance to the best prefix of each reference, over
  :data:`FRACTIONS` of it (:mod:`promp.baselines.prefix`);
* :func:`relative_to_start`, :func:`column_spread`: the relative form and the scale of its
  columns (:mod:`promp.baselines.relative`);
* :func:`nearest_primitive`: the nearest primitive and softmin probabilities
  (:mod:`promp.baselines.nearest`).
"""

from promp.baselines.dtw import OpenEndDTW, open_end_dtw
from promp.baselines.nearest import nearest_primitive
from promp.baselines.prefix import FRACTIONS, prefix_search
from promp.baselines.relative import column_spread, relative_to_start

__all__ = [
    "FRACTIONS",
    "OpenEndDTW",
    "column_spread",
    "nearest_primitive",
    "open_end_dtw",
    "prefix_search",
    "relative_to_start",
]
