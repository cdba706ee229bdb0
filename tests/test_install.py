"""What the README's two commands install, and what the studio does where a library is missing.

``make run`` installs everything the studio offers (the ``studio`` extra: the figures, every rig
format, live sessions); the library's optional extras stay for users who install ``promp``
alone. Where matplotlib is missing (such an install), the evaluation says so before its sweep
and the Data tab's export and saved runs keep their tables and say why there are no figures.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

from tests.conftest import REPO

PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
# What each thing the studio offers needs: the Data tab's formats, its figures, live sessions.
OFFERED = {"rosbag": "rosbags", "xdf": "pyxdf", "c3d": "ezc3d", "figures": "matplotlib",
           "live": "pylsl"}  # fmt: skip
NO_MATPLOTLIB = "import sys; sys.modules['matplotlib'] = None; "  # `import matplotlib` fails


def extra(name: str) -> set[str]:
    """The distributions an extra installs, its self-references (``pkg[a,b]``) followed."""
    found = set()
    for requirement in PROJECT["optional-dependencies"][name]:
        distribution, _, rest = re.match(r"([A-Za-z0-9_.-]+)(\[([^\]]+)\])?", requirement).groups()
        if distribution == PROJECT["name"]:
            for inner in rest.strip("[]").split(","):
                found |= extra(inner.strip())
        else:
            found.add(distribution)
    return found


def make_rule(stamp: str) -> str:
    """The recipe of the Makefile rule that makes ``stamp``."""
    text = (REPO / "Makefile").read_text()
    return re.search(rf"^\$\(VENV\)/{re.escape(stamp)}:.*\n((?:\t.*\n)+)", text, re.M).group(1)


def test_make_run_installs_everything_the_studio_offers() -> None:
    from promp.rigs import RIG_FORMATS

    studio = extra("studio")
    for offered, distribution in OFFERED.items():
        assert distribution in studio, f"{offered} needs {distribution}, not in [studio]"
    assert {"rosbag", "xdf", "c3d"} <= set(RIG_FORMATS)  # the formats above are those offered
    assert '-e ".[studio]"' in make_rule(".run-installed")
    assert "studio" in re.search(r'-e "\.\[([^\]]+)\]"', make_rule(".test-installed")).group(1)
    assert "matplotlib" not in PROJECT["dependencies"]  # promp alone stays numpy/scipy


def test_the_installed_environment_has_what_make_run_installs() -> None:
    """The environment the suite runs in (made by make test, which installs [studio] too)."""
    import importlib.util

    for offered, distribution in OFFERED.items():
        module = {"rosbags": "rosbags.highlevel"}.get(distribution, distribution)
        assert importlib.util.find_spec(module.split(".")[0]) is not None, offered


def run_evaluate(tmp_path: Path, *args: str, prelude: str = "") -> subprocess.CompletedProcess:
    from promp.datasets import write_csv_dataset
    from tests.synthetic import make_dataset

    folder = tmp_path / "set"
    if not folder.exists():
        write_csv_dataset(folder, make_dataset(n_demos=4, seed=3))
    argv = [str(folder), "--format", "csv", "--modality", "hand=x,y,z", "--percent", "50",
            "--basis", "8", "--jobs", "1", *args]  # fmt: skip
    code = f"{prelude}from promp.evaluate.cli import main; sys.exit(main({argv!r}))"
    return subprocess.run([sys.executable, "-c", "import sys; " + code], cwd=REPO,
                          capture_output=True, text=True, timeout=600)  # fmt: skip


def test_the_evaluation_says_before_its_sweep_that_figures_need_matplotlib(tmp_path) -> None:
    for flag in (["--plots", str(tmp_path / "figures")], ["--run", str(tmp_path / "run")]):
        done = run_evaluate(tmp_path, *flag, prelude=NO_MATPLOTLIB)
        assert done.returncode == 2, done.stderr
        assert "figures need matplotlib" in done.stderr and "[plots]" in done.stderr
        assert "leave-one-out" not in done.stderr  # refused before the sweep began
        assert not (tmp_path / "figures").exists() and not (tmp_path / "run").exists()
    done = run_evaluate(tmp_path, "--plots", str(tmp_path / "figures"))
    assert done.returncode == 0, done.stderr
    assert sorted(p.suffix for p in (tmp_path / "figures").iterdir())[0] == ".png"


EXPORT_WITHOUT_MATPLOTLIB = """
import io, json, zipfile
from app.panels.data.results_area import ResultsArea
from tests.test_data_tab import fake_job

class Button:
    def on_click(self, callback):
        pass

said = []
area = ResultsArea(None, None, Button(), lambda *args: said.append(args[1:]))
area.evaluation = fake_job()
with zipfile.ZipFile(io.BytesIO(area.export(None))) as archive:
    print(json.dumps({"names": archive.namelist(), "said": said}))
"""


def test_an_export_without_matplotlib_keeps_the_tables_and_says_why() -> None:
    import json

    done = subprocess.run([sys.executable, "-c", NO_MATPLOTLIB + EXPORT_WITHOUT_MATPLOTLIB],
                          cwd=REPO, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.splitlines()[-1])
    assert out["names"] == ["results.json", "results.csv", "trials.csv"]
    (title, text, color), = out["said"]
    assert title == "Results exported" and color == "yellow"
    assert "no figures: the figures need matplotlib" in text


def test_the_workspaces_make_run_creates_stay_out_of_the_clone() -> None:
    """The default workspace, and those a Data-tab import creates beside it, are in a folder
    git ignores, never untracked folders among the code."""
    import shutil

    from app.cli import DEFAULT_WORKSPACE
    from app.panels.data.import_dataset import sibling_folder

    made = subprocess.run(["make", "-n", "run"], cwd=REPO, capture_output=True, text=True)
    assert made.returncode == 0 and "--workspace" not in made.stdout  # the CLI's default
    imported = sibling_folder(REPO / DEFAULT_WORKSPACE, "lab-records-heights")
    assert imported.parent == (REPO / DEFAULT_WORKSPACE).parent != REPO
    if shutil.which("git") is None or not (REPO / ".git").exists():
        return  # not a clone: nothing to be untracked in
    for folder in (REPO / DEFAULT_WORKSPACE, imported):
        index = str(folder.relative_to(REPO) / "studio.json")
        ignored = subprocess.run(["git", "check-ignore", "-q", "--no-index", index], cwd=REPO)
        assert ignored.returncode == 0, f"{folder} would be an untracked folder of the clone"
