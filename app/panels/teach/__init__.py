"""The Teach tab: primitives, recording, the head source, demonstrations, learning, priors.

:class:`app.panels.teach.panel.TeachPanel` composes one section per folder:
:mod:`~app.panels.teach.primitives`, :mod:`~app.panels.teach.record` (over the pure state
machine of :mod:`~app.live.take_controller`), :mod:`~app.panels.teach.head`,
:mod:`~app.panels.teach.demos`, :mod:`~app.panels.teach.learn` and
:mod:`~app.panels.teach.prior`.
"""

from app.panels.teach.panel import TeachPanel

__all__ = ["TeachPanel"]
