"""MediaPipe's short-range face detector (BlazeFace) on OpenCV's DNN module.

The network takes a 128x128 RGB image scaled to [-1, 1] and regresses, for each of 896 SSD
anchors, a face box and six key points, plus a face score (a logit). Anchors sit at the centres of
a 16x16 grid (stride 8, 2 anchors per cell) and an 8x8 grid (stride 16, 6 anchors per cell), all of
unit size, in that order (MediaPipe's SSD anchor options for this model). Each anchor's 16
regressed numbers, in input pixels, are: box centre offset (x, y), box width and height, then the
six key points' offsets (x, y): the face's right eye, left eye, nose tip, mouth centre, right ear
tragion, left ear tragion ("right" = the face's right, on the image left of a non-mirrored
camera). The frame is letterboxed to a square (aspect ratio kept) before scaling to 128x128.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from app.headpose.models import DETECTOR_OUTPUTS, load_network

INPUT_SIZE = 128
#: MediaPipe clips the score logits to this range before the sigmoid.
SCORE_CLIP = 100.0


def _anchor_centres() -> np.ndarray:
    centres = []
    for stride, per_cell in ((8, 2), (16, 6)):
        cells = INPUT_SIZE // stride
        ys, xs = np.mgrid[0:cells, 0:cells]
        grid = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
        centres.append(np.repeat((grid + 0.5) * stride, per_cell, axis=0))
    return np.concatenate(centres)  # input pixels, shape (896, 2)


ANCHORS = _anchor_centres()
ANCHORS.setflags(write=False)


@dataclass(frozen=True)
class FaceDetection:
    """One detected face, in pixels of the processed frame.

    Attributes
    ----------
    score : float
        Face probability in [0, 1].
    box : array, shape (4,)
        ``(x_centre, y_centre, width, height)``.
    keypoints : array, shape (6, 2)
        Right eye, left eye, nose tip, mouth, right ear, left ear (the face's right and left).
    """

    score: float
    box: np.ndarray
    keypoints: np.ndarray


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    half, halves = box[2:4] / 2, boxes[:, 2:4] / 2
    lo = np.maximum(box[:2] - half, boxes[:, :2] - halves)
    hi = np.minimum(box[:2] + half, boxes[:, :2] + halves)
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    union = box[2] * box[3] + boxes[:, 2] * boxes[:, 3] - inter
    return inter / np.maximum(union, 1e-9)


def _tile_starts(length: int, side: int, step: int) -> list[int]:
    if length <= side:
        return [0]
    starts = list(range(0, length - side, step))
    return starts + [length - side]


class FaceDetector:
    """Detect faces in BGR frames.

    Parameters
    ----------
    model_path : path-like
        The ``face_detection_short_range.tflite`` file.
    min_score : float
        Faces below this probability are dropped.
    iou_threshold : float
        Detections overlapping more than this are merged (weighted by score), as MediaPipe does.
    """

    def __init__(self, model_path, min_score: float = 0.5, iou_threshold: float = 0.3) -> None:
        if not 0.0 < min_score < 1.0:
            raise ValueError(f"min_score must be in (0, 1), got {min_score}")
        self.net = load_network(model_path, DETECTOR_OUTPUTS)
        self.min_score = float(min_score)
        self.iou_threshold = float(iou_threshold)

    def _letterbox(self, frame_bgr: np.ndarray) -> tuple[np.ndarray, float, float, float]:
        height, width = frame_bgr.shape[:2]
        scale = INPUT_SIZE / max(height, width)
        new_w = max(1, round(width * scale))
        new_h = max(1, round(height * scale))
        small = cv2.resize(frame_bgr, (new_w, new_h), interpolation=cv2.INTER_AREA)
        pad_x, pad_y = (INPUT_SIZE - new_w) // 2, (INPUT_SIZE - new_h) // 2
        square = cv2.copyMakeBorder(
            small,
            pad_y,
            INPUT_SIZE - new_h - pad_y,
            pad_x,
            INPUT_SIZE - new_w - pad_x,
            cv2.BORDER_CONSTANT,
            value=(0, 0, 0),
        )
        return square, scale, float(pad_x), float(pad_y)

    def detect(self, frame_bgr: np.ndarray) -> list[FaceDetection]:
        """Find the faces in one frame.

        Parameters
        ----------
        frame_bgr : array, shape (height, width, 3), uint8
            The frame, BGR as OpenCV delivers it.

        Returns
        -------
        list of FaceDetection
            Best first; empty when no face scores above ``min_score``.
        """
        return self._merge(*self._candidates(frame_bgr, (0.0, 0.0)))

    def detect_tiled(self, frame_bgr: np.ndarray) -> list[FaceDetection]:
        """Find faces too small for :meth:`detect` by scanning overlapping tiles.

        The whole-frame pass shrinks a 640x480 frame five times, so it misses faces narrower
        than about 70 pixels (a partner further than about 1.3 m from a webcam). Tiles of
        two thirds of the shorter frame side, overlapping by half, are each shrunk less; any face
        up to half a tile fits in one of them. A 640x480 frame gives 6 tiles: 6 more detector
        runs, spent only while no face is tracked.

        Parameters
        ----------
        frame_bgr : array, shape (height, width, 3), uint8

        Returns
        -------
        list of FaceDetection
            Best first, in frame pixels.
        """
        height, width = frame_bgr.shape[:2]
        side = max(INPUT_SIZE, (2 * min(height, width)) // 3)
        step = side // 2
        parts = []
        for y0 in _tile_starts(height, side, step):
            for x0 in _tile_starts(width, side, step):
                tile = frame_bgr[y0 : y0 + side, x0 : x0 + side]
                parts.append(self._candidates(tile, (float(x0), float(y0))))
        scores = np.concatenate([p[0] for p in parts])
        if scores.size == 0:
            return []
        boxes = np.concatenate([p[1] for p in parts])
        points = np.concatenate([p[2] for p in parts])
        return self._merge(scores, boxes, points)

    def _candidates(
        self, frame_bgr: np.ndarray, origin: tuple[float, float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Anchors scoring above ``min_score``: scores (n,), boxes (n, 4), key points (n, 6, 2)."""
        square, scale, pad_x, pad_y = self._letterbox(frame_bgr)
        blob = cv2.dnn.blobFromImage(
            square, scalefactor=1 / 127.5, mean=(127.5, 127.5, 127.5), swapRB=True
        )
        self.net.setInput(blob)
        regressors, logits = self.net.forward(list(DETECTOR_OUTPUTS))
        raw = regressors.reshape(-1, 16).astype(np.float64)
        logit = np.clip(logits.reshape(-1).astype(np.float64), -SCORE_CLIP, SCORE_CLIP)
        scores = 1.0 / (1.0 + np.exp(-logit))
        keep = np.flatnonzero(scores >= self.min_score)
        anchors = ANCHORS[keep]
        boxes = raw[keep, :4].copy()
        boxes[:, :2] += anchors
        points = raw[keep, 4:].reshape(-1, 6, 2) + anchors[:, None, :]
        # back from the letterboxed input to frame pixels
        pad = np.array([pad_x, pad_y])
        boxes[:, :2] = (boxes[:, :2] - pad) / scale + origin
        boxes[:, 2:] /= scale
        points = (points - pad) / scale + origin
        return scores[keep], boxes, points

    def _merge(
        self, scores: np.ndarray, boxes: np.ndarray, points: np.ndarray
    ) -> list[FaceDetection]:
        if scores.size == 0:
            return []
        order = np.argsort(-scores)
        scores, boxes, points = scores[order], boxes[order], points[order]
        remaining = np.ones(len(scores), dtype=bool)
        faces = []
        for i in range(len(scores)):
            if not remaining[i]:
                continue
            group = remaining & (_iou(boxes[i], boxes) > self.iou_threshold)
            group[i] = True
            weights = scores[group] / scores[group].sum()
            faces.append(
                FaceDetection(
                    score=float(scores[i]),
                    box=weights @ boxes[group],
                    keypoints=np.tensordot(weights, points[group], axes=1),
                )
            )
            remaining &= ~group
        return faces
