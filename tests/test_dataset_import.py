"""Bringing one's own recordings in: a dataset folder or zip becomes a workspace through the
evaluation's reader; every bad import is refused naming the file and the problem, with nothing
written; the command line refuses a folder that is not a workspace, untouched, with a non-zero
exit; and the authors' lab recordings are where the iCub's left hand can be."""

from __future__ import annotations

import hashlib
import io
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

from app.cli import build_parser, prepare_workspace
from app.core.session import Session
from app.io.dataset_import import (
    dataset_to_workspace,
    extract_dataset_zip,
    read_folder,
    safe_name,
)
from app.io.exchange import Limits
from app.io.workspace import FolderKind, inspect_folder
from promp.datasets import parse_modality, read_dataset
from tests.conftest import REPO


def zip_folder(folder: Path, prefix: str = "") -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                archive.write(path, prefix + path.relative_to(folder).as_posix())
    return buffer.getvalue()


def zip_of(members: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    return buffer.getvalue()


def csv_demo(seed: int, n: int = 30) -> bytes:
    rng = np.random.default_rng(seed)
    rows = np.column_stack([np.arange(n) * 0.02, np.cumsum(rng.normal(size=(n, 3)), axis=0)])
    return ("t,x,y,z\n" + "\n".join(",".join(f"{v:.6f}" for v in r) for r in rows)).encode()


def leftovers() -> set[str]:
    return {p.name for p in Path(tempfile.gettempdir()).glob("icub-studio-dataset-*")}


def checksums(root: Path) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def test_safe_names() -> None:
    taken: set[str] = set()
    assert safe_name("person1/record0", taken) == "person1_record0"
    assert safe_name("person1 record0", taken) == "person1_record0-2"
    assert safe_name("_x", taken) == "x"
    assert safe_name("é", taken) == "demo"
    assert len(safe_name("a" * 60, taken)) == 40


def test_the_heights_recordings_become_a_workspace(heights_dir: Path) -> None:
    data, summary = read_folder(heights_dir, "records")
    assert summary.counts == {"bottom": 40, "middle": 40, "top": 42}
    assert data.layout.names == ("hand",) and data.layout.columns == ("x", "y", "z")
    assert data.demos["bottom"][0].name == "person1_record0"
    assert data.demos["bottom"][0].times[0] == 0.0
    assert "3 primitives, 122 demonstrations" in summary.describe()


def test_the_lab_recordings_are_in_the_icub_root_frame(heights_dir: Path) -> None:
    """Columns 10-12 are the left hand of this iCub in its root frame: the arm reaches every
    recorded position with the torso still, and not the same points mirrored to its right or
    put behind it (so the check tells frames apart)."""
    from robots.icub.ik import solve_ik
    from robots.icub.kinematics import load_arm
    from robots.icub.model import load_urdf, natural_pose

    arm = load_arm()
    q0 = arm.from_full(natural_pose(load_urdf(load_meshes=False)))
    read = read_dataset(heights_dir, "records")
    dataset, layout = read.dataset, read.layout
    points = np.concatenate(
        [layout.extract(d)[::25] for demos in dataset.values() for d in demos[::8]]
    )

    def reached(targets: np.ndarray) -> float:
        errors = [solve_ik(arm, p, q0, lock_torso=True).position_error_m for p in targets]
        return float(np.mean(np.array(errors) < 5e-3))

    assert reached(points) == 1.0
    assert reached(points * [1, -1, 1]) < 0.6
    assert reached(points * [-1, 1, 1]) == 0.0


def test_a_zip_of_the_dataset_folder_is_extracted_and_read(heights_dir: Path) -> None:
    before = leftovers()
    upload = extract_dataset_zip(zip_folder(heights_dir, "heights/"), "heights.zip")
    try:
        assert upload.format == "records" and upload.root.name == "heights"
        data, summary = upload.read()
        assert summary.source == "heights.zip" and data.n_demos == 122
        wrench, _ = upload.read(
            "records", [parse_modality("hand=x,y,z"), parse_modality("wrench=fx,fy,fz")]
        )
        assert wrench.layout.names == ("hand", "wrench")
    finally:
        upload.close()
    assert leftovers() == before


BAD_ZIPS = {
    "empty folder": (zip_of({"data/": b""}), "no .csv or .txt files"),
    "non-numeric": (
        zip_of({"a/r1.txt": b"hello world\n", "a/r2.txt": b"x\n", "b/r1.txt": b"y\n"}),
        "bad.zip/a/r1.txt: not a lab record",
    ),
    "one demonstration": (
        zip_of({"reach/d1.csv": csv_demo(1), "reach/d2.csv": csv_demo(2),
                "wave/d1.csv": csv_demo(3)}),  # fmt: skip
        "class 'wave' (1: d1) has fewer than 2 demonstrations",
    ),
    "zip-slip": (
        zip_of({"reach/d1.csv": csv_demo(1), "../evil.csv": csv_demo(2)}),
        "../evil.csv: '..', '.' and empty path components are refused",
    ),
    "absolute path": (zip_of({"/etc/evil.csv": csv_demo(2)}), "absolute paths are refused"),
    "zip bomb": (
        zip_of({"a/d.csv": b"0" * (3 * 2**20)}),
        "the archive expands to 3.0 MB, over the 1.0 MB limit",
    ),
    "not a zip": (b"PK\x03\x04 but not really a zip file at all", "not a zip archive"),
    "empty file": (b"", "the file is empty"),
    "duplicated names": (
        zip_of({"a/d.csv": csv_demo(1), "a/D.csv": csv_demo(2)}),
        "a/D.csv: appears twice",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_ZIPS))
def test_bad_dataset_zips_are_refused_leaving_nothing(case: str) -> None:
    content, message = BAD_ZIPS[case]
    before = leftovers()
    limits = Limits(max_upload_bytes=2**20, max_uncompressed_bytes=2**20)
    with pytest.raises(ValueError) as info:
        upload = extract_dataset_zip(content, "bad.zip", limits)
        try:
            upload.read()
        finally:
            upload.close()
    assert message in str(info.value)
    assert leftovers() == before


def test_an_oversized_upload_and_a_wrong_mapping_are_refused() -> None:
    big = b"\0" * (2 * 2**20)
    with pytest.raises(ValueError, match=r"2.0 MB, over the 1.0 MB upload limit"):
        extract_dataset_zip(big, "huge.zip", Limits(max_upload_bytes=2**20))
    with pytest.raises(ValueError, match=r"a dataset is uploaded as a \.zip"):
        extract_dataset_zip(zip_of({"a/d.csv": csv_demo(1)}), "data.tar")
    upload = extract_dataset_zip(
        zip_of({"a/d1.csv": csv_demo(1), "a/d2.csv": csv_demo(2)}), "mine.zip"
    )
    try:
        with pytest.raises(ValueError, match=r"a/d1: missing column\(s\) \['w'\]"):
            upload.read("csv", [parse_modality("hand=x,y,w")])
        with pytest.raises(ValueError, match="'hand' drives the 3D view"):
            upload.read("csv", [parse_modality("hand=x,y")])
        data, _ = upload.read("csv", [parse_modality("pos=x,y")])
        assert data.layout.names == ("pos",)
    finally:
        upload.close()


def test_classes_with_fewer_than_two_demonstrations_are_named() -> None:
    from promp.data import Demonstration, Layout, Modality

    layout = Layout((Modality("hand", ("x", "y", "z")),))
    demo = Demonstration(np.arange(3.0), np.zeros((3, 3)), ("x", "y", "z"), "only")
    with pytest.raises(ValueError, match=r"class 'alone' \(1: only\) has fewer than 2"):
        dataset_to_workspace({"alone": [demo], "ok": [demo, demo]}, layout)


def args(*argv: str):
    return build_parser().parse_args(list(argv))


def test_the_command_line_imports_a_dataset_into_a_new_workspace(tmp_path, heights_dir) -> None:
    before = checksums(heights_dir)
    new = tmp_path / "heights-ws"
    prepare_workspace(args("--workspace", str(new), "--import-dataset", str(heights_dir)))
    assert inspect_folder(new)[0] is FolderKind.WORKSPACE
    session = Session.open(new)
    demos = session.store.state.demos
    assert {n: len(d) for n, d in demos.items()} == {"bottom": 40, "middle": 40, "top": 42}
    model = session.snapshot().model
    assert model is not None and model.names == ("bottom", "middle", "top")
    session.close()
    assert checksums(heights_dir) == before  # the source is only read
    for argv, message in [
        (("--workspace", str(new), "--import-dataset", str(heights_dir)), "already is one"),
        (("--workspace", str(heights_dir / "ws"), "--import-dataset", str(heights_dir)),
         "must be separate folders"),
        (("--workspace", str(tmp_path / "x"), "--import-dataset", str(tmp_path / "nope")),
         "no such folder"),
        (("--workspace", str(heights_dir), "--import-dataset", str(new)), "absent or empty"),
        (("--workspace", str(tmp_path / "y"), "--format", "csv"), "go with --import-dataset"),
    ]:  # fmt: skip
        with pytest.raises(ValueError, match=message):
            prepare_workspace(args(*argv))
    assert checksums(heights_dir) == before
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_starting_on_a_folder_of_recordings_exits_and_leaves_it_byte_identical(
    tmp_path, heights_dir
) -> None:
    import shutil

    mine = tmp_path / "my_recordings"
    shutil.copytree(heights_dir, mine)
    before = checksums(mine)
    from app.io.net import free_port

    result = subprocess.run(
        [sys.executable, "-m", "app", "--workspace", str(mine), "--port", str(free_port())],
        cwd=REPO, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode != 0
    assert f"{mine} holds {len(before)} file(s)" in result.stderr
    assert f"--import-dataset {mine}" in result.stderr
    assert checksums(mine) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my_recordings"]
