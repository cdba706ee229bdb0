"""Head-pose speed: frames per second end to end (decode, detect, landmarks, PnP, filter).

Writes a 640x480 video of scikit-image's astronaut face drifting and tilting slightly into a
temporary folder, then, on one OpenCV thread, times each stage separately and the whole pipeline
over the decoded video. Target: >= 60 fps. The last line is one JSON object with ``fps``,
``landmarks_ms`` and ``detect_ms`` (medians), plus the other stages.

Run: ``.venv/bin/python bench/headpose.py [--frames 300] [--codec mp4v]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from app.headpose import HeadPoseEstimator, open_video
from app.headpose.face_model import MODEL_LANDMARKS
from app.headpose.landmarks import roi_from_detection, roi_from_landmarks
from app.headpose.pose import camera_matrix, solve_head_pose
from app.headpose.synthetic import ASTRONAUT_FACE_CENTRE, place_face

FRAME_SIZE = (640, 480)


def write_video(path: Path, n_frames: int, codec: str, fps: float = 30.0) -> None:
    """A face that drifts on a small circle, tilts by +-8 degrees and zooms by +-10 %."""
    from skimage.data import astronaut  # test/benchmark dependency only

    face = cv2.cvtColor(astronaut(), cv2.COLOR_RGB2BGR)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec), fps, FRAME_SIZE)
    if not writer.isOpened():
        raise RuntimeError(f"OpenCV cannot write {codec} video to {path}")
    for i in range(n_frames):
        phase = 2 * np.pi * i / 90
        centre = (320 + 40 * np.cos(phase), 240 + 25 * np.sin(phase))
        frame = place_face(
            face,
            ASTRONAUT_FACE_CENTRE,
            FRAME_SIZE,
            centre,
            8 * np.sin(phase / 2),
            1.5 + 0.15 * np.sin(phase / 3),
        )
        writer.write(frame)
    writer.release()


def median_ms(times: list[float]) -> float:
    return 1000.0 * statistics.median(times)


def main(frames: int = 300, codec: str = "mp4v") -> dict:
    """Run the benchmark and print its figures; returns the JSON summary."""
    cv2.setNumThreads(1)
    with tempfile.TemporaryDirectory(prefix="bench-headpose-") as folder:
        suffix = ".avi" if codec.upper() == "MJPG" else ".mp4"
        path = Path(folder) / f"astronaut{suffix}"
        write_video(path, frames, codec)
        estimator = HeadPoseEstimator()

        decoded = []
        decode_times = []
        with open_video(path) as source:
            while True:
                start = time.perf_counter()
                item = source.read()
                decode_times.append(time.perf_counter() - start)
                if item is None:
                    break
                decoded.append(item[1])
        decode_times.pop()  # the failed read at the end

        detect_times, landmark_times, pnp_times = [], [], []
        size = decoded[0].shape[1], decoded[0].shape[0]
        intrinsics = camera_matrix(*size)
        roi = None
        for frame in decoded:
            start = time.perf_counter()
            detections = estimator.tracker.detector.detect(frame)
            detect_times.append(time.perf_counter() - start)
            if roi is None and detections:
                roi = roi_from_detection(detections[0])
            if roi is None:
                continue
            start = time.perf_counter()
            result = estimator.tracker.landmarker.run(frame, roi)
            landmark_times.append(time.perf_counter() - start)
            start = time.perf_counter()
            solve_head_pose(result.landmarks[MODEL_LANDMARKS], intrinsics)
            pnp_times.append(time.perf_counter() - start)
            roi = roi_from_landmarks(result.landmarks)

        estimator.reset()
        found = 0
        start = time.perf_counter()
        with open_video(path) as source:
            for t, frame in source:
                found += estimator.process(frame, t).face_found
        elapsed = time.perf_counter() - start
        n = len(decoded)

    summary = {
        "fps": round(n / elapsed, 1),
        "landmarks_ms": round(median_ms(landmark_times), 3),
        "detect_ms": round(median_ms(detect_times), 3),
        "decode_ms": round(median_ms(decode_times), 3),
        "pnp_ms": round(median_ms(pnp_times), 3),
        "frames": n,
        "face_found": found,
        "detector_runs": estimator.tracker.n_detections,
        "codec": codec,
    }
    print(f"video: {n} frames {size[0]}x{size[1]} {codec}, one OpenCV thread")
    print(f"decode     median {summary['decode_ms']:.2f} ms/frame")
    print(f"detect     median {summary['detect_ms']:.2f} ms/frame (run on every frame here)")
    print(f"landmarks  median {summary['landmarks_ms']:.2f} ms/frame (crop + network)")
    print(f"pnp        median {summary['pnp_ms']:.2f} ms/frame (SQPnP + LM refinement)")
    print(
        f"end to end {summary['fps']:.1f} fps: face in {found}/{n} frames, detector ran on "
        f"{estimator.tracker.n_detections} (tracking otherwise); target >= 60 fps"
    )
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300, help="video length in frames")
    parser.add_argument("--codec", default="mp4v", help="FourCC of the generated video")
    args = parser.parse_args()
    main(frames=args.frames, codec=args.codec)
