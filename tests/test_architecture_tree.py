"""docs/ARCHITECTURE.md's trees (tests/doc_tree.py) against the files on disk, both ways: every
folder and module they name exists (a pattern such as ``lsl_*.py`` matches one at least), and
every package and module of promp, app and robots is named there or in a pattern."""

from __future__ import annotations

from tests.doc_tree import REPO, missing, named, tree_blocks, unlisted


def architecture_paths(text: str) -> set[str]:
    return set().union(*(named(block) for block in tree_blocks(text)))


def test_every_file_the_trees_name_exists() -> None:
    text = (REPO / "docs" / "ARCHITECTURE.md").read_text(encoding="utf-8")
    assert len(tree_blocks(text)) == 3  # by layer, the repository, the live pipeline
    assert missing(architecture_paths(text)) == []


def test_every_package_and_module_is_in_the_trees() -> None:
    text = (REPO / "docs" / "ARCHITECTURE.md").read_text(encoding="utf-8")
    assert unlisted(architecture_paths(text)) == []


def test_the_tree_reads_entries_descriptions_and_patterns() -> None:
    """The check's own test: a folder's entries nest by indentation, a description names files
    of its entry's folder (or by a path), a pattern groups modules; a name that is not on disk
    is missing, a module not named is unlisted."""
    block = ("app/                   the studio\n"
             "  live/                in time: replay.py (panels/infer/replay_section.py)\n"
             "    lsl_*.py            the LSL source; stream.py: the live stream, and\n"
             "                        ghost.py, a module that is not there\n"
             "  vanished/            a folder that is not there\n")  # fmt: skip
    paths = named(block)
    assert {"app/", "app/live/", "app/live/lsl_*.py", "app/live/replay.py",
            "app/live/stream.py", "app/panels/infer/replay_section.py"} <= paths  # fmt: skip
    assert missing(paths) == ["app/live/ghost.py", "app/vanished/"]
    left = unlisted(paths, ("app",))
    assert "app/live/lsl_source.py" not in left and "app/live/recorder.py" in left
    assert "app/core/" in left and "app/live/" not in left
