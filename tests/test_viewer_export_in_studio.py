"""The studio's viewer exports against what the studio shows (GUI logic, no browser): the Data
tab's Export to Rerun / MCAP holds the demonstrations the 3D view draws, its prior tubes' very
vertices and the robot; the Infer tab's Export view holds the inference the Infer layer drew
and the Recognition chart's probabilities. Read back with Rerun's and mcap's own readers."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app.scene.tubes import resample
from app.scene.workspace_layer import LINE_POINTS
from promp.viewers.trial import path_name
from robots.icub.layout import hand_dims
from robots.icub.model_file import robot_glb
from tests.conftest import GIVEN_SETTINGS, StudioSpec, wait_frames, wait_until
from tests.viewer_readers import points, read_mcap, read_rrd, scene_entities

STUDIO = StudioSpec(seed=4, n_demos=4, settings=GIVEN_SETTINGS)


def _panel(studio, kind):
    return next(p for p in studio.panels if isinstance(p, kind))


def _rgba(value: int) -> tuple[int, ...]:
    return tuple(int(value) >> s & 0xFF for s in (24, 16, 8, 0))


def _tubes_drawn(studio) -> bool:
    """The scene's prior tubes are those of the learned model of the latest change."""
    snapshot = studio.session.snapshot()
    model = snapshot.model
    return (model is not None and not snapshot.refitting
            and studio.scene._tubes_from[0] is model
            and set(studio.scene.workspace.tubes) == set(model.names))  # fmt: skip


@pytest.fixture(scope="module")
def workspace_files(studio, tmp_path_factory):
    from app.panels.data import DataPanel

    wait_until(lambda: _tubes_drawn(studio), timeout=180, what="the prior tubes drawn")
    panel = _panel(studio, DataPanel)
    folder = tmp_path_factory.mktemp("studio_viewers")
    files = {}
    for suffix in (".rrd", ".mcap"):
        content = panel.viewers.export(None, suffix)
        assert content is not None
        files[suffix] = folder / f"workspace{suffix}"
        files[suffix].write_bytes(content)
    return files


def test_export_to_rerun_holds_what_the_3d_view_draws(studio, workspace_files) -> None:
    entities = read_rrd(workspace_files[".rrd"])
    store = studio.session.snapshot().store
    layout, cols = store.layout, hand_dims(store.layout)
    colors = {p.name: tuple(p.color) for p in store.primitives}
    for name, demos in store.demos.items():
        for demo in demos:
            path = f"demos/{path_name(name)}/{path_name(demo.name)}"
            [strip] = entities[path].static["LineStrips3D:strips"]
            hand = layout.extract(demo)[:, cols]
            assert_allclose(strip, hand, rtol=1e-6, atol=1e-7)
            assert _rgba(entities[path].static["LineStrips3D:colors"][0])[:3] == colors[name]
            line = studio.scene.workspace.lines[(name, demo.name)]  # the line the view draws
            assert_allclose(line.points, resample(np.array(strip), min(len(strip), LINE_POINTS)),
                            atol=1e-6)  # fmt: skip
            times, values = entities[f"{path}/head/yaw"].series("demo_time")
            assert_allclose(times, np.round((demo.times - demo.times[0]) * 1e9))
            assert_allclose(values, layout.extract(demo)[:, layout.dims(["head"])[2]])
            assert entities[f"{path}/head/yaw"].static["SeriesLines:names"] == ["head yaw (rad)"]
    for name, tube in studio.scene.workspace.tubes.items():
        mesh = entities[f"priors/{path_name(name)}"].static
        assert_allclose(mesh["Mesh3D:vertex_positions"], tube.vertices, atol=1e-7)
        assert np.array_equal(mesh["Mesh3D:triangle_indices"], tube.faces)
    blob = bytes(entities["robot"].static["Asset3D:blob"][0])
    assert blob == robot_glb(studio.arm.robot.q)  # the iCub at the pose the studio shows


def test_export_to_mcap_holds_the_same_entities(studio, workspace_files) -> None:
    rrd = read_rrd(workspace_files[".rrd"])
    messages, metadata = read_mcap(workspace_files[".mcap"])
    scene = scene_entities(messages)
    spatial = {p for p, e in rrd.items() if any(k.split(":")[0] in (
        "LineStrips3D", "Points3D", "Mesh3D", "Asset3D") for k in [*e.static, *(
            c for _, row in e.rows for c in row)])}  # fmt: skip
    assert set(scene) == spatial
    store = studio.session.snapshot().store
    name, demo = next((n, d[0]) for n, d in store.demos.items() if d)
    path = f"demos/{path_name(name)}/{path_name(demo.name)}"
    [(t, entity)] = scene[path]
    assert t == 0
    assert_allclose(points(entity.lines[0].points), rrd[path].static["LineStrips3D:strips"][0],
                    rtol=1e-6)  # fmt: skip
    for tube_name, tube in studio.scene.workspace.tubes.items():
        [(_, mesh)] = scene[f"priors/{path_name(tube_name)}"]
        assert_allclose(points(mesh.triangles[0].points), tube.vertices, atol=1e-7)
    assert "metres" in metadata["timelines"][0]["units"]


def test_a_hidden_demonstration_is_left_out_as_in_the_view(studio, tmp_path) -> None:
    from app.panels.data import DataPanel

    store = studio.session.snapshot().store
    name, demo = next((n, d[0]) for n, d in store.demos.items() if d)
    studio.session.view.set_hidden(name, demo.name, True)
    try:
        told = len(studio.notices)
        (tmp_path / "w.mcap").write_bytes(_panel(studio, DataPanel).viewers.export(None, ".mcap"))
        ids = set(scene_entities(read_mcap(tmp_path / "w.mcap")[0]))
        assert f"demos/{path_name(name)}/{path_name(demo.name)}" not in ids
        assert f"demos/{path_name(name)}/{path_name(demo.name)}/hand" not in ids
        assert any("1 hidden left out" in body for _, body, _ in list(studio.notices)[told:])
    finally:
        studio.session.view.set_hidden(name, demo.name, False)


def test_export_view_holds_the_inference_the_infer_layer_drew(studio, tmp_path) -> None:
    from app.panels.infer import InferPanel
    from app.panels.infer.viewer_export import InferExport

    panel = _panel(studio, InferPanel)
    wait_until(lambda: panel.view is not None and panel.view.result is not None, timeout=180,
               what="an inference in the Infer tab")  # fmt: skip
    wait_until(lambda: panel.recognition.curve() is not None, timeout=180,
               what="the recognition curve")  # fmt: skip
    wait_frames(studio)
    view, curve = panel.view, panel.recognition.curve()
    export = InferExport(panel.ctx, lambda: (view, curve), panel._color)
    (tmp_path / "v.rrd").write_bytes(export.export(None, ".rrd"))
    entities = read_rrd(tmp_path / "v.rrd")
    state, result = view.state, view.result
    prefix = f"infer/{path_name(state.primitive)}/{path_name(state.demo)}"
    hand = result.positions[0]
    assert hand.modality == "hand"
    at = entities[f"{prefix}/hand/predicted"].at("observed_percent", state.percent)
    assert_allclose(at["LineStrips3D:strips"][0], hand.future, rtol=1e-6, atol=1e-7)
    region = entities[f"{prefix}/hand/region"].at("observed_percent", state.percent)
    chosen = np.round(np.linspace(0, len(hand.region.mean) - 1, 16)).astype(int)
    assert_allclose(region["Ellipsoids3D:centers"], hand.region.mean[chosen], atol=1e-7)
    observed = entities[f"{prefix}/hand/observed"].at("observed_percent", state.percent)
    assert_allclose(observed["LineStrips3D:strips"][0], hand.observed, rtol=1e-6, atol=1e-7)
    for k, name in enumerate(result.model.names):
        times, values = entities[f"{prefix}/p/{path_name(name)}"].series("observed_percent")
        assert_allclose(times, curve.percents)
        assert_allclose(values, curve.probabilities[:, k])
        here = values[list(times).index(state.percent)]
        assert here == pytest.approx(result.inference.probabilities[k], abs=1e-9)


def _colourful_share(png: bytes) -> float:
    """The share of the 3-D view's pixels (the window's middle) in a saturated colour: the
    primitives' lines and tubes (Rerun's own interface and an empty view are grey)."""
    import io

    from PIL import Image

    image = np.asarray(Image.open(io.BytesIO(png)).convert("HSV"), dtype=float)
    h, w = image.shape[:2]
    middle = image[int(0.15 * h): int(0.7 * h), int(0.25 * w): int(0.75 * w)]
    return float(np.mean((middle[..., 1] > 110) & (middle[..., 2] > 60)))


@pytest.mark.browser
def test_rerun_s_own_web_viewer_draws_an_exported_workspace(
    workspace_files, browser, tmp_path, artifacts
) -> None:
    """``rerun --web-viewer --bind 127.0.0.1 FILE.rrd`` serves the Data tab's export and
    headless Chromium draws it (software rendering); the viewer listens on loopback only, its
    analytics are off (its own switch), and nothing the page asks for leaves the machine: the
    web page itself asks for fonts, a version check and Rerun's usage events (tel.rerun.io;
    Rerun 0.41's page has no switch for them), each refused here before it is sent."""
    from urllib.parse import urlsplit

    from tests.rerun_web import LOOPBACK, listening, web_viewer

    outside: list[str] = []

    def only_loopback(route) -> None:
        host = urlsplit(route.request.url).hostname or ""
        if host.startswith(LOOPBACK):
            route.continue_()
        else:  # fonts, a version check: refused here, never sent
            outside.append(route.request.url)
            route.abort()

    with web_viewer(workspace_files[".rrd"], tmp_path, tmp_path / "rerun.log") as (url, process):
        addresses = listening(process.pid)
        assert addresses and all(host.startswith(LOOPBACK) for host, _ in addresses), addresses
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.set_default_timeout(120_000)  # a frame of software WebGL on a busy machine
        shot = artifacts / "rerun.png"

        def drawn() -> bool:
            page.screenshot(path=str(shot), timeout=120_000)
            return _colourful_share(shot.read_bytes()) > 0.002

        finished: list[str] = []
        page.on("requestfinished", lambda request: finished.append(request.url))
        try:
            page.route("**/*", only_loopback)
            page.goto(url)
            wait_until(drawn, timeout=300, interval=2.0,
                       what=f"the workspace drawn by Rerun's web viewer (last: {shot})")
            pictures = [b""]

            def settled() -> bool:  # the whole recording is in: two pictures alike
                pictures.append(page.screenshot(timeout=120_000))
                return pictures[-1] == pictures[-2]

            wait_until(settled, timeout=180, interval=3.0, what="the viewer's picture settled")
            shot.write_bytes(pictures[-1])
        finally:
            page.close()
    sent = {urlsplit(u).hostname for u in finished}
    assert sent and all(host.startswith(LOOPBACK) for host in sent), sent
