"""The Infer tab: recognise the primitive from the early part of a movement, predict the rest.

:class:`app.panels.infer.panel.InferPanel` reads its controls
(:mod:`~app.panels.infer.controls`) into a state, computes its view from the state and the
frame's snapshot (:func:`app.panels.infer.view_model.compute`, pure), and writes its text and charts
(:mod:`~app.panels.infer.readout`) and the recognition over the whole movement
(:mod:`~app.panels.infer.recognition`); the 3D objects are the scene's
(:mod:`app.scene.inference_layer`).
"""

from app.live.inference import LIVE, TEST
from app.panels.infer.panel import InferPanel

__all__ = ["LIVE", "TEST", "InferPanel"]
