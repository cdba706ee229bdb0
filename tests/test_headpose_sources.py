"""Frame sources, whole-video tracks, the background stream and the preview overlay."""

from __future__ import annotations

import re
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.headpose import (
    CameraStream,
    HeadPoseEstimator,
    HeadPoseSourceError,
    HeadPoseTrack,
    draw_overlay,
    open_camera,
    open_video,
    track_video,
)
from app.headpose.synthetic import ASTRONAUT_FACE_CENTRE, place_face
from tests.conftest import wait_until

N_FRAMES = 24
FPS = 30.0
MISSING_CAMERA = 99


@pytest.fixture(scope="module")
def face_video(tmp_path_factory) -> Path:
    """An MJPG video of the astronaut's face tilting from -10 to +10 degrees."""
    from skimage.data import astronaut

    face = np.ascontiguousarray(astronaut()[:, :, ::-1])
    path = tmp_path_factory.mktemp("headpose") / "face.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (640, 480))
    assert writer.isOpened()
    for roll in np.linspace(-10, 10, N_FRAMES):
        writer.write(place_face(face, ASTRONAUT_FACE_CENTRE, (640, 480), roll_deg=roll, scale=1.5))
    writer.release()
    return path


@pytest.fixture
def corrupt_video(tmp_path) -> Path:
    path = tmp_path / "corrupt.mp4"
    path.write_bytes(np.random.default_rng(3).integers(0, 256, 20_000, dtype=np.uint8).tobytes())
    return path


def test_video_source_yields_timestamped_frames(face_video):
    with open_video(face_video) as source:
        assert source.fps == pytest.approx(FPS)
        assert source.frame_count == N_FRAMES
        items = list(source)
    assert len(items) == N_FRAMES
    times = np.array([t for t, _ in items])
    np.testing.assert_allclose(times, np.arange(N_FRAMES) / FPS)
    assert all(frame.shape == (480, 640, 3) and frame.dtype == np.uint8 for _, frame in items)
    assert source.closed


def test_track_video_gives_one_sample_per_frame(installed, face_video):
    progress: list[float] = []
    track = track_video(face_video, progress=progress.append)
    assert isinstance(track, HeadPoseTrack) and len(track) == N_FRAMES
    assert np.all(np.diff(track.t) > 0)
    assert track.face_found.all() and np.all(track.confidence > 0.3)
    assert track.angles.shape == (N_FRAMES, 3)
    # the video tilts the face by 20 degrees: the roll follows, smoothed but in the right order
    assert np.degrees(track.roll[-1] - track.roll[0]) > 12
    assert progress[-1] == 1.0 and progress == sorted(progress) and len(progress) >= N_FRAMES // 2
    assert str(face_video) in track.source


def test_track_video_from_uploaded_bytes(installed, face_video):
    estimator = HeadPoseEstimator()
    from_path = track_video(face_video, estimator=estimator)
    from_bytes = track_video(face_video.read_bytes(), estimator=estimator, suffix=".avi")
    np.testing.assert_allclose(from_bytes.t, from_path.t)
    np.testing.assert_allclose(from_bytes.angles, from_path.angles, atol=1e-9)
    assert from_bytes.source.startswith("uploaded video")


def test_corrupt_or_missing_video_is_a_clear_error(installed, corrupt_video, tmp_path):
    name = re.escape(f"video {corrupt_video}: ")
    with pytest.raises(HeadPoseSourceError, match=f"{name}.*(corrupt|unsupported)"):
        open_video(corrupt_video)
    with pytest.raises(HeadPoseSourceError, match="uploaded video .*(corrupt|unsupported)"):
        track_video(corrupt_video.read_bytes())
    missing = tmp_path / "missing.mp4"
    with pytest.raises(HeadPoseSourceError, match=re.escape(f"video {missing}: no such file")):
        track_video(missing)
    with pytest.raises(ValueError, match="suffix"):
        track_video(b"", suffix="/../x")


def test_missing_camera_is_a_clear_error():
    with pytest.raises(HeadPoseSourceError, match=f"camera {MISSING_CAMERA}: cannot be opened"):
        open_camera(MISSING_CAMERA)
    with pytest.raises(ValueError, match="camera index"):
        open_camera(-1)


def test_stream_processes_a_video_in_the_background(installed, face_video):
    with CameraStream(face_video, realtime=False) as stream:
        wait_until(lambda: stream.finished, timeout=30, what="the stream to end")
        assert stream.error is None
        sample = stream.latest()
        assert sample is not None and sample.face_found
        assert sample.t == pytest.approx((N_FRAMES - 1) / FPS)
        preview = stream.latest_preview()
        assert preview.shape == (480, 640, 3) and preview.dtype == np.uint8
        samples = stream.drain()
        assert len(samples) == N_FRAMES and stream.drain() == []
        stream.calibrate_neutral()
    assert not stream.running


@pytest.fixture(scope="module")
def long_video(tmp_path_factory) -> tuple[Path, int]:
    """A 10 s video of small grey frames (no face: only the pacing matters) and its length."""
    path = tmp_path_factory.mktemp("headpose") / "long.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (160, 120))
    n_frames = int(10 * FPS)
    for i in range(n_frames):
        writer.write(np.full((120, 160, 3), i % 256, dtype=np.uint8))
    writer.release()
    return path, n_frames


def test_stream_paces_a_video_and_closes_early(installed, long_video):
    """Frames are processed no faster than the video plays, and close() stops at once: both
    measured against the time that really passed, so that a busy machine changes nothing."""
    path, n_frames = long_video
    created = time.monotonic()
    stream = CameraStream(path, realtime=True)
    wait_until(lambda: stream.latest() is not None, timeout=60, what="the first frame")
    closing = time.monotonic()
    stream.close()
    closed = time.monotonic()
    assert stream.finished and stream.error is None
    n = len(stream.drain())
    assert 1 <= n <= (closed - created) * FPS + 1, (n, closed - created)  # paced
    assert closed - closing < 5.0 and n < n_frames  # not played to its end (10 s)


def test_stream_on_a_missing_camera_reports_the_error(installed):
    stream = CameraStream(MISSING_CAMERA)
    wait_until(lambda: stream.finished, timeout=10, what="the stream to fail")
    assert isinstance(stream.error, HeadPoseSourceError)
    assert f"camera {MISSING_CAMERA}" in str(stream.error)
    assert stream.latest() is None and stream.latest_preview() is None
    stream.close()


def test_overlay_draws_on_a_copy(installed, face_video):
    with open_video(face_video) as source:
        t, frame = source.read()
    original = frame.copy()
    estimator = HeadPoseEstimator()
    sample = estimator.process(frame, t)
    drawn = draw_overlay(frame, sample)
    np.testing.assert_array_equal(frame, original)
    assert drawn.shape == frame.shape
    changed = np.any(drawn != frame, axis=2)
    nose = np.rint(sample.landmarks[1]).astype(int)
    assert changed[nose[1] - 3 : nose[1] + 4, nose[0] - 3 : nose[0] + 4].any()
    assert changed[:40, :300].any()  # the angles, top left
    assert np.any(draw_overlay(frame, None) != frame)  # "no face"


def test_track_arrays_must_agree():
    with pytest.raises(ValueError, match="roll must have shape"):
        HeadPoseTrack(
            t=np.zeros(3),
            roll=np.zeros(2),
            pitch=np.zeros(3),
            yaw=np.zeros(3),
            confidence=np.zeros(3),
            face_found=np.zeros(3, bool),
        )
