"""The Data tab: export and import, one's own recordings, the trash, the evaluation.

:class:`app.panels.data.panel.DataPanel` (export and import of models and workspaces) with its
sections :mod:`~app.panels.data.import_dataset`, :mod:`~app.panels.data.trash_list` and
:mod:`~app.panels.data.evaluation_section`, which plans (:mod:`~app.panels.data.evaluation_plan`)
and runs (:mod:`~app.panels.data.evaluation`) an evaluation, shows its results
(:mod:`~app.panels.data.results_area`, :mod:`~app.panels.data.results`) and failed trials
(:mod:`~app.panels.data.failed_trial_picker`, :mod:`~app.panels.data.failed_trials`), and
exports :mod:`~app.panels.data.results_zip`.
"""

from app.panels.data.panel import DataPanel

__all__ = ["DataPanel"]
