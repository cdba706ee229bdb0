"""The class posterior of every primitive's quadrature over its speed: which primitive, at
which speed, and how sure (:class:`promp.recognition.Recognition`), from what
:class:`promp.evidence.Evidence` integrated."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from promp.evidence.speed import logsumexp
from promp.model import ProMPModel
from promp.recognition import Recognition, label_noise, with_label_noise

__all__ = ["recognition_of"]


def recognition_of(
    model: ProMPModel,
    nodes: Sequence[np.ndarray],
    tables: Sequence[np.ndarray],
    priors: Sequence[np.ndarray],
    evidence: np.ndarray,
    alpha_method: str,
) -> Recognition:
    """The :class:`promp.recognition.Recognition` of every primitive's quadrature: its
    ``nodes`` (log alpha, increasing), the log-likelihoods ``tables`` and log prior densities
    ``priors`` there, and its log-evidence (``evidence``, (K,)); the probabilities with the
    "none of these" hypothesis (:func:`promp.recognition.with_label_noise`)."""
    if not np.isfinite(evidence).any():
        raise ValueError("no primitive explains the observation (every likelihood is zero)")
    probabilities = with_label_noise(np.exp(evidence - logsumexp(evidence)), label_noise(model))
    index = int(np.argmax(evidence))
    best = int(np.argmax(tables[index] + priors[index]))
    return Recognition(
        index=index,
        primitive=model.primitives[index].name,
        alpha=float(math.exp(nodes[index][best])),
        probabilities=probabilities,
        candidates=tuple(np.exp(x) for x in nodes),
        log_likelihoods=tuple(tables),
        log_prior=tuple(priors),
        log_evidence=evidence,
        alpha_method=alpha_method,
    )
