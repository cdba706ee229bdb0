"""``import promp``: the library's public API, its guide, and what every module declares public.

The front door (``promp/__init__.py``) names the handful of functions and types a user needs
and loads each from its module on first use; every public module of ``promp`` lists its public
names in ``__all__``.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import inspect
import json
import os
import subprocess
import sys

import pytest
from numpy.testing import assert_allclose

import promp
from promp.datasets import write_csv_dataset
from promp.evaluate.cli import main as evaluate_main
from promp.model import Settings
from tests.conftest import REPO
from tests.synthetic import LAYOUT, make_dataset

FUNCTIONS = ("fit", "infer", "recognise", "condition", "predict", "condition_on_via_points",
             "save_model", "load_model", "read_dataset", "leave_one_out")  # fmt: skip
TYPES = ("Demonstration", "Layout", "Modality", "Observation", "Settings", "ProMPModel",
         "Primitive", "Inference", "Recognition", "Posterior", "Prediction", "ViaPoint",
         "DatasetRead", "SweepResult", "CommitRule")  # fmt: skip
# Modules without ``__all__``, and why.
WITHOUT_ALL = {
    "promp.evaluate.__main__": "a script: ``python -m promp.evaluate``",
    "promp.live.__main__": "a script: ``python -m promp.live``",
}
WITHOUT_ALL_PACKAGES: dict[str, str] = {}


def _run(code: str) -> str:
    env = dict(os.environ, PAGER="cat", TERM="dumb")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO, env=env, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_public_api_is_the_functions_and_types_a_user_needs() -> None:
    assert sorted(promp.__all__) == sorted(FUNCTIONS + TYPES)
    for name in FUNCTIONS:
        assert inspect.isfunction(getattr(promp, name)), name
    for name in TYPES:
        assert inspect.isclass(getattr(promp, name)), name


def test_help_promp_shows_the_guide_and_every_public_name() -> None:
    """``python -c "import promp; help(promp)"``: the guide with its example, every function
    with its signature and every type, each once."""
    text = _run("import promp; help(promp)")
    assert "Learn and infer" in text and ">>> model = promp.fit(dataset, layout)" in text
    for name in FUNCTIONS:
        assert f"    {name}(" in text, name
    for name in TYPES:
        assert f"class {name}" in text, name


@pytest.mark.parametrize("name", FUNCTIONS + TYPES)
def test_every_public_name_is_documented_with_numpydoc_sections(name: str) -> None:
    """Functions say what they take and give (Parameters, Returns), types what they hold
    (Parameters or Attributes); each is the object of the module it lives in, listed in
    that module's ``__all__`` (when it has one: see :data:`WITHOUT_ALL`)."""
    obj = getattr(promp, name)
    home = importlib.import_module(obj.__module__)
    assert getattr(home, name) is obj
    if obj.__module__ not in WITHOUT_ALL:
        assert name in home.__all__
    doc = inspect.getdoc(obj) or ""
    sections = ("Parameters",)
    if inspect.isfunction(obj) and inspect.signature(obj).return_annotation != "None":
        sections = ("Parameters", "Returns")
    if inspect.isclass(obj) and "Attributes\n----------" in doc:
        sections = ("Attributes",)
    for section in sections:
        assert f"{section}\n{'-' * len(section)}" in doc, (name, section)


def test_the_guides_example_runs() -> None:
    """The example of ``promp``'s docstring, as doctest runs it: learn two reaches, recognise
    a third from its first 40 samples, predict the rest."""
    result = doctest.testmod(promp, optionflags=doctest.ELLIPSIS, verbose=False)
    assert result.attempted >= 10 and result.failed == 0


def test_import_promp_loads_each_public_name_on_first_use() -> None:
    """``import promp`` limits the BLAS threads and loads nothing else of promp; a public
    name loads its module when first asked for; submodules import as ever; an unknown name
    is an AttributeError."""
    out = _run(
        "import json, sys\n"
        "import promp\n"
        "seen = {'imported': sorted(m for m in sys.modules if m.startswith('promp'))}\n"
        "promp.fit\n"
        "seen['after fit'] = 'promp.learn' in sys.modules\n"
        "seen['evaluation before'] = 'promp.evaluate' in sys.modules\n"
        "from promp import leave_one_out, selection\n"
        "seen['evaluation after'] = 'promp.evaluate.sweep' in sys.modules\n"
        "seen['selection'] = selection.__name__\n"
        "seen['dir'] = sorted(set(promp.__all__) - set(dir(promp)))\n"
        "try:\n    promp.fitt\nexcept AttributeError as exc:\n    seen['unknown'] = str(exc)\n"
        "print(json.dumps(seen))\n"
    )
    seen = json.loads(out)
    assert seen["imported"] == ["promp", "promp._threads"]
    assert seen["after fit"] and not seen["evaluation before"] and seen["evaluation after"]
    assert seen["selection"] == "promp.selection" and seen["dir"] == []
    assert "'fitt'" in seen["unknown"]


def _public_modules() -> dict[str, ast.Module]:
    """Every module of promp a user may import (no underscored module), parsed."""
    out = {}
    for path in sorted((REPO / "promp").rglob("*.py")):
        parts = list(path.relative_to(REPO).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        name = ".".join(parts)
        if any(p.startswith("_") for p in parts[1:]) and not name.endswith("__main__"):
            continue
        if name in WITHOUT_ALL or any(name.startswith(f"{p}.") or name == p
                                      for p in WITHOUT_ALL_PACKAGES):  # fmt: skip
            continue
        out[name] = ast.parse(path.read_text(encoding="utf-8"))
    return out


def test_every_public_module_lists_its_public_names() -> None:
    """``__all__`` in every public module (but :data:`WITHOUT_ALL`): it names what exists,
    nothing private, and every function, class and constant the module defines without a
    leading underscore: a new public name is listed, or made private."""
    modules = _public_modules()
    assert "promp.selection.loo" in modules and "promp.model" in modules
    for name, tree in modules.items():
        module = importlib.import_module(name)
        assert isinstance(getattr(module, "__all__", None), list), f"{name} has no __all__"
        assert all(hasattr(module, n) and not n.startswith("_") for n in module.__all__), name
        defined = set()
        for node in tree.body:
            if isinstance(node, ast.FunctionDef | ast.ClassDef):
                defined.add(node.name)
            elif isinstance(node, ast.Assign | ast.AnnAssign):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                defined |= {t.id for t in targets if isinstance(t, ast.Name)}
        public = {n for n in defined if not n.startswith("_")}
        assert public <= set(module.__all__), (name, sorted(public - set(module.__all__)))


def test_what_the_studio_and_the_robot_import_from_promp_is_public() -> None:
    """Every name ``app/`` and ``robots/`` import from a module of promp is in that module's
    ``__all__``: the public lists are the surface the rest of the project uses."""
    modules = _public_modules()
    used = []
    for path in sorted([*(REPO / "app").rglob("*.py"), *(REPO / "robots").rglob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("promp"):
                used += [(node.module, a.name, path.name) for a in node.names]
    assert len(used) > 20
    private = [
        (module, name, where)
        for module, name, where in used
        if module in modules and f"{module}.{name}" not in modules
        and name not in importlib.import_module(module).__all__
    ]  # fmt: skip
    assert private == []


def test_leave_one_out_is_the_command_lines_sweep(tmp_path) -> None:
    """``promp.leave_one_out`` on a folder read by ``promp.read_dataset`` gives the rows
    ``python -m promp.evaluate`` writes for the same folder and settings."""
    write_csv_dataset(tmp_path / "data", make_dataset(seed=5, n_demos=3))
    read = promp.read_dataset(tmp_path / "data", "csv")
    settings = Settings(n_basis=6, width=1.0, noise_scale=1.5, duration_temperature=0.5)
    result = promp.leave_one_out(read.dataset, read.layout, [40, 80], settings,
                                 alpha_methods=["ml"], observe=[["hand"], ["head"]])  # fmt: skip
    assert len(result.rows) == 4 and len(result.trials) == 4 * 6 and not result.failures
    out = tmp_path / "report.json"
    args = [str(tmp_path / "data"), "--format", "csv", "--percent", "40", "80", "--alpha", "ml",
            "--observe", "hand", "--observe", "head", "--basis", "6", "--width", "1",
            "--noise-scale", "1.5", "--duration-temperature", "0.5", "--jobs", "1",
            "--json", str(out)]  # fmt: skip
    assert evaluate_main(args) == 0
    rows = json.loads(out.read_text())["results"]
    assert len(rows) == len(result.rows)
    for mine, theirs in zip(result.rows, rows, strict=True):
        for key in ("percent", "alpha_method", "observed", "recognition_errors", "trials"):
            assert mine[key] == theirs[key], key
        for key in ("log_loss", "position_error_m", "goal_error_m", "duration_error_s"):
            assert_allclose(mine[key], theirs[key], rtol=1e-9)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"percents": [0]}, r"percents must be in \(0, 100\]"),
        ({"percents": [50, 101]}, r"percents must be in \(0, 100\]"),
        ({"percents": []}, "at least one"),
        ({"alpha_methods": ["fast"]}, "alpha_methods must be some of"),
        ({"observe": [["nose"]]}, "nose"),
        ({"jobs": 0}, "jobs must be a positive number or -1"),
    ],
)
def test_leave_one_out_refuses_bad_input_before_any_work(change: dict, message: str) -> None:
    dataset = make_dataset(seed=5, n_demos=3)
    arguments = {"percents": [50]} | change
    with pytest.raises(ValueError, match=message):
        promp.leave_one_out(dataset, LAYOUT, **arguments)
    with pytest.raises(ValueError, match="at least 3 demonstrations per primitive"):
        promp.leave_one_out(make_dataset(seed=5, n_demos=2), LAYOUT, [50])
