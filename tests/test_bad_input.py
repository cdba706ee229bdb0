"""Bad input, counted: every loader and upload path is fed a generated corpus of malformed inputs
(``tests/bad_inputs.py``, plus hypothesis fuzzing where it fits), and each must be refused with a
``ValueError`` (a head-pose source error for videos) whose message names the problem, while the
workspace stays byte-identical. Anything else (another exception, or the input accepted) is a
crash. The module's tally is written to ``artifacts/bad_input.json`` (the README's figures).
"""

from __future__ import annotations

import hashlib
import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.headpose.frames import HeadPoseSourceError, track_video
from app.io.dataset_import import extract_dataset_zip
from app.io.exchange import Limits, read_upload, workspace_zip
from app.io.workspace import Workspace, WorkspaceData
from app.io.workspace_index import PALETTE, PrimitiveEntry
from promp.datasets import demo_from_csv, demo_to_csv, read_record
from promp.demo_npz import demo_from_npz_bytes
from promp.evidence.pipeline import infer
from promp.inference import Observation
from promp.io import model_to_json
from promp.learn import fit
from promp.model import Settings
from robots.icub.layout import STUDIO_LAYOUT as LAYOUT
from tests import bad_inputs
from tests.conftest import GIVEN_SETTINGS, StudioSpec
from tests.synthetic import make_dataset

TALLY: Counter = Counter()
CRASHES: list[str] = []


@pytest.fixture(scope="module", autouse=True)
def tally(artifacts):
    """Writes what the module tried to ``artifacts/bad_input.json`` when it ends."""
    TALLY.clear()
    CRASHES.clear()
    yield TALLY
    paths = sorted({path for path, _ in TALLY})
    summary = {
        "inputs_tried": sum(TALLY[(p, "tried")] for p in paths),
        "refused_cleanly": sum(TALLY[(p, "refused")] for p in paths),
        # fuzzed inputs that happen to be valid (e.g. a changed unit name) load as valid files
        "accepted_as_valid": sum(TALLY[(p, "valid")] for p in paths),
        "crashes": len(CRASHES),
        "per_path": {
            p: {k: TALLY[(p, k)] for k in ("tried", "refused", "valid") if TALLY[(p, k)]}
            for p in paths
        },
    }
    (artifacts / "bad_input.json").write_text(json.dumps(summary, indent=1))


def tree_hash(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def refuse(
    path: str,
    case: str,
    expected: str,
    action: Callable[[], object],
    errors: tuple[type[BaseException], ...] = (ValueError,),
) -> str | None:
    """Run ``action``; None when it is refused by one of ``errors`` with a message that holds
    ``expected``, else what went wrong (and the case is counted as a crash)."""
    TALLY[(path, "tried")] += 1
    try:
        action()
    except errors as exc:
        message = str(exc)
        if not message.strip():
            problem = "refused without saying why"
        elif expected and expected not in message.lower():
            problem = f"refused, but the message does not say {expected!r}: {message}"
        else:
            TALLY[(path, "refused")] += 1
            return None
    except Exception as exc:  # noqa: BLE001 - any other exception is what this module hunts
        problem = f"crashed with {type(exc).__name__}: {exc}"
    else:
        problem = "accepted"
    CRASHES.append(f"{path} / {case}: {problem}")
    return f"{case}: {problem}"


def run_corpus(path: str, cases, action, errors=(ValueError,)) -> None:
    problems = [
        p
        for case, payload, expected in cases
        if (p := refuse(path, case, expected, lambda payload=payload: action(payload), errors))
    ]
    assert not problems, "\n".join(problems)


# ------------------------------------------------------------------------------ fixtures


@pytest.fixture(scope="module")
def dataset():
    return make_dataset(seed=5, n_demos=4)


@pytest.fixture(scope="module")
def model(dataset):
    return fit(dataset, LAYOUT, Settings())


@pytest.fixture
def workspace(tmp_path, dataset):
    """A studio workspace on disk, and its checksums before the test."""
    data = WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset,
        settings={},
    )
    root = tmp_path / "ws"
    Workspace.create(root, data)
    before = tree_hash(root)
    yield root
    assert tree_hash(root) == before, "a refused input changed the workspace"


def make_csv(dataset) -> Callable[[int], bytes]:
    demos = [d for items in dataset.values() for d in items]

    def make(seed: int) -> bytes:
        return demo_to_csv(demos[seed % len(demos)]).encode()

    return make


# ------------------------------------------------------------------------------ the paths


def test_model_files(model, workspace) -> None:
    valid = model_to_json(model).encode()
    read_upload("model.json", valid)  # the corpus is made of mutations of a valid file
    run_corpus("model JSON", bad_inputs.model_cases(valid),
               lambda content: read_upload("model.json", content))  # fmt: skip
    limits = Limits(max_upload_bytes=len(valid) - 1)
    run_corpus("model JSON", [("over the limit", valid, "upload limit")],
               lambda content: read_upload("model.json", content, limits))  # fmt: skip


def test_workspace_archives(dataset, model, workspace) -> None:
    data = Workspace(workspace).load()
    archive = workspace_zip(data, model)
    import io
    import zipfile

    with zipfile.ZipFile(io.BytesIO(archive)) as z:
        members = {name: z.read(name) for name in z.namelist()}
    read_upload("workspace.zip", bad_inputs.zip_of(members))
    run_corpus(
        "workspace zip",
        bad_inputs.workspace_zip_cases(members, make_csv(dataset)),
        lambda content: read_upload("workspace.zip", content),
    )
    limits = Limits(max_upload_bytes=len(archive) - 1)
    tight = Limits(max_uncompressed_bytes=1000)
    few = Limits(max_members=2)
    run_corpus("workspace zip", [("over the limit", archive, "upload limit")],
               lambda content: read_upload("workspace.zip", content, limits))  # fmt: skip
    run_corpus("workspace zip", [("expands too far", archive, "expands")],
               lambda content: read_upload("workspace.zip", content, tight))  # fmt: skip
    run_corpus("workspace zip", [("too many members", archive, "entries")],
               lambda content: read_upload("workspace.zip", content, few))  # fmt: skip
    run_corpus("workspace zip", [("wrong extension", archive, "expected a model")],
               lambda content: read_upload("workspace.tar", content))  # fmt: skip


def test_dataset_imports(dataset, workspace, heights_record) -> None:
    def extract_and_read(content: bytes) -> None:
        upload = extract_dataset_zip(content, "dataset.zip")
        try:
            upload.read()
        finally:
            upload.close()

    cases = list(bad_inputs.dataset_zip_cases(make_csv(dataset), heights_record))
    run_corpus("dataset import", cases, extract_and_read)
    limits = Limits(max_upload_bytes=10)
    run_corpus("dataset import", [("over the limit", cases[-1][1], "upload limit")],
               lambda content: extract_dataset_zip(content, "dataset.zip", limits))  # fmt: skip
    run_corpus("dataset import", [("not a .zip", cases[-1][1], ".zip")],
               lambda content: extract_dataset_zip(content, "dataset.rar"))  # fmt: skip


def test_csv_demonstrations(dataset) -> None:
    valid = demo_to_csv(dataset["left"][0])
    demo_from_csv(valid)
    run_corpus("CSV demo", bad_inputs.csv_cases(valid), demo_from_csv)


def test_npz_demonstrations(dataset) -> None:
    demo = dataset["left"][0]
    run_corpus(
        "NPZ demo", bad_inputs.npz_cases(demo.times, demo.values, demo.columns),
        demo_from_npz_bytes,
    )  # fmt: skip


def test_lab_records(tmp_path, heights_record) -> None:
    path = tmp_path / "record.txt"
    path.write_bytes(heights_record)
    read_record(path)

    def read(text: str) -> None:
        path.write_text(text)
        read_record(path)

    run_corpus("lab record", bad_inputs.record_cases(heights_record.decode()), read)


def test_rig_recordings(tmp_path) -> None:
    """Each rig format's session spoilt (truncated, random bytes), and recordings that read
    but cannot be used (a wrong topic, a clock that goes back, an unknown marker, a stream that
    stops, an iCub dump's port that starts too late): refused with the file named, and nothing
    written next to them."""
    for library in ("rosbags", "pyxdf", "ezc3d"):
        pytest.importorskip(library)
    from promp.datasets import parse_modalities, read_dataset
    from tests import rig_files as rf

    made = tmp_path / "made"
    rf.write_ros2_bag(made / "ros2")
    rf.write_ros1_bag(made / "session.bag")
    rf.write_xdf(made / "session.xdf")
    rf.write_c3d(made / "session.c3d")
    rf.write_yarp_session(made / "yarp" / "session")

    def files(folder) -> dict[str, bytes]:
        return {p.relative_to(folder).as_posix(): p.read_bytes()
                for p in sorted(folder.rglob("*")) if p.is_file()}  # fmt: skip

    mcap = next((made / "ros2").glob("*.mcap"))
    hand = "hand=/hand:pose.position.{x,y,z}"
    yarp = "hand=left_arm:0,1,2@m; head=head:0,1,2@deg"
    recordings = {
        "rosbag": ({"session.mcap": mcap.read_bytes()}, "session.mcap", hand),
        "rosbag ROS 1": ({"session.bag": (made / "session.bag").read_bytes()}, "session.bag",
                         "hand=/tf:left_hand.translation.{x,y,z}"),
        "xdf": ({"session.xdf": (made / "session.xdf").read_bytes()}, "session.xdf", ""),
        "c3d": ({"session.c3d": (made / "session.c3d").read_bytes()}, "session.c3d", ""),
        "yarp": (files(made / "yarp"), "session/left_arm/data.log", yarp),
    }  # fmt: skip
    counter = iter(range(10**6))

    def read(payload) -> None:
        format, members, mapping = payload
        root = tmp_path / f"case{next(counter)}"
        for name, content in members.items():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_bytes(content)
        before = tree_hash(root)
        try:
            read_dataset(root, format.split()[0], parse_modalities(mapping) if mapping else None)
        finally:
            assert tree_hash(root) == before, "reading a recording wrote next to it"

    back = [line.split(" ") for line in recordings["yarp"][0]["session/head/data.log"]
            .decode().splitlines()]  # fmt: skip
    back[40][1], back[41][1] = back[41][1], back[40][1]  # two time stamps swapped
    swapped = {**recordings["yarp"][0], "session/head/data.log": "\n".join(
        " ".join(line) for line in back).encode()}  # fmt: skip
    rf.write_xdf(made / "marker.xdf", markers=[*rf.MARKERS, (10.4, "applause")])
    rf.write_ros2_bag(made / "stops", head_duration=5.0)
    stops = {"session.mcap": next((made / "stops").glob("*.mcap")).read_bytes()}
    late = files(rf.write_icub_dump(made / "late", {"reach": 2}, delay=0.15 * rf.ICUB_TAKE_S))
    cases = [
        *bad_inputs.rig_cases(recordings),
        ("rosbag: a wrong topic", ("rosbag", recordings["rosbag"][0],
                                   "hand=/nope:pose.position.x"), "no numeric stream '/nope'"),
        ("yarp: a clock that goes back", ("yarp", swapped, yarp), "not monotonic"),
        ("xdf: an unknown marker", ("xdf", {"session.xdf": (made / "marker.xdf").read_bytes()},
                                    ""), "unknown marker 'applause'"),
        ("rosbag: a stream that stops", ("rosbag", stops, f"{hand}; head=/head:pose.position.x"),
         "stream '/head' stops"),
        ("yarp: a port 15 % of the take late", ("yarp", late, ""),
         "stream 'cartesianendeffectorwrench' starts at 1.350 s"),
    ]  # fmt: skip
    run_corpus("rig recording", cases, read)


def test_video_uploads(installed, tmp_path) -> None:
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for k in range(10):
        writer.write(np.full((48, 64, 3), 20 * k, dtype=np.uint8))
    writer.release()
    run_corpus("video upload", bad_inputs.video_cases(path.read_bytes()),
               lambda content: track_video(content, suffix=".mp4"),
               errors=(ValueError, HeadPoseSourceError))  # fmt: skip


def test_observations(model) -> None:
    def run(triple) -> None:
        infer(model, Observation(*triple))

    run_corpus("observation", bad_inputs.observation_cases(3), run)


# ------------------------------------------------------------------------------ in the studio


def _studio_workspace(root, request) -> None:
    """The module's dataset, learned with the settings given (no browser: the upload
    callbacks are called as viser calls them; the studio's notices are what it said)."""
    dataset = request.getfixturevalue("dataset")
    Workspace.create(root, WorkspaceData(
        primitives=[PrimitiveEntry(name, PALETTE[i]) for i, name in enumerate(dataset)],
        demos=dataset, settings=GIVEN_SETTINGS,
    ))  # fmt: skip


STUDIO = StudioSpec(make=_studio_workspace, ready=lambda studio: studio.session.wait_for_model())


def refused_in_the_gui(studio, path: str, cases, upload, title: str) -> None:
    """Each case given to ``upload(filename, content)`` (a GUI upload callback) is a red
    notification titled ``title...`` holding the expected fragment, and changes nothing."""
    store = studio.session.store
    root = store.state.workspace.root
    before, version = tree_hash(root), store.state.version

    def attempt(payload: bytes, expected: str) -> None:
        studio.notices.clear()
        upload(payload)
        red = [n for n in studio.notices if n[2] == "red" and n[0].startswith(title)]
        if not red:
            raise AssertionError(f"no refusal shown (notifications: {studio.notices})")
        raise ValueError(red[0][1])  # the refusal, checked by refuse() like any other

    problems = [
        p for case, payload, expected in cases
        if (p := refuse(path, case, expected,
                        lambda payload=payload, expected=expected: attempt(payload, expected)))
    ]  # fmt: skip
    assert not problems, "\n".join(problems)
    assert tree_hash(root) == before and store.state.version == version, "the workspace changed"


def test_the_data_tab_refuses_bad_model_and_workspace_files(studio, model, dataset) -> None:
    from app.panels.data.panel import DataPanel

    panel = next(p for p in studio.panels if isinstance(p, DataPanel))
    models = list(bad_inputs.model_cases(model_to_json(model).encode()))
    refused_in_the_gui(studio, "GUI model upload", models,
                       lambda c: panel.import_file(None, "m.json", c), "Cannot import")  # fmt: skip
    import io
    import zipfile

    root = studio.session.store.state.workspace.root
    with zipfile.ZipFile(io.BytesIO(workspace_zip(Workspace(root).load(), model))) as z:
        members = {name: z.read(name) for name in z.namelist()}
    archives = list(bad_inputs.workspace_zip_cases(members, make_csv(dataset)))
    refused_in_the_gui(studio, "GUI workspace upload", archives,
                       lambda c: panel.import_file(None, "ws.zip", c), "Cannot import")  # fmt: skip


def test_the_dataset_import_refuses_bad_zips(studio, dataset, heights_record) -> None:
    from app.panels.data.panel import DataPanel

    section = next(p for p in studio.panels if isinstance(p, DataPanel)).importer
    cases = list(bad_inputs.dataset_zip_cases(make_csv(dataset), heights_record))
    refused_in_the_gui(studio, "GUI dataset import", cases,
                       lambda c: section.receive(None, "mine.zip", c), "Cannot import")  # fmt: skip


def test_the_head_source_refuses_bad_videos(installed, studio, tmp_path) -> None:
    from app.panels.teach import TeachPanel
    from tests.conftest import wait_until

    head = next(p for p in studio.panels if isinstance(p, TeachPanel)).head
    source = studio.head.source
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for k in range(10):
        writer.write(np.full((48, 64, 3), 20 * k, dtype=np.uint8))
    writer.release()
    cases = [*bad_inputs.video_cases(path.read_bytes()),
             ("a video without a face", path.read_bytes(), "no face")]  # fmt: skip

    def upload(content: bytes) -> None:
        count = len(studio.notices)
        head.process("clip.mp4", content)
        wait_until(lambda: len(studio.notices) > count and not head.tracks.processing, timeout=60,
                   what="the video's outcome")  # fmt: skip

    refused_in_the_gui(studio, "GUI video upload", cases, upload, "Video not usable")
    assert studio.head.source is source  # the head source in use stays


# ------------------------------------------------------------------------------ fuzzing

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip


@FUZZ
@given(st.text(alphabet=st.sampled_from("t,xyz0123456789.-e\n naNif"), max_size=400))
def test_fuzzed_csv_text_is_parsed_or_refused(text: str) -> None:
    TALLY[("CSV demo (fuzzed)", "tried")] += 1
    try:
        demo = demo_from_csv(text)
    except ValueError as exc:
        assert str(exc).strip()
        TALLY[("CSV demo (fuzzed)", "refused")] += 1
    else:  # what is accepted is a valid demonstration
        assert demo.n_samples >= 2 and np.all(np.diff(demo.times) > 0)
        assert np.all(np.isfinite(demo.values))
        TALLY[("CSV demo (fuzzed)", "valid")] += 1


JSON = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=4),
    max_leaves=20,
)  # fmt: skip


@FUZZ
@given(data=st.data())
def test_fuzzed_model_fields_are_refused(model, data) -> None:
    """A valid model file with one field anywhere in it replaced by random JSON."""
    doc = json.loads(model_to_json(model))
    path, node = [], doc
    while isinstance(node, (dict, list)) and node:
        key = data.draw(st.sampled_from(sorted(node) if isinstance(node, dict)
                                        else list(range(len(node)))))  # fmt: skip
        path.append(key)
        if data.draw(st.booleans()):
            break
        node = node[key]
    value = data.draw(JSON)
    target = doc
    for key in path[:-1]:
        target = target[key]
    if not path or target[path[-1]] == value:
        return
    target[path[-1]] = value
    content = json.dumps(doc).encode()
    TALLY[("model JSON (fuzzed)", "tried")] += 1
    try:
        read_upload("model.json", content)
    except ValueError as exc:
        assert str(exc).strip()
        TALLY[("model JSON (fuzzed)", "refused")] += 1
    except Exception as exc:  # noqa: BLE001
        CRASHES.append(f"model JSON (fuzzed) / {path}: {type(exc).__name__}: {exc}")
        raise
    else:
        # Accepted: the replaced field was one the reader may ignore (e.g. the report) or a
        # value it may take (a unit's name, a ridge); it loaded as a valid model.
        TALLY[("model JSON (fuzzed)", "valid")] += 1


def test_no_crash_in_the_whole_corpus() -> None:
    """Runs last in this module: the tally of every path above."""
    assert not CRASHES, "\n".join(CRASHES)
    assert sum(v for k, v in TALLY.items() if k[1] == "tried") > 300


# ------------------------------------------------------------------------------ data


@pytest.fixture(scope="module")
def heights_record() -> bytes:
    """One real lab record when the shared data is there, else a synthetic one in its format."""
    from tests.conftest import HEIGHTS

    files = sorted(HEIGHTS.rglob("*.txt")) if HEIGHTS.exists() else []
    if files:
        return files[0].read_bytes()
    rng = np.random.default_rng(0)
    t = np.arange(50) * 0.01
    table = np.column_stack([t, rng.normal(size=(50, 12)) * 0.1])
    return ("\n".join(" ".join(f"{v:.6f}" for v in row) for row in table) + "\n").encode()


# ------------------------------------------------------------------------------ live sessions


@pytest.fixture(scope="module")
def hand_model(dataset):
    from promp.data import Layout

    return fit(dataset, Layout((LAYOUT.modality("hand"),)), Settings())


def test_live_inputs(hand_model) -> None:
    from promp.live.session import LiveSession
    from tests.live_fakes import FakeTransport

    run_corpus("live input (--in)", bad_inputs.live_input_cases(),
               lambda spec: LiveSession(hand_model, [spec], FakeTransport()))  # fmt: skip


def test_live_journals(tmp_path) -> None:
    from promp.live.journal import Journal, read_journal

    journal = Journal(tmp_path / "valid.journal", ("x", "y", "z"), "take", "", 10.0)
    journal.append(10.0 + np.arange(4) * 0.01, np.arange(12.0).reshape(4, 3))
    journal.close()
    valid = (tmp_path / "valid.journal").read_bytes()
    read_journal(tmp_path / "valid.journal")

    def read(content: bytes) -> None:
        path = tmp_path / "case.journal"
        path.write_bytes(content)
        read_journal(path)

    run_corpus("live journal", bad_inputs.journal_cases(valid), read)


def test_live_samples_are_left_out_with_a_status(hand_model) -> None:
    """A chunk no session can use is not refused by raising (a live session never stops): its
    samples are left out, the stream's status says why, the movement's rows stay valid."""
    from promp.live.session import LiveOptions, LiveSession
    from tests.live_fakes import FakeStream, FakeTransport

    problems = []
    for case, (times, values), expected in bad_inputs.live_sample_cases(3):
        TALLY[("live samples", "tried")] += 1
        transport = FakeTransport(now=0.0)
        stream = transport.add(FakeStream("Hand", ("x", "y", "z")))
        session = LiveSession(hand_model, ["hand=Hand:0,1,2"], transport,
                              LiveOptions(start="call"))  # fmt: skip
        session.connect()
        session.begin(time=0.0)
        stream.push(np.arange(10) * 0.01, np.random.default_rng(0).normal(size=(10, 3)) * 0.01)
        transport.now = 0.1
        try:
            session.step()
            stream.pending.append((np.asarray(times), np.asarray(values)))
            transport.now = 0.2
            session.step()
        except Exception as exc:  # a crash is what this test counts
            CRASHES.append(f"live samples / {case}: {type(exc).__name__}: {exc}")
            problems.append(case)
            continue
        snap = session.snapshot()
        rows = snap.movement if snap.movement is not None else snap.ended[-1]
        texts = " ".join(e.text for e in snap.events)
        valid = np.all(np.isfinite(rows.values)) and np.all(np.diff(rows.times) > 0)
        if not valid or expected not in texts:
            problems.append(f"{case}: {texts}")
            CRASHES.append(f"live samples / {case}: not said or not valid ({texts})")
            continue
        TALLY[("live samples", "refused")] += 1
    assert not problems, problems
