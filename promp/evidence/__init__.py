"""The evidence of an observation: what the first samples of a movement say under a model, as
one object (:class:`Evidence`) over the likelihood of Eq. 6 at candidate speeds and its
integral over each primitive's speed prior; the method's functions ask it their question.

* :mod:`~promp.evidence.evidence`: :class:`Evidence`, built from a model and an observation,
  extended by new samples; :mod:`~promp.evidence.inference`: the :class:`Inference` it gives;
* :mod:`~promp.evidence.pipeline`: :func:`infer`, :func:`recognise`, :func:`condition`,
  :func:`log_likelihoods`, each a question asked of a new evidence;
* :mod:`~promp.evidence.speed`: the speed prior and the quadrature over it (the Student-t,
  logsumexp);
* :mod:`~promp.evidence.sums`: the whitened sums of the samples at candidate speeds, kept
  while the observation grows;
* :mod:`~promp.evidence.woodbury` and :mod:`~promp.evidence.weight_space`: the likelihood from
  the sums in two exact forms (and the posterior of Eq. 8 from the first).
"""

from promp.evidence.evidence import Evidence
from promp.evidence.inference import Inference, Position
from promp.evidence.pipeline import condition, infer, log_likelihoods, recognise, relative_speed

__all__ = [
    "Evidence", "Inference", "Position", "condition", "infer", "log_likelihoods", "recognise",
    "relative_speed",
]  # fmt: skip
