"""The Teach tab's Learn folder: the learning settings, and how the latest fit went.

*Automatic* (the default) leaves the basis count, its width and the noise scale to every fit,
which chooses them from the demonstrations (:mod:`promp.selection`); the sliders then show what
the latest fit chose and are read-only. Unticked, the sliders set them. Moving a control only
notes the time; once the controls have been still for :data:`LEARN_DEBOUNCE_S`,
:meth:`LearnSection.step` hands the settings to :meth:`app.core.store.Store.set_learning`, which
stores them; the learner refits in the background.

The fit's line says what the learner's state says, and nothing else: the time of *its* fit and
the demonstrations *it* learned from; while the model does not answer the latest change yet,
the line says the model is being learned again (a model is never shown with the count of
demonstrations it has not learned from).
"""

from __future__ import annotations

import math
import time

from app.core.snapshot import Snapshot
from app.ui.context import Frame, PanelContext
from app.ui.text import GREEN, ORANGE, colored, escape
from promp.model import FALLBACK
from promp.progress import clock

LEARN_DEBOUNCE_S = 0.15  # a slider being dragged refits once it pauses
FAST_FIT_MS = 100.0  # a fit slower than this is shown in orange
SHRINKAGE_CHOICES: dict[str, float | None] = {
    "automatic (pooled prior)": None,
    "1e-6 (span of the demos)": 1e-6,
    "1e-4": 1e-4,
    "1e-3": 1e-3,
    "0.01": 0.01,
    "0.1": 0.1,
    "0.3": 0.3,
}


def shrinkage_label(value: float | None) -> str:
    """The Shrinkage option showing ``value`` (a number the list lacks is shown as is)."""
    for label, choice in SHRINKAGE_CHOICES.items():
        if same_value(choice, value):
            return label
    return f"{value:g}"


def same_value(a: float | None, b: float | None) -> bool:
    """Equal settings: both automatic (None), or the same number."""
    if a is None or b is None:
        return a is b
    return math.isclose(a, b)



class LearnSection:
    """The Learn folder (see the module docstring)."""

    def __init__(self, ctx: PanelContext):
        self.ctx = ctx
        self._changed_at: float | None = None
        self._shown: tuple = ()  # what the settings and the status were drawn from
        self._refit: tuple[float, int] | None = None  # a refit seen since, its whole seconds
        # What each control was last set to from the store. A control is set again only when
        # that changes: a user's choice that reached the control while the frame drew keeps.
        self._displayed: dict[str, object] = {}
        settings = ctx.store.state.learning_settings()
        shown = settings.with_fallback()
        gui = ctx.gui
        with gui.add_folder("Learn"):
            self.automatic = gui.add_checkbox(
                "Automatic",
                bool(settings.automatic),
                hint="Basis functions, width and noise scale chosen from the demonstrations "
                "by every fit (cross-validated recognition log-loss)",
            )
            self.n_basis = gui.add_slider(
                "Basis functions", 4, 30, 1, int(shown.n_basis), hint="M per dimension"
            )
            self.width = gui.add_slider(
                "Width",
                0.5,
                3.0,
                0.1,
                float(shown.width),
                hint="RBF width, in multiples of the spacing of the centres",
            )
            self.noise_scale = gui.add_slider(
                "Noise scale",
                0.5,
                6.0,
                0.1,
                float(shown.noise_scale),
                hint="Multiplies the observation noise estimated from the fit residuals",
            )
            label = shrinkage_label(settings.shrinkage)
            options = tuple(SHRINKAGE_CHOICES)
            self.shrinkage = gui.add_dropdown(
                "Shrinkage",
                options if label in options else (*options, label),
                initial_value=label,
                hint="Regularisation of the weight covariance: the prior pooled across "
                "primitives, or a fixed shrinkage towards a scaled identity",
            )
            self.fit_status = gui.add_markdown("")
        self.sliders = (self.n_basis, self.width, self.noise_scale)
        for handle in (self.automatic, *self.sliders, self.shrinkage):
            handle.on_update(self._moved)

    def _moved(self, event) -> None:
        if event.client is None:  # the section's own assignment (viser calls back at once)
            return
        self._changed_at = time.monotonic()

    def step(self, frame: Frame) -> None:
        """Store the settings once the controls have been still for a moment; show the
        settings and the latest fit when they changed."""
        snapshot = frame.snapshot
        changed = self._changed_at
        if changed is not None and frame.now - changed >= LEARN_DEBOUNCE_S:
            self._changed_at = None
            self._store_settings(snapshot)
        store, learner = snapshot.store, snapshot.learner
        shown = (store.settings, store.findings, store.checks, learner, store.learn_version)
        since = None if self._refit is None else self._refit[0]
        if snapshot.refitting:  # its clock, moved every second
            since = frame.now if since is None else since
            refit = (since, int(frame.now - since))
        else:
            refit = None
        ticked, self._refit = refit != self._refit, refit
        if not ticked and len(shown) == len(self._shown) and all(
            a is b for a, b in zip(shown, self._shown, strict=True)
        ):
            return
        self._shown = shown
        if self._changed_at is None:
            self._show_settings(snapshot)
        self.fit_status.content = fit_text(snapshot, None if since is None else frame.now - since)

    def _store_settings(self, snapshot: Snapshot) -> None:
        current = snapshot.store.learning_settings()
        wanted = {
            "n_basis": int(self.n_basis.value),
            "width": round(float(self.width.value), 3),
            "noise_scale": round(float(self.noise_scale.value), 3),
        }
        if self.automatic.value:
            wanted = dict.fromkeys(wanted)
        shrinkage = SHRINKAGE_CHOICES.get(self.shrinkage.value, current.shrinkage)
        if all(
            same_value(value, getattr(current, name)) for name, value in wanted.items()
        ) and same_value(shrinkage, current.shrinkage):
            return
        try:
            self.ctx.store.set_learning(
                wanted["n_basis"], wanted["width"], shrinkage=shrinkage,
                noise_scale=wanted["noise_scale"],
            )  # fmt: skip
        except (ValueError, OSError) as exc:
            self.ctx.notify("Cannot change the learning settings", str(exc), "red")
            self._shown, self._displayed = (), {}  # the stored settings again

    def _show_settings(self, snapshot: Snapshot) -> None:
        settings = snapshot.store.learning_settings()
        automatic = set(settings.automatic) == set(FALLBACK)
        # What the latest fit chose where the data chooses (the fallback values until then).
        model = snapshot.model
        chosen = settings.with_fallback() if model is None else model.settings
        self._display("Automatic", self.automatic, automatic)
        for handle, name in zip(self.sliders, FALLBACK, strict=True):
            handle.disabled = automatic
            value = getattr(settings, name)
            self._display(name, handle, getattr(chosen, name) if value is None else value)
        label = shrinkage_label(settings.shrinkage)
        if label not in self.shrinkage.options:
            self.shrinkage.options = (*self.shrinkage.options, label)
        self._display("shrinkage", self.shrinkage, label)

    def _display(self, key: str, handle, value) -> None:
        """Set ``handle`` to ``value`` when the store's value for it changed since last shown."""
        if key in self._displayed and self._displayed[key] == value:
            return
        self._displayed[key] = value
        handle.value = value


def fit_text(snapshot: Snapshot, refit_s: float | None = None) -> str:
    """The Learn folder's line (see the module docstring); ``refit_s``: how long the refit
    under way has been running."""
    store, learner = snapshot.store, snapshot.learner
    n_left_out = len(store.left_out)
    left_out = (
        "  \n" + colored(
            f"⚠ {n_left_out} flagged demonstration(s) left out (see Demonstrations)", ORANGE
        )
        if n_left_out
        else ""
    )
    refitting = ""
    if snapshot.refitting:
        n_now = sum(len(d) for d in store.learned.values())
        refitting = "  \n" + colored(
            f"Learning again from {n_now} demonstrations...", ORANGE, bold=True
        ) + refit_clock(refit_s, learner.fit_ms / 1000.0 if snapshot.model is not None else 0.0)
    model, error, fit_ms = snapshot.model, learner.error, learner.fit_ms
    if error is not None and model is None:
        return colored(f"Not learned: {escape(error)}", ORANGE) + refitting + left_out
    if model is None:
        return "Learning..." + refitting + left_out
    learned = f"{len(model.names)} primitive(s) learned from {learner.n_demos} demonstrations"
    if learner.reused:  # the fit took fit_ms a moment ago; this refit none
        text = colored("Model reused", GREEN, bold=True)
        learned += f", the same as a recent fit ({fit_ms:.0f} ms)"
    else:
        color = GREEN if fit_ms < FAST_FIT_MS else ORANGE
        text = colored(f"Fit in {fit_ms:.0f} ms", color, bold=True)
    text = f"{text}: {learned}."
    choice = model.report.get("settings", {})
    if choice.get("chosen"):
        used, rule = model.settings, str(choice.get("rule", ""))
        if rule.startswith("fallback"):
            how = escape(rule[0].upper() + rule[1:])
        elif rule.startswith("kept"):
            how = "Kept from the last fit (it still beats the runner-up)"
        else:
            how = "Chosen from the demonstrations"
        text += f"  \n{how}: M = {used.n_basis}, width {used.width:g}, noise x{used.noise_scale:g}."
    text += recognition_line(model)
    if error is not None:
        text += "  \n" + colored(escape(error), ORANGE)
    return text + refitting + left_out


def recognition_line(model) -> str:
    """The recognition variant the model uses, and why, in one line (empty for a model that
    says nothing of it: a file before version 5, or every setting given): chosen by the
    held-out log-loss (:mod:`promp.selection.recognition_choice`), or given."""
    name = model.settings.recognition
    if name is None:
        return ""
    what = ("the ProMP (one Gaussian per primitive)" if name == "promp" else
            f"the mixture over the demonstrations (bandwidth {name.partition(':')[2]})")
    why = model.report.get("settings", {}).get("recognition")
    if not isinstance(why, dict):
        return f"  \nRecognition: {what}, given."
    losses = why.get("log_loss") or {}
    if not losses:
        return f"  \nRecognition: {what} ({escape(str(why.get('rule', '')))})."
    promp, lowest = losses.get("promp"), str(why.get("lowest", name))
    kept = str(why.get("rule", "")).startswith("kept")
    if name != "promp" and promp is not None:
        because = f"held-out log-loss {losses[name]:.3f} against the ProMP's {promp:.3f}"
    elif lowest != name and losses.get(lowest) is not None:
        because = (f"held-out log-loss {promp:.3f}; {escape(lowest)}'s {losses[lowest]:.3f} is "
                   "within the trials' noise")
    elif kept:  # the ProMP alone scored
        because = f"held-out log-loss {promp:.3f}"
    else:
        because = f"held-out log-loss {promp:.3f}, the lowest"
    if kept:
        because += ", kept with the settings from the last fit"
    return f"  \nRecognition: {what}: {because}."


def refit_clock(elapsed_s: float | None, last_s: float) -> str:
    """`` 0:05 elapsed · about 0:03 left``: a refit has no count, so the time the last fit took
    (``last_s``, 0: unknown) is the estimate."""
    if elapsed_s is None:
        return ""
    text = f" {clock(elapsed_s)} elapsed"
    if last_s <= 0:
        return text
    if last_s > elapsed_s:
        return f"{text} · about {clock(last_s - elapsed_s)} left (as long as the last fit)"
    return f"{text} · longer than the last fit ({clock(last_s)})"
