"""The Teach tab's Learn folder: the learning settings, and how the latest fit went.

*Automatic* (the default) leaves the basis count, its width and the noise scale to every fit,
which chooses them from the demonstrations (:mod:`promp.selection`); the sliders then show what
the latest fit chose and are read-only. Unticked, the sliders set them. Moving a control only
notes the time; once the controls have been still for :data:`LEARN_DEBOUNCE_S`,
:meth:`LearnSection.step` hands the settings to :meth:`app.core.session.Session.set_learning`, which
stores them and refits in the background.
"""

from __future__ import annotations

import math
import time

from app.ui.context import PanelContext
from app.ui.text import GREEN, ORANGE, colored, escape
from promp.model import FALLBACK, Settings

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
        settings = ctx.session.learning_settings()
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

    def _moved(self, _event) -> None:
        self._changed_at = time.monotonic()

    def step(self, now: float) -> None:
        """Store the settings once the controls have been still for a moment."""
        changed = self._changed_at
        if changed is None or now - changed < LEARN_DEBOUNCE_S:
            return
        self._changed_at = None
        session = self.ctx.session
        current = session.learning_settings()
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
            session.set_learning(
                wanted["n_basis"], wanted["width"], shrinkage=shrinkage,
                noise_scale=wanted["noise_scale"],
            )  # fmt: skip
        except (ValueError, OSError) as exc:
            self.ctx.notify("Cannot change the learning settings", str(exc), "red")
            self._show_settings(session.learning_settings())

    def show(self) -> None:
        """The session's settings (unless the user is moving a control) and the latest fit."""
        if self._changed_at is None:
            self._show_settings(self.ctx.session.learning_settings())
        self._show_fit()

    def _show_settings(self, settings: Settings) -> None:
        automatic = set(settings.automatic) == set(FALLBACK)
        # What the latest fit chose where the data chooses (the fallback values until then).
        model = self.ctx.session.model
        chosen = settings.with_fallback() if model is None else model.settings
        self.automatic.value = automatic
        for handle, name in zip(self.sliders, FALLBACK, strict=True):
            handle.disabled = automatic
            value = getattr(settings, name)
            handle.value = getattr(chosen, name) if value is None else value
        label = shrinkage_label(settings.shrinkage)
        if label not in self.shrinkage.options:
            self.shrinkage.options = (*self.shrinkage.options, label)
        self.shrinkage.value = label
        self._changed_at = None  # these assignments ran the callbacks

    def _show_fit(self) -> None:
        session = self.ctx.session
        with session.lock:
            model, error, fit_ms = session.model, session.fit_error, session.fit_ms
            reused = session.fit_reused
            n_demos = sum(len(d) for d in session.learned_demos().values())
            n_left_out = len(session.left_out())
        left_out = (
            "  \n" + colored(
                f"⚠ {n_left_out} flagged demonstration(s) left out (see Demonstrations)",
                ORANGE,
            )
            if n_left_out
            else ""
        )
        if error is not None and model is None:
            self.fit_status.content = colored(f"Not learned: {escape(error)}", ORANGE) + left_out
            return
        n_learned = len(model.names) if model is not None else 0
        learned = f"{n_learned} primitive(s) learned from {n_demos} demonstrations"
        if reused:  # the fit took fit_ms a moment ago; this refit none
            text = colored("Model reused", GREEN, bold=True)
            learned += f", the same as a recent fit ({fit_ms:.0f} ms)"
        else:
            color = GREEN if fit_ms < FAST_FIT_MS else ORANGE
            text = colored(f"Fit in {fit_ms:.0f} ms", color, bold=True)
        self.fit_status.content = f"{text}: {learned}."
        choice = model.report.get("settings", {}) if model is not None else {}
        if choice.get("chosen"):
            used, rule = model.settings, str(choice.get("rule", ""))
            if rule.startswith("fallback"):
                how = escape(rule[0].upper() + rule[1:])
            elif rule.startswith("kept"):
                how = "Kept from the last fit (it still beats the runner-up)"
            else:
                how = "Chosen from the demonstrations"
            self.fit_status.content += (
                f"  \n{how}: M = {used.n_basis}, width {used.width:g}, "
                f"noise x{used.noise_scale:g}."
            )
        if error is not None:
            self.fit_status.content += "  \n" + colored(escape(error), ORANGE)
        self.fit_status.content += left_out
