"""The Infer tab: recognise the primitive from the early part of a movement, predict the rest.

:class:`app.panels.infer.panel.InferPanel` (observation choices, the scrub step, the live
stream, the replay), its text (:mod:`~app.panels.infer.readout`) and its charts
(:mod:`~app.panels.infer.charts`); the 3D objects are the scene's
(:mod:`app.scene.inference_layer`).
"""

from app.panels.infer.panel import LIVE, TEST, InferPanel

__all__ = ["LIVE", "TEST", "InferPanel"]
