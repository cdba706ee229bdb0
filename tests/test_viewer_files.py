"""promp.viewers: a log of every kind of item written to Rerun (``.rrd``) and MCAP (Foxglove's
schemas) reads back, with the tools' own readers, as the items it was written from; the regions'
ellipsoids are the regions; bad input is refused and nothing is overwritten."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from promp.region import region_radius
from promp.viewers.formats import viewer_file_bytes, write_viewer_file
from promp.viewers.regions import region_ellipsoids
from promp.viewers.scene_log import (
    Event,
    Mesh,
    Model,
    Note,
    Points,
    SceneLog,
    Series,
    Stamp,
    Strips,
    Timeline,
)
from tests.viewer_readers import json_series, points, read_mcap, read_rrd, scene_entities

SECONDS = Timeline("demo_time", "seconds", "seconds from the start of each demonstration")
STEPS = Timeline("observed_percent", "sequence", "the percent observed")
RNG = np.random.default_rng(3)


def _glb() -> bytes:
    return trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(file_type="glb")


def _covariances(n: int) -> np.ndarray:
    a = RNG.normal(size=(n, 3, 3)) * 0.02
    return a @ a.transpose(0, 2, 1) + 1e-5 * np.eye(3)


MEAN = np.cumsum(RNG.normal(size=(30, 3)) * 0.01, axis=0)
COV = _covariances(30)
STRIP = RNG.normal(size=(7, 3))
SERIES_T = np.array([0.0, 0.25, 0.5, 0.75])
SERIES_V = np.array([0.1, np.nan, -0.3, 0.4])


def the_log() -> SceneLog:
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    return SceneLog("test-log", (SECONDS, STEPS), (
        Note("about", "# Hello\nunits: m"),
        Strips("demos/reach/d-1", (STRIP, STRIP[:3] + 1.0), (10, 20, 30), 0.004),
        Points("demos/reach/d-1/hand", STRIP[2:3], (200, 100, 0), 0.01, Stamp("demo_time", 0.5)),
        Mesh("priors/reach", mesh.vertices, mesh.faces, (1, 2, 3), 0.25),
        region_ellipsoids("trial/region", MEAN, COV, 0.9, (9, 8, 7), Stamp("observed_percent", 40)),
        Model("robot", _glb()),
        Series("demos/reach/d-1/hand/x", "hand x", "m", "demo_time", SERIES_T, SERIES_V),
        Event("events", "movement start", Stamp("demo_time", 0.25)),
    ))  # fmt: skip


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    folder = tmp_path_factory.mktemp("viewer_files")
    log = the_log()
    return (log, write_viewer_file(log, folder / "log.rrd"),
            write_viewer_file(log, folder / "log.mcap"))  # fmt: skip


def _rgba(value: int) -> tuple[int, int, int, int]:
    return tuple(int(value) >> s & 0xFF for s in (24, 16, 8, 0))  # type: ignore[return-value]


def test_rerun_reads_back_every_item_at_its_time(written) -> None:
    log, rrd, _ = written
    entities = read_rrd(rrd)
    items = {item.path: item for item in log.items}
    assert entities[""].static["ViewCoordinates:xyz"] == [[3, 5, 1]]  # RIGHT_HAND_Z_UP: x F y L z U
    assert "# Hello" in entities["about"].static["TextDocument:text"][0]
    strips = entities["demos/reach/d-1"].static
    for got, want in zip(strips["LineStrips3D:strips"], items["demos/reach/d-1"].strips,
                         strict=True):  # fmt: skip
        assert_allclose(got, want, rtol=1e-6, atol=1e-7)
    assert _rgba(strips["LineStrips3D:colors"][0]) == (10, 20, 30, 255)
    hand = entities["demos/reach/d-1/hand"]
    assert [t for t, _ in hand.rows] == [{"demo_time": 500_000_000}]  # 0.5 s, in ns
    assert_allclose(hand.rows[0][1]["Points3D:positions"], STRIP[2:3], rtol=1e-6)
    mesh = entities["priors/reach"].static
    assert_allclose(mesh["Mesh3D:vertex_positions"], items["priors/reach"].vertices, atol=1e-7)
    assert np.array_equal(mesh["Mesh3D:triangle_indices"], items["priors/reach"].faces)
    assert _rgba(mesh["Mesh3D:albedo_factor"][0]) == (1, 2, 3, 64)
    region = entities["trial/region"].at("observed_percent", 40)
    want = items["trial/region"]
    assert_allclose(region["Ellipsoids3D:centers"], want.centers, atol=1e-7)
    assert_allclose(region["Ellipsoids3D:half_sizes"], want.half_axes, rtol=1e-6)
    rotations = Rotation.from_quat(region["Ellipsoids3D:quaternions"]).as_matrix()
    assert_allclose(rotations, want.rotations, atol=1e-6)
    assert entities["robot"].static["Asset3D:blob"][0] == list(_glb())
    times, values = entities["demos/reach/d-1/hand/x"].series("demo_time")
    assert_allclose(times, SERIES_T * 1e9)
    assert_allclose(values, SERIES_V)  # NaN where there is none
    assert entities["demos/reach/d-1/hand/x"].static["SeriesLines:names"] == ["hand x (m)"]
    [(when, event)] = entities["events"].rows
    assert when == {"demo_time": 250_000_000} and event["TextLog:text"] == ["movement start"]
    timelines = {t for e in entities.values() for times, _ in e.rows for t in times}
    assert timelines == {"demo_time", "observed_percent"}  # no wall clock (log_time)


def test_mcap_holds_the_same_entities_and_series_for_foxglove(written) -> None:
    log, _, mcap = written
    messages, metadata = read_mcap(mcap)
    items = {item.path: item for item in log.items}
    entities = scene_entities(messages)
    assert set(entities) == {p for p, i in items.items()
                             if not isinstance(i, Note | Series | Event)}  # fmt: skip
    [event] = [m for m in messages if m.topic == "/events"]
    assert event.schema == "foxglove.Log" and event.log_time == 250_000_000
    assert event.message.message == "movement start"
    assert {m.topic for m in messages if m.schema == "foxglove.SceneUpdate"} == {
        "/demos/reach", "/demos/reach/d-1", "/priors", "/trial", "/scene"}  # fmt: skip
    [(t, strip)] = entities["demos/reach/d-1"]
    assert t == 0 and strip.frame_id == "root_link"  # static: at the start
    assert_allclose(points(strip.lines[0].points), STRIP)
    assert_allclose(points(strip.lines[1].points), STRIP[:3] + 1.0)
    assert strip.lines[0].color.r == pytest.approx(10 / 255)
    [(t, hand)] = entities["demos/reach/d-1/hand"]
    assert t == 500_000_000 and hand.spheres[0].size.x == pytest.approx(0.02)
    [(_, mesh)] = entities["priors/reach"]
    triangles = mesh.triangles[0]
    assert_allclose(points(triangles.points), items["priors/reach"].vertices)
    assert list(triangles.indices) == items["priors/reach"].faces.reshape(-1).tolist()
    assert triangles.color.a == pytest.approx(0.25)
    [(t, region)] = entities["trial/region"]
    assert t == 40 * 1_000_000_000  # a step of a sequence is a second
    want = items["trial/region"]
    for sphere, c, a, r in zip(region.spheres, want.centers, want.half_axes, want.rotations,
                               strict=True):  # fmt: skip
        p, q = sphere.pose.position, sphere.pose.orientation
        assert_allclose([p.x, p.y, p.z], c)
        assert_allclose([sphere.size.x, sphere.size.y, sphere.size.z], 2 * a)
        assert_allclose(Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix(), r, atol=1e-9)
    [(_, robot)] = entities["robot"]
    assert robot.models[0].data == _glb() and robot.models[0].media_type == "model/gltf-binary"
    times, values = json_series(messages, "/demos/reach/d-1/hand/x", "demo_time")
    assert_allclose(times, SERIES_T)
    assert_allclose(values, SERIES_V)  # NaN written as null
    assert {"about": "# Hello\nunits: m"} in metadata["notes"]
    assert "seconds" in metadata["timelines"][0]["demo_time"]
    download = viewer_file_bytes(log, ".mcap")  # the studio's download: the same format
    assert io.BytesIO(download).read(8) == b"\x89MCAP0\r\n"


def test_a_region_ellipsoid_is_the_region_s_boundary() -> None:
    """Points on each ellipsoid's surface are at the region's Mahalanobis radius."""
    item = region_ellipsoids("r", MEAN, COV, 0.9, (0, 0, 0), n=7)
    chosen = np.round(np.linspace(0, len(MEAN) - 1, 7)).astype(int)
    assert_allclose(item.centers, MEAN[chosen])
    directions = RNG.normal(size=(3, 20))
    directions /= np.linalg.norm(directions, axis=0)
    for k, i in enumerate(chosen):
        surface = item.centers[k][:, None] + item.rotations[k] @ (item.half_axes[k][:, None]
                                                                  * directions)  # fmt: skip
        r = surface - MEAN[i][:, None]
        d2 = np.einsum("in,in->n", r, np.linalg.solve(COV[i], r))
        assert_allclose(d2, region_radius(0.9, 3) ** 2, rtol=1e-9)


def test_an_existing_file_is_never_overwritten(tmp_path) -> None:
    log = the_log()
    for name in ("a.rrd", "a.mcap"):
        path = tmp_path / name
        path.write_bytes(b"mine")
        with pytest.raises(ValueError, match="already exists"):
            write_viewer_file(log, path)
        assert path.read_bytes() == b"mine"
    with pytest.raises(ValueError, match=r"\.rrd"):
        write_viewer_file(log, tmp_path / "b.mcap", ".rrd")
    with pytest.raises(ValueError, match=r"\.rrd or \.mcap"):
        write_viewer_file(log, tmp_path / "b.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mcap", "a.rrd"]  # no temporary left


def test_a_missing_library_names_the_extra(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "rerun", None)
    monkeypatch.setitem(sys.modules, "foxglove", None)
    with pytest.raises(ValueError, match=r"\[rerun\].*rerun-sdk"):
        write_viewer_file(the_log(), tmp_path / "a.rrd")
    with pytest.raises(ValueError, match=r"\[mcap\].*foxglove-sdk"):
        write_viewer_file(the_log(), tmp_path / "a.mcap")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: Strips("a//b", (STRIP,), (0, 0, 0)), "path"),
        (lambda: Strips("a", (STRIP[:1],), (0, 0, 0)), "two points"),
        (lambda: Strips("a", (STRIP,), (0, 0, 300)), "colour"),
        (lambda: Mesh("a", STRIP, [[0, 1, 9]], (0, 0, 0)), "vertex"),
        (lambda: Points("a", [[0.0, np.nan, 0.0]], (0, 0, 0)), "finite"),
        (lambda: Model("a", b"not a glb"), "glTF"),
        (lambda: SceneLog("x", (STEPS,), (Points("a", STRIP, (0, 0, 0),
                                                 at=Stamp("observed_percent", 4.5)),)), "whole"),
        (lambda: SceneLog("x", (STEPS,), (Points("a", STRIP, (0, 0, 0),
                                                 at=Stamp("elsewhere", 1)),)), "no timeline"),
        (lambda: region_ellipsoids("r", MEAN, -COV, 0.9, (0, 0, 0)), "semi-definite"),
        (lambda: region_ellipsoids("r", MEAN, COV, 1.5, (0, 0, 0)), "probability"),
    ],
)  # fmt: skip
def test_bad_items_are_refused(make, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def test_rerun_opens_with_the_camera_and_a_plot_per_unit(tmp_path) -> None:
    """The recording's layout (its blueprint, read by Rerun's reader): the 3-D view starts at
    the log's camera; the series are plotted by unit."""
    import dataclasses

    import rerun as rr

    log = dataclasses.replace(the_log(), camera=((1.0, -2.0, 0.5), (0.1, 0.0, 0.0)))
    reader = rr.chunk.RrdReader(write_viewer_file(log, tmp_path / "a.rrd"))
    [blueprint] = reader.blueprints()
    found: dict[str, list] = {}
    for chunk in reader.stream(store=blueprint):
        batch = chunk.to_record_batch()
        for name in ("ViewBlueprint:display_name", "EyeControls3D:position",
                     "EyeControls3D:look_target"):  # fmt: skip
            if name in batch.schema.names:
                found.setdefault(name, []).extend(batch.column(name).to_pylist())
    assert sorted(n[0] for n in found["ViewBlueprint:display_name"]) == ["3D (m)", "positions (m)"]
    assert_allclose(found["EyeControls3D:position"][0][0], (1.0, -2.0, 0.5))
    assert_allclose(found["EyeControls3D:look_target"][0][0], (0.1, 0.0, 0.0))


def test_rerun_s_own_mcap_reader_opens_the_mcap_file(written) -> None:
    """A reader we do not write, Rerun's, lists every topic with its Foxglove schema and
    decodes the scene messages."""
    import rerun as rr

    _, _, mcap = written
    reader = rr.chunk.McapReader(mcap)
    channels = {c.topic: c for c in reader.info().channels}
    assert {t for t, c in channels.items() if c.schema and c.schema.name == "foxglove.SceneUpdate"
            } == {"/demos/reach", "/demos/reach/d-1", "/priors", "/trial", "/scene"}  # fmt: skip
    assert channels["/demos/reach/d-1/hand/x"].message_encoding == "json"
    decoded = {chunk.entity_path for chunk in reader.stream()
               if "foxglove.SceneUpdate:message" in chunk.to_record_batch().schema.names}
    assert decoded == {"/demos/reach", "/demos/reach/d-1", "/priors", "/trial", "/scene"}


def test_writing_a_recording_sends_nothing_and_leaves_no_trace(tmp_path) -> None:
    """The SDK writes the file and nothing else: no analytics configuration or queue in the
    writer's home (Rerun's analytics live in the viewer, whose switch the manual gives)."""
    import os
    import subprocess

    home = tmp_path / "home"
    home.mkdir()
    env = dict(os.environ, HOME=str(home), XDG_CONFIG_HOME=str(home / ".config"),
               XDG_DATA_HOME=str(home / ".local"), XDG_CACHE_HOME=str(home / ".cache"))
    code = ("from tests.test_viewer_files import the_log\n"
            "from promp.viewers.formats import write_viewer_file\n"
            f"write_viewer_file(the_log(), {str(tmp_path / 'a.rrd')!r})\n")  # fmt: skip
    subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=300,
                   cwd=Path(__file__).resolve().parent.parent)  # fmt: skip
    assert (tmp_path / "a.rrd").stat().st_size > 0
    assert list(home.rglob("*")) == []

