"""Every name the documents and docstrings cite resolves (tests/doc_names.py): a dotted name of
promp, app or robots (a module, or a name defined in one), a Sphinx role's target in a
docstring (the module's or its class's own name without a prefix), and a file path of the
repository (a ``*`` pattern must match a file) in README.md, docs/*.md and every docstring of
promp, app and robots."""

from __future__ import annotations

from tests.doc_names import sources, stale


def test_every_cited_name_and_path_resolves() -> None:
    found = {where: names for where, text, module, cls in sources()
             if (names := stale(text, module, cls))}  # fmt: skip
    assert not found, found


def test_a_stale_name_or_path_is_found() -> None:
    """The check's own test: names that moved or never were are reported, those that exist
    are not."""
    text = ("promp.pipeline.typicality moved to promp.typicality.typicality; promp/selection.py "
            "is the folder promp/selection/, with app/live/lsl_*.py and app/live/nothing_*.py; "
            "app.live.inference.InferResult.truth, "
            "app.scene.inference_layer.InferenceLayer.drawn")  # fmt: skip
    assert stale(text) == ["promp.pipeline.typicality", "promp/selection.py",
                           "app/live/nothing_*.py"]  # fmt: skip
    roles = ":func:`typicality` and :func:`untypical`; :meth:`Learner.wait`, :class:`str`"
    assert stale(roles, "promp.typicality") == ["untypical", "Learner.wait"]
    assert stale(roles, "app.core.learner") == ["typicality", "untypical"]
