"""The studio's GUI panels, one tab each: Teach (record and learn primitives), Infer (recognise
and predict), Data (export, import, evaluation).

A panel is built by the studio inside its tab with a :class:`app.ui.context.PanelContext` and
follows the :class:`app.ui.context.Panel` protocol: its callbacks record what changed, its
``step()`` (the studio's loop) recomputes, its ``close()`` stops what runs in the background.
"""
