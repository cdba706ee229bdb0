"""Multi-modal Probabilistic Movement Primitives: learn, recognise, predict (numpy/scipy only).

The method of Dermy, Charpillet and Ivaldi, "Multi-Modal Intention Prediction With
Probabilistic Movement Primitives": from demonstrations of several movements, each recorded in
several modalities (the hand's position in metres, the head's angles in radians...), learn one
primitive per movement, a Gaussian over the weights of a basis of each dimension (Eqs. 1-4);
then from the first samples of a new movement, in any subset of the modalities, recognise
which primitive it is and at which speed (Eqs. 6-7), condition the primitive on what was seen
(Eq. 8) and predict the rest of the movement in every modality, the unobserved ones too.

Learn and infer
---------------
fit(dataset, layout)            a ProMPModel from {primitive name: [Demonstration, ...]}; the
                                basis, its width and the noise are chosen from the data
infer(model, observation)       an Inference: recognition, timing, posterior, prediction
recognise, condition, predict   the three steps of infer, one at a time
condition_on_via_points         a primitive (or a posterior) made to pass through points,
                                ViaPoint by phase or time, each with its precision (Eq. 8)
save_model, load_model          the model as versioned JSON (the studio's Export model)
read_dataset(folder, format)    demonstrations from files (lab records, CSV, rig recordings)
leave_one_out(dataset, layout,  the evaluation: every demonstration held out in turn
              percents)         (what ``python -m promp.evaluate`` runs)
CommitRule(threshold, window)   when to act: commit to the recognised primitive once its
                                probability has stayed above ``threshold`` for ``window`` s of
                                the movement, fed prediction by prediction
                                (``state, decision = state.update(time, probabilities)``)

Example
-------
Two reaches, six demonstrations each, learned; a new reach recognised from its first 40
samples, and the rest of it predicted:

>>> import numpy as np
>>> import promp
>>> rng = np.random.default_rng(0)
>>> layout = promp.Layout((promp.Modality("hand", ("x", "y", "z"), unit="m"),))
>>> def reach(goal, seconds):
...     times = np.arange(0.0, seconds, 0.02)  # s, 50 Hz
...     s = np.sin(0.5 * np.pi * times / times[-1]) ** 2  # a smooth start and stop
...     values = np.outer(s, goal) + 0.002 * rng.standard_normal((times.size, 3))
...     return promp.Demonstration(times, values, ("x", "y", "z"))
>>> goals = {"left": np.array([0.3, 0.2, 0.1]), "right": np.array([0.3, -0.2, 0.1])}
>>> dataset = {
...     name: [reach(goal * rng.uniform(0.9, 1.1), rng.uniform(1.5, 2.5)) for _ in range(6)]
...     for name, goal in goals.items()
... }
>>> model = promp.fit(dataset, layout)
>>> seen = reach(goals["right"], 2.0)
>>> observation = promp.Observation(seen.times[:40], seen.values[:40], ("hand",))
>>> result = promp.infer(model, observation)
>>> result.primitive, bool(result.probabilities[1] > 0.9)
('right', True)
>>> result.prediction.mean.shape[1]  # the whole movement, every dimension
3

The names below are the library's public API (``promp.__all__``); each module lists its own
public names in its ``__all__``, and a name with a leading underscore is internal. Importing
``promp`` limits every BLAS library to one thread for the process (``promp._threads``) and
loads the rest on first use.
"""

from __future__ import annotations

import importlib

# Every BLAS library on one thread, once for the process (see promp/_threads.py): first.
from promp import _threads  # noqa: F401

# The public API: each name, and the module it lives in, imported on first use (importing
# them all at once would double the cost of ``import promp``; see the tests).
_HOMES = {
    "fit": "promp.learn",
    "infer": "promp.pipeline",
    "recognise": "promp.recognition",
    "condition": "promp.inference",
    "predict": "promp.inference",
    "condition_on_via_points": "promp.via_points",
    "ViaPoint": "promp.via_points",
    "save_model": "promp.io",
    "load_model": "promp.io",
    "read_dataset": "promp.datasets",
    "leave_one_out": "promp.evaluate.sweep",
    "Demonstration": "promp.data",
    "Layout": "promp.data",
    "Modality": "promp.data",
    "Observation": "promp.observation",
    "Settings": "promp.model",
    "ProMPModel": "promp.model",
    "Primitive": "promp.model",
    "Inference": "promp.pipeline",
    "Recognition": "promp.recognition",
    "Posterior": "promp.inference",
    "Prediction": "promp.inference",
    "DatasetRead": "promp.datasets",
    "SweepResult": "promp.evaluate.sweep",
    "CommitRule": "promp.decision",
}

__all__ = list(_HOMES)


def __getattr__(name: str) -> object:
    if name not in _HOMES:
        raise AttributeError(f"module 'promp' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), name)
    globals()[name] = value  # once: later lookups do not come here
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
