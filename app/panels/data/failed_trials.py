"""The evaluation's failed trials, as the Data tab lists them for "Open in Infer": every
held-out demonstration recognised as another primitive at some setting (observed percentage,
modalities, alpha method), and every one the method could not run (counted as a recognition
error by the sweep). When the evaluation compared several methods, each trial says whose it is
(Open in Infer shows the demonstration to our method, at that setting). Pure: no viser.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from app.ui.context import InferRequest
from app.ui.display import method_label, series_title
from promp.data import Demonstration
from promp.evaluate.sweep import SweepResult


@dataclass(frozen=True)
class FailedTrial:
    """One trial not recognised as its own primitive.

    Attributes
    ----------
    request : InferRequest
        The demonstration and the setting the sweep tested it at.
    recognised : str or None
        The primitive it was recognised as; None when the method failed on it (``error``).
    probability : float
        The probability the method gave the recognised primitive (NaN when it failed).
    error : str
    method : str
        The method that did not recognise it (the sweep's name, e.g. ``dtw``).
    """

    request: InferRequest
    recognised: str | None
    probability: float = float("nan")
    error: str = ""
    method: str = ""

    def label(self, with_setting: bool, with_method: bool = False) -> str:
        """``curved_003 · curved · 10 % → direct`` (the demonstration, its primitive, the
        percentage observed, what it was recognised as, or ``failed``); ``with_setting`` adds
        the observed modalities and the alpha method (``10 % of hand + head, ML``),
        ``with_method`` the method first (``DTW 1-NN: curved_003 ...``). Short: the dropdown
        shows it in the panel's width."""
        r = self.request
        observed = f"{r.percent:g} %"
        if with_setting:
            observed += f" of {series_title(r.observed, r.alpha_method)}"
        who = f"{method_label(self.method)}: " if with_method else ""
        return f"{who}{r.demo} · {r.primitive} · {observed} → {self.recognised or 'failed'}"


def failed_trials(
    result: SweepResult, dataset: Mapping[str, Sequence[Demonstration]]
) -> list[FailedTrial]:
    """The trials of ``result`` (swept on ``dataset``, with its trials kept) not recognised as
    their own primitive: by primitive and demonstration in ``dataset``'s order, then by
    percentage, then in the sweep's order of observed modalities and alpha methods."""
    names = list(dataset)
    position = {
        (k, demo.name): j for k, name in enumerate(names) for j, demo in enumerate(dataset[name])
    }
    wrong = [t for t in result.trials if not t.correct]
    order = {m: i for i, m in enumerate(dict.fromkeys(t.method for t in result.trials))}
    wrong.sort(key=lambda t: (order[t.method], t.primitive,
                              position.get((t.primitive, t.demo), 0), t.percent))  # fmt: skip
    out = []
    for t in wrong:
        request = InferRequest(
            primitive=names[t.primitive],
            demo=t.demo,
            percent=float(t.percent),
            observed=tuple(t.observed),
            alpha_method=t.alpha_method,
        )
        if t.inferred is None:
            out.append(FailedTrial(request, None, error=t.error, method=t.method))
        else:
            index = t.inferred.index
            probability = float(t.inferred.probabilities[index])
            out.append(FailedTrial(request, names[index], probability, method=t.method))
    return out


def trial_choices(trials: Sequence[FailedTrial]) -> dict[str, FailedTrial]:
    """The trials by their label (a dropdown's options, in order); the observed modalities
    and alpha method, and the method, are written only when the trials differ in them."""
    settings = {(t.request.observed, t.request.alpha_method) for t in trials}
    methods = {t.method for t in trials}
    return {t.label(len(settings) > 1, len(methods) > 1): t for t in trials}
