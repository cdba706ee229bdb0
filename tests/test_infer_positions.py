"""Every position in space drawn in Infer: which modalities are positions (three linear columns
in metres), what an inference gives of each (region, predicted path, observed part, truth), and,
in Chromium, a workspace with the robot's hand and a partner's hand: observing the partner's,
both are drawn in 3D, labelled."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry
from app.live.inference import inferred
from app.live.regions import PATH_POINTS, TUBE_POINTS
from app.panels.infer import InferPanel
from app.scene.position_nodes import lighter
from app.scene.tubes import region_vertices
from promp.data import Demonstration, Layout, Modality
from promp.inference import Observation
from promp.learn import fit
from robots.icub.layout import HAND, HEAD, position_modalities
from robots.icub.scenario import generate_scenario
from tests.browser import choose, settled_screenshot
from tests.conftest import PICTURE_DPR, PageSpec, StudioSpec, wait_frames, wait_until

PARTNER = Modality("partner", ("px", "py", "pz"), unit="m")
LAYOUT = Layout((HAND, HEAD, PARTNER))
SCREENSHOT = Path("/tmp/infer_two_positions.png")


def with_partner(demo: Demonstration) -> Demonstration:
    """``demo`` with a partner's hand that comes from across the table to meet the robot's
    hand at its end (px, py, pz, metres)."""
    hand = demo.select(("x", "y", "z"))
    z = (demo.times - demo.times[0]) / demo.duration
    partner = hand[-1] + np.outer(1.0 - z, [-0.35, 0.05, -0.08]) + [-0.06, 0.0, 0.0]
    partner = partner + 0.01 * np.sin(3.0 * z + hand[0, 0])[:, None]  # each its own way
    values = np.column_stack([demo.values, partner])
    return Demonstration(demo.times, values, (*demo.columns, "px", "py", "pz"), name=demo.name)


def partner_dataset(seed: int, n_demos: int) -> dict[str, list[Demonstration]]:
    scenario = generate_scenario(seed=seed, n_demos=n_demos)
    return {name: [with_partner(d) for d in demos] for name, demos in scenario.items()}


def make_workspace(root: Path, _request) -> None:
    dataset = partner_dataset(6, 5)
    Workspace.create(root, WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset, layout=LAYOUT,
    ))  # fmt: skip


STUDIO = StudioSpec(make=make_workspace, ready=lambda studio: studio.session.snapshot().model)
PAGE = PageSpec(tab="Infer", dpr=PICTURE_DPR)


def test_a_position_is_three_linear_columns_in_metres() -> None:
    assert HAND.is_position and PARTNER.is_position
    assert Modality("marker", ("hx", "hy", "hz"), unit="").is_position  # a CSV's, no unit
    assert not HEAD.is_position  # angles
    assert not Modality("force", ("fx", "fy", "fz"), unit="N").is_position
    assert not Modality("marker", ("a", "b", "c"), unit="").is_position  # not named x, y, z
    assert not Modality("plane", ("x", "y"), unit="m").is_position
    layout = Layout((HEAD, PARTNER, HAND))
    assert [m.name for m in position_modalities(layout)] == ["hand", "partner"]  # hand first


def test_an_inference_gives_every_position() -> None:
    dataset = partner_dataset(7, 5)
    model = fit({k: v[1:] for k, v in dataset.items()}, LAYOUT)
    demo = dataset["direct"][0]
    obs = Observation.from_demo(model, demo, demo.n_samples // 2, ["partner"])
    result = inferred(model, obs, "ml", truth=demo)
    hand, partner = result.positions
    assert (hand.modality, partner.modality) == ("hand", "partner")
    assert hand.observed is None  # not observed
    assert_allclose(partner.observed, demo.select(("px", "py", "pz"))[: obs.n_observed])
    for view in (hand, partner):
        assert view.region.mean.shape == (TUBE_POINTS, 3)
        assert view.region.cov.shape == (TUBE_POINTS, 3, 3)
        assert view.future.shape == (PATH_POINTS, 3)
        assert view.truth.shape == (demo.n_samples - obs.n_observed + 1, 3)
    assert_allclose(hand.future, result.future.hand)  # the hand's path is the replayed one
    dims = model.layout.dims(["partner"])
    assert_allclose(partner.region.mean, result.prediction.mean[:, dims], atol=1e-12)
    assert_allclose(partner.future[-1], result.prediction.mean[-1, dims], atol=1e-12)


@pytest.mark.browser
def test_observing_the_partners_hand_draws_both_hands_labelled(studio, page) -> None:
    infer = next(p for p in studio.panels if isinstance(p, InferPanel))
    choose(page, infer.controls.observed, "partner")

    def shown():
        view = infer.view
        drawn = studio.scene.inference.drawn
        return (view is not None and view.result is not None
                and view.result.observation.modalities == ("partner",)
                and drawn.result is view.result and studio.scene.look.inference and drawn)

    drawn = wait_until(shown, timeout=180, what="the partner's hand observed and drawn")
    # the frame that drew it shows the nodes it shaped only after: a whole frame later, what
    # the previous result showed (the robot's hand observed) is hidden
    wait_frames(studio, 1)
    layer, result = studio.scene.inference, drawn.result
    nodes = layer.others["partner"]
    for node in (nodes.tube, nodes.future, nodes.observed, nodes.end, nodes.label):
        assert id(node) in drawn.shaped
    wait_until(lambda: nodes.tube.visible and nodes.label.visible and layer.tube.visible,
               timeout=60, what="both tubes and the labels shown")  # fmt: skip
    assert id(layer.observed_line) not in drawn.shaped  # the robot's hand was not observed
    assert not layer.observed_line.visible
    assert nodes.label.text == "partner: observed, predicted"
    assert layer.hand_label.text == "hand: predicted"
    partner = result.positions[1]
    assert_allclose(nodes.tube.vertices, region_vertices(partner.region, 0.9), atol=1e-6)
    assert tuple(nodes.tube.color) == lighter(drawn.color)
    assert_allclose(nodes.observed.points[0], partner.observed[0], atol=1e-6)
    page.mouse.move(5, 450)
    settled_screenshot(page, SCREENSHOT, timeout=120)


def test_the_observed_choices_are_every_set_of_modalities(studio) -> None:
    """GUI logic without a browser: with three modalities, Infer offers all seven sets (the
    command line's, :meth:`promp.data.Layout.observable`); one chosen is what is observed."""
    from app.scene.look import INFER

    infer = next(p for p in studio.panels if isinstance(p, InferPanel))
    studio.scene.use_panel(INFER)
    wait_until(lambda: "head + partner" in infer.controls.observed.options, timeout=60,
               what="the layout's choices offered")  # fmt: skip
    assert tuple(infer.controls.observed.options) == (
        "hand + head + partner", "hand", "head", "partner", "hand + head", "hand + partner",
        "head + partner",
    )  # fmt: skip
    infer.controls.observed.value = "head + partner"

    def observed():
        view = infer.view
        result = view.result if view is not None else None
        return result is not None and result.observation.modalities == ("head", "partner")

    wait_until(observed, timeout=180, what="an inference observing the head and the partner")
