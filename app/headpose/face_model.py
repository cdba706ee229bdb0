"""The 3D face model that ``cv2.solvePnP`` fits to the detected landmarks.

The points are a subset of the 468 vertices of MediaPipe's canonical face model
(``mediapipe/modules/face_geometry/data/canonical_face_model.obj`` in google/mediapipe, Apache
License 2.0), whose vertex ``i`` is the face landmark model's output ``i``. That file is in
centimetres with X to the face's left, Y up and Z out of the face. The subset keeps points on
rigid parts of the face (forehead, nose, eye corners, cheekbones, the face outline at the temples
and cheeks) and the chin, which pins down pitch; the mouth corners are left out, as smiling moves
them by several millimetres. Coordinates were read from
the file, rounded to 0.01 cm, and the model being left/right symmetric, each pair is written once.

Here the points are expressed in the partner's head frame of the package convention (x forward
out of the face, y to the face's left, z up), i.e. ``(x, y, z) = (Z, X, Y)`` of the canonical file.
"""

from __future__ import annotations

import numpy as np

# Landmarks on the face's midline: index -> canonical (X, Y, Z), X = 0.
_MIDLINE = {
    10: (8.26, 4.48),  # top of the forehead: (Y, Z)
    151: (6.55, 5.03),  # forehead
    9: (4.89, 5.39),  # between the brows
    168: (3.27, 5.24),  # nasion
    6: (2.47, 5.79),  # nose bridge
    4: (-0.46, 7.59),  # nose, above the tip
    1: (-1.13, 7.48),  # nose tip
    2: (-2.09, 6.06),  # below the nose
    152: (-9.40, 4.26),  # chin
}

# Symmetric pairs: (face's right index, face's left index) -> canonical (|X|, Y, Z).
_PAIRS = {
    (33, 263): (4.45, 2.66, 3.17),  # outer eye corners
    (133, 362): (1.86, 2.59, 3.76),  # inner eye corners
    (98, 327): (1.41, -1.71, 5.24),  # nose wings
    (50, 280): (4.77, -0.70, 3.53),  # cheekbones
    (205, 425): (3.83, -1.54, 4.14),  # cheeks
    (127, 356): (7.74, 2.36, -2.01),  # face outline at the temples
    (234, 454): (7.66, 0.67, -2.44),  # face outline at the cheeks
}


def _build() -> tuple[np.ndarray, np.ndarray]:
    indices: list[int] = []
    canonical: list[tuple[float, float, float]] = []
    for index, (y, z) in _MIDLINE.items():
        indices.append(index)
        canonical.append((0.0, y, z))
    for (right, left), (x, y, z) in _PAIRS.items():
        indices += [right, left]
        canonical += [(-x, y, z), (x, y, z)]  # the face's right side has X < 0
    xyz = np.asarray(canonical, dtype=np.float64)
    head = xyz[:, [2, 0, 1]]  # (Z, X, Y): forward, left, up
    return np.asarray(indices, dtype=np.intp), head


#: Landmark indices used for the pose fit, shape (n_points,).
MODEL_LANDMARKS: np.ndarray
#: Their 3D positions in the head frame (x forward, y left, z up), cm, shape (n_points, 3).
MODEL_POINTS: np.ndarray
MODEL_LANDMARKS, MODEL_POINTS = _build()
MODEL_LANDMARKS.setflags(write=False)
MODEL_POINTS.setflags(write=False)

#: Landmarks that set the tracking ROI's in-plane angle: outer corners of the right and left eye.
RIGHT_EYE_OUTER = 33
LEFT_EYE_OUTER = 263
#: The nose tip, where the overlay draws the pose axes.
NOSE_TIP = 1
