"""The evaluation folder's "Failed trials" dropdown and its "Open in Infer" button: the
held-out demonstrations the latest evaluation did not recognise
(:mod:`app.panels.data.failed_trials`), one of which the Infer tab shows on request, held out,
at the percentage it failed at (:meth:`app.ui.context.PanelContext.open_in_infer`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import viser

from app.panels.data.failed_trials import FailedTrial, failed_trials, trial_choices
from app.ui.context import InferRequest
from promp.data import Demonstration
from promp.evaluate.sweep import SweepResult

Notify = Callable[[viser.ClientHandle | None, str, str, str], None]
TRIALS_LISTED = 200  # the Failed trials dropdown's options at most
NO_TRIAL = "(none)"


class FailedTrialPicker:
    """Choose a failed trial and open it in the Infer tab.

    Parameters
    ----------
    dropdown : viser.GuiDropdownHandle
        "Failed trials": the trials by their label.
    open_button : viser.GuiButtonHandle
        "Open in Infer".
    open_in_infer : callable
        ``open_in_infer(request, client)``: the studio shows ``request`` in the Infer tab.
    notify : callable
        ``notify(client, title, body, color)``.
    """

    def __init__(
        self,
        dropdown: viser.GuiDropdownHandle,
        open_button: viser.GuiButtonHandle,
        open_in_infer: Callable[[InferRequest, viser.ClientHandle | None], None],
        notify: Notify,
    ) -> None:
        self.dropdown, self.open_button = dropdown, open_button
        self._open_in_infer, self.notify = open_in_infer, notify
        self._trials: dict[str, FailedTrial] = {}  # by their label, as the dropdown lists them
        open_button.on_click(lambda event: self.open_in_infer(event.client))

    def show(self, result: SweepResult, dataset: Mapping[str, Sequence[Demonstration]]) -> None:
        """List the failed trials of ``result`` (swept on ``dataset``), the first
        :data:`TRIALS_LISTED` of them."""
        trials = failed_trials(result, dataset)
        self._trials = trial_choices(trials[:TRIALS_LISTED])
        shown = f"first {TRIALS_LISTED} of " if len(trials) > TRIALS_LISTED else ""
        self.dropdown.label = f"Failed trials ({shown}{len(trials)})"
        self.dropdown.options = tuple(self._trials) or (NO_TRIAL,)
        self.dropdown.visible = True
        self.open_button.visible = True
        self.open_button.disabled = not self._trials

    def clear(self) -> None:
        """No trial listed; the dropdown and the button hidden."""
        self._trials = {}
        self.dropdown.visible = self.open_button.visible = False

    def open_in_infer(self, client: viser.ClientHandle | None) -> FailedTrial | None:
        """Ask the studio to show the chosen failed trial in the Infer tab."""
        trial = self._trials.get(self.dropdown.value)
        if trial is None:
            self.notify(
                client, "No failed trial", "The evaluation recognised every trial.", "yellow"
            )
            return None
        self._open_in_infer(trial.request, client)
        return trial
