"""The README's pictures of an imported real set, taken in headless Chromium as a user sees them.

    .venv/bin/python docs/pictures.py ../shared/data/lab-records-heights docs/

Reads the lab records into a new workspace (in a temporary folder), starts a studio on it and
saves ``real_teach.png`` (the demonstrations and their 90 % tubes, the panel on the line that
says what the tubes are and the share of samples inside them), ``real_infer.png`` (a
held-out recording at 40 % observed: the phase and the predicted end with their intervals) and
``real_data.png`` (two leave-one-out runs at 40 %, ML and model alpha, kept in the workspace and
compared). Takes about five minutes on two cores; needs Debian's chromium.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.io.dataset_import import placed, read_folder  # noqa: E402
from app.io.hand_frame import ICUB_FRAME  # noqa: E402
from app.io.workspace import Workspace  # noqa: E402
from tests.browser import choose, click, close_notifications, open_tab, settled_screenshot  # noqa: E402
from tests.conftest import CHROMIUM, CHROMIUM_FLAGS, open_page, start_studio, wait_until  # noqa: E402

PRIMITIVE, DEMO, PERCENT = "top", "person2_record3", 40


def until(predicate, what: str):
    return wait_until(predicate, timeout=600.0, what=what)


def panel_of(studio, name: str):
    from app.panels.data import DataPanel
    from app.panels.infer import InferPanel
    from app.panels.teach import TeachPanel

    kind = {"teach": TeachPanel, "infer": InferPanel, "data": DataPanel}[name]
    return next(p for p in studio.panels if isinstance(p, kind))


def text_input(page, handle):
    return page.locator(
        f"label[for='{handle._impl.uuid}'] >> xpath=ancestor::*[.//input][1]//input"
    )


def teach(page, studio, out: Path) -> None:
    open_tab(page, "Teach")
    page.get_by_text("demonstration(s) of").first.wait_for()
    until(lambda: studio.session.snapshot().model is not None, "the model")
    note = page.get_by_text("Tubes: at each moment").first
    note.wait_for()
    page.get_by_text("measured:").first.wait_for()
    note.evaluate("e => e.scrollIntoView({block: 'start'})")
    page.mouse.move(5, 450)
    settled_screenshot(page, out / "real_teach.png", timeout=300)


def infer(page, studio, out: Path) -> None:
    panel = panel_of(studio, "infer")
    open_tab(page, "Infer")
    controls = panel.controls
    choose(page, controls.primitive, PRIMITIVE)
    choose(page, controls.demo, DEMO)
    controls.percent.value = PERCENT

    def shown():
        view = panel.view
        ok = view is not None and view.result is not None and view.state.percent == PERCENT
        return ok and view.state.demo == DEMO

    until(shown, "the inference at 40 %")
    page.get_by_text("Phase: observed").first.wait_for()
    page.mouse.move(5, 450)
    settled_screenshot(page, out / "real_infer.png", timeout=300)


def data(page, studio, out: Path) -> None:
    panel = panel_of(studio, "data")
    evaluation, runs = panel.evaluation, panel.runs
    controls = evaluation.controls
    open_tab(page, "Data")
    for alpha, name in (("ML", "ML alpha"), ("model", "model alpha")):
        for handle, value in ((controls.percents_text, "40"), (controls.run_name_text, name)):
            text_input(page, handle).fill(value)
            until(lambda h=handle, v=value: h.value == v, f"{value!r} typed")
        page.locator(f"[id='{controls.alpha_dropdown._impl.uuid}']").scroll_into_view_if_needed()
        choose(page, controls.alpha_dropdown, alpha)
        kept, previous = len(runs._listed or {}), evaluation.job
        click(page, "Run leave-one-out evaluation")
        job = until(lambda p=previous: evaluation.job is not p and evaluation.job, "the run")
        until(lambda j=job: j.finished, "the evaluation to end")
        until(lambda k=kept: len(runs._listed or {}) == k + 1, f"run {name!r} listed")
    close_notifications(page)
    labels = list(runs._choices)  # newest first: model, ML
    page.locator(f"[id='{runs.controls.choice._impl.uuid}']").scroll_into_view_if_needed()
    choose(page, runs.controls.choice, labels[1])
    click(page, "Open run")
    page.get_by_text("Saved run:").first.wait_for()
    choose(page, runs.controls.other, labels[0])
    click(page, "Compare runs")
    page.get_by_text("Made differently").first.wait_for()
    section = page.get_by_text("Saved runs", exact=True).first
    section.evaluate("e => e.scrollIntoView({block: 'start'})")
    page.mouse.move(5, 450)
    settled_screenshot(page, out / "real_data.png", timeout=300)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a lab-records folder")
    parser.add_argument("out", type=Path, help="where the PNG files go")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        workspace = Path(tmp) / args.dataset.name
        data_, summary = read_folder(args.dataset, "records")
        # as the Data tab imports it: in the iCub's frame, recorded elsewhere (no simulated
        # table and bins drawn)
        Workspace.create(workspace, placed(data_, ICUB_FRAME))
        print(f"workspace: {summary.describe()}", flush=True)
        studio = start_studio(workspace)
        try:
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
                page, _ = open_page(browser, studio, width=1600, height=1000, dpr=1.0)
                page.set_default_timeout(300_000)
                teach(page, studio, args.out)
                infer(page, studio, args.out)
                data(page, studio, args.out)
                browser.close()
        finally:
            studio.stop()
    print(f"saved real_teach.png, real_infer.png, real_data.png in {args.out}")


if __name__ == "__main__":
    main()
