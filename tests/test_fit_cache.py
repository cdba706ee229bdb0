"""Recent fits are reused: the same demonstrations, layout and settings give back the same
model at once (Undo delete, a setting put back), anything else the fit reads is a new key, a
crash is never kept, Session.refit (what the benchmarks time) always learns anew, and the cache
is the one the session is given (sessions given the same one share their fits)."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
from numpy.testing import assert_allclose

import app.core.fits
from app.core.fits import FitCache, LruCache, Training, training_key
from app.core.session import Session
from app.io.workspace import Workspace
from app.studio import default_workspace
from promp.data import Demonstration, Layout
from promp.model import Settings
from tests.synthetic import LAYOUT, make_dataset

SETTINGS = Settings(n_basis=8, width=1.0, noise_scale=1.5)


def copy_of(dataset):
    """The same content in new objects (new arrays)."""
    return {
        name: [Demonstration(d.times.copy(), d.values.copy(), d.columns, d.name) for d in demos]
        for name, demos in dataset.items()
    }


def test_the_key_is_the_content_and_changes_with_anything_the_fit_reads() -> None:
    dataset = make_dataset(seed=0, n_demos=4)
    key = training_key(dataset, LAYOUT, SETTINGS)
    assert training_key(copy_of(dataset), LAYOUT, SETTINGS) == key
    nudged = copy_of(dataset)
    first = nudged["left"][0]
    values = first.values.copy()
    values[3, 2] += 1e-12
    nudged["left"][0] = Demonstration(first.times, values, first.columns, first.name)
    renamed = copy_of(dataset)
    renamed["left"][1] = dataclasses.replace(renamed["left"][1], name="other")
    reordered = dict(reversed(list(dataset.items())))
    fewer = {name: demos[:-1] for name, demos in dataset.items()}
    one_modality = Layout(LAYOUT.modalities[:1])
    others = {
        "a value": training_key(nudged, LAYOUT, SETTINGS),
        "a name": training_key(renamed, LAYOUT, SETTINGS),
        "the order": training_key(reordered, LAYOUT, SETTINGS),
        "a demonstration less": training_key(fewer, LAYOUT, SETTINGS),
        "the layout": training_key(dataset, one_modality, SETTINGS),
        "the settings": training_key(dataset, LAYOUT, dataclasses.replace(SETTINGS, width=0.9)),
        "automatic settings": training_key(dataset, LAYOUT, Settings()),
    }
    assert key not in others.values()
    assert len(set(others.values())) == len(others)


def test_the_least_recently_used_outcome_goes_first() -> None:
    cache: LruCache[str] = LruCache(max_entries=2)
    cache.put("a", "A")
    cache.put("b", "B")
    assert cache.get("a") == "A"  # a is now the most recent
    cache.put("c", "C")
    assert (cache.get("a"), cache.get("b"), cache.get("c")) == ("A", None, "C")
    assert len(cache) == 2 and "a" in cache and "b" not in cache
    with pytest.raises(ValueError, match="at least one"):
        LruCache(max_entries=0)


def test_a_refit_of_the_same_training_reuses_its_outcome_and_a_crash_is_not_kept(
    monkeypatch,
) -> None:
    fits = FitCache()
    training = Training(make_dataset(seed=1, n_demos=4), LAYOUT, SETTINGS)
    first = fits.fit(training)
    assert first.model is not None and not first.reused
    again = fits.fit(Training(copy_of(training.demos), LAYOUT, SETTINGS))
    assert again.reused and again.model is first.model and again.ms == first.ms
    anew = fits.fit(training, reuse=False)
    assert not anew.reused and anew.model is not first.model
    for a, b in zip(anew.model.primitives, first.model.primitives, strict=True):
        assert_allclose(a.mean, b.mean, rtol=1e-12, atol=1e-15)
    # A refusal of the method is an outcome too; a crash is not kept.
    short = Training({"left": training.demos["left"][:1]}, LAYOUT, SETTINGS)
    refused = fits.fit(short)
    assert refused.model is None and "at least 2" in refused.error
    assert fits.fit(short).reused
    other = Training(make_dataset(seed=2, n_demos=4), LAYOUT, SETTINGS)

    def crash(*args, **kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(app.core.fits, "fit", crash)
    crashed = fits.fit(other)
    assert crashed.model is None and crashed.error == "RuntimeError: a bug"
    monkeypatch.undo()
    learned = fits.fit(other)
    assert learned.model is not None and not learned.reused


def test_undo_delete_gives_back_the_model_at_once_and_refit_learns_anew(tmp_path) -> None:
    fits = FitCache()
    root = tmp_path / "ws"
    Workspace.create(root, default_workspace())
    session = Session.open(root, fits=fits)
    before = session.snapshot().model
    assert before is not None and not session.learner.state.reused
    entry = session.store.delete_demo("curved", "curved_004")
    assert session.wait_for_model() is not before and not session.learner.state.reused
    session.store.restore(entry.name)
    assert session.wait_for_model() is before and session.learner.state.reused
    # What the benchmarks time: a real fit, whatever the cache holds.
    refitted = session.refit()
    learned = session.learner.state
    assert refitted is not before and not learned.reused and learned.fit_ms > 0
    session.close()
    # Another session of the same workspace given the same cache (a studio restarted in this
    # process) reuses it; one given another cache learns anew.
    copy = tmp_path / "copy"
    shutil.copytree(root, copy)
    reopened = Session.open(copy, fits=fits)
    assert reopened.snapshot().model is refitted and reopened.learner.state.reused
    reopened.close()
    assert np.isfinite(reopened.learner.state.fit_ms)
    other = Session.open(copy, fits=FitCache())
    assert other.snapshot().model is not refitted and not other.learner.state.reused
    other.close()
