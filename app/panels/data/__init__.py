"""The Data tab: export and import, one's own recordings, the trash, the evaluation.

:class:`app.panels.data.panel.DataPanel` (export and import of models and workspaces) with its
sections :mod:`~app.panels.data.import_dataset`, :mod:`~app.panels.data.trash_list` and
:mod:`~app.panels.data.evaluation_section`, which runs :mod:`~app.panels.data.evaluation`,
shows :mod:`~app.panels.data.results` and :mod:`~app.panels.data.failed_trials`, and exports
:mod:`~app.panels.data.results_zip`.
"""

from app.panels.data.panel import DataPanel

__all__ = ["DataPanel"]
