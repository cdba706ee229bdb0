"""The Learn folder's controls when a user's choice races the studio's loop.

viser sets a control's value on its event loop when the browser sends it, then calls the
callbacks from its thread pool; an assignment on the server calls them at once, without a
client. A choice that reaches the control while the loop's frame draws the stored settings must
stay chosen and be stored (a fresh-clone CI run lost "automatic" this way: the frame set the
dropdown back to the stored 0.01 and forgot the move). The handles below follow those rules.
"""

from __future__ import annotations

import contextlib
import time
from types import MappingProxyType, SimpleNamespace

import pytest

from app.panels.teach import learn
from promp.model import Settings


class Handle:
    """A viser input handle's value and callbacks (see the module docstring)."""

    def __init__(self, value, options=()):
        self._value, self.options, self.disabled, self._callbacks = value, options, False, []

    def on_update(self, callback) -> None:
        self._callbacks.append(callback)

    @property
    def value(self):
        return self._value

    @value.setter
    def value(self, value) -> None:  # the server's assignment: callbacks at once, no client
        if value == self._value:
            return
        self._value = value
        for callback in self._callbacks:
            callback(SimpleNamespace(client=None, target=self))

    def chosen_in_browser(self, value) -> None:  # viser's event loop: the value first
        self._value = value

    def called_back(self) -> None:  # then its thread pool: the callbacks, with the client
        for callback in self._callbacks:
            callback(SimpleNamespace(client=object(), target=self))


class Gui:
    def add_folder(self, _label):
        return contextlib.nullcontext()

    def add_checkbox(self, _label, value, hint=""):
        return Handle(value)

    def add_slider(self, _label, _low, _high, _step, value, hint=""):
        return Handle(value)

    def add_dropdown(self, _label, options, initial_value, hint=""):
        return Handle(initial_value, options)

    def add_markdown(self, content):
        return SimpleNamespace(content=content)


class Store:
    """Settings stored and published as a new state, as :class:`app.core.store.Store` does."""

    def __init__(self, **settings):
        self.calls: list[dict] = []
        self.publish(settings)

    def publish(self, settings: dict) -> None:
        frozen = MappingProxyType(dict(settings))
        self.state = SimpleNamespace(
            settings=frozen, findings=object(), checks=object(), learn_version=len(self.calls),
            learning_settings=lambda: Settings(**frozen),
        )  # fmt: skip

    def set_learning(self, n_basis, width, *, shrinkage, noise_scale) -> None:
        wanted = {"n_basis": n_basis, "width": width, "noise_scale": noise_scale}
        self.calls.append({**wanted, "shrinkage": shrinkage})
        self.publish({**{k: v for k, v in wanted.items() if v is not None}, "shrinkage": shrinkage})


def frame(store: Store, now: float):
    snapshot = SimpleNamespace(store=store.state, learner=object(), model=None, refitting=False)
    return SimpleNamespace(snapshot=snapshot, now=now)


@pytest.fixture
def section(monkeypatch):
    monkeypatch.setattr(learn, "fit_text", lambda *_args: "")
    store = Store(shrinkage=0.01)
    ctx = SimpleNamespace(gui=Gui(), store=store, notify=lambda *args: None)
    section = learn.LearnSection(ctx)
    section.step(frame(store, time.monotonic()))
    return section, store


def after_the_pause() -> float:
    return time.monotonic() + learn.LEARN_DEBOUNCE_S + 1.0


def test_a_choice_reaching_the_control_while_a_frame_draws_is_kept_and_stored(section) -> None:
    section, store = section
    assert section.shrinkage.value == "0.01"
    section.shrinkage.chosen_in_browser("automatic (pooled prior)")
    store.publish({"shrinkage": 0.01})  # a new state, e.g. a take's scores written meanwhile
    section.step(frame(store, time.monotonic()))  # the frame draws the stored settings
    assert section.shrinkage.value == "automatic (pooled prior)"
    section.shrinkage.called_back()
    section.step(frame(store, after_the_pause()))
    assert [call["shrinkage"] for call in store.calls] == [None]
    assert store.state.settings["shrinkage"] is None


def test_what_the_store_changes_is_shown_and_never_stored_back(section) -> None:
    section, store = section
    store.publish({"shrinkage": 0.1, "n_basis": 9, "width": 1.2, "noise_scale": 2.0})  # an import
    section.step(frame(store, time.monotonic()))
    assert section.shrinkage.value == "0.1" and section.n_basis.value == 9
    assert not section.automatic.value and not section.n_basis.disabled
    # another browser tab stores other settings
    store.publish({"shrinkage": 0.3, "n_basis": 12, "width": 1.2, "noise_scale": 2.0})
    section.step(frame(store, after_the_pause()))
    assert store.calls == []  # the section's own assignments are not a user's move
    assert section.shrinkage.value == "0.3" and section.n_basis.value == 12
