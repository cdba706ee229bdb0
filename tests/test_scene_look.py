"""What the 3D view shows, without a browser: the look of each panel, and the controls that say
which panel is in use."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from app.scene.look import DATA, FADED, HIDDEN, INFER, SHOWN, TEACH
from app.scene.scene_view import WORKSPACE_LOOK, Look, look
from app.ui.context import PanelGui


def test_teach_and_data_show_the_workspace_whatever_infer_shows() -> None:
    for panel in (TEACH, DATA):
        for shown in (True, False):
            for priors in (SHOWN, FADED, HIDDEN):
                # Teach adds the ghost of the start pose, where a take begins.
                assert look(panel, shown, priors) == Look(True, SHOWN, False, panel == TEACH)


def test_infer_shows_its_inference_with_the_priors_as_asked() -> None:
    assert look(INFER, True, SHOWN) == Look(demos=True, priors=SHOWN, inference=True)
    assert look(INFER, True, FADED) == Look(demos=False, priors=FADED, inference=True)
    assert look(INFER, True, HIDDEN) == Look(demos=False, priors=HIDDEN, inference=True)
    assert look(INFER, False, FADED) == WORKSPACE_LOOK  # nothing to show: the workspace
    with pytest.raises(ValueError, match="unknown panel"):
        look("settings", True)
    with pytest.raises(ValueError, match="unknown priors"):
        look(INFER, True, "dimmed")


class FakeGui:
    """What PanelGui wraps: add_* methods returning handles with viser's callback hooks."""

    def __init__(self) -> None:
        self.callbacks: list = []

    def add_button(self, label: str):
        return SimpleNamespace(label=label, on_click=self.callbacks.append)

    def add_slider(self, label: str):
        return SimpleNamespace(label=label, on_update=self.callbacks.append)

    def add_markdown(self, text: str):
        return SimpleNamespace(content=text)

    def configure_theme(self) -> str:
        return "not wrapped"


def test_a_control_used_from_a_browser_makes_its_panel_the_one_in_use() -> None:
    used: list[str] = []
    fake = FakeGui()
    gui = PanelGui(fake, lambda: used.append("infer"))
    button, slider = gui.add_button("Play"), gui.add_slider("Observed %")
    gui.add_markdown("no control")
    assert (button.label, slider.label) == ("Play", "Observed %")
    assert gui.configure_theme() == "not wrapped"
    assert len(fake.callbacks) == 2  # one hook per control, none on the markdown
    for callback in fake.callbacks:
        callback(SimpleNamespace(client=None))  # set from Python: not the user
    assert used == []
    fake.callbacks[1](SimpleNamespace(client=object()))
    assert used == ["infer"]

