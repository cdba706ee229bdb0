"""The inputs of the Data tab's "Import dataset" (format, modalities, a rig's options) and the
text of its preview."""

from __future__ import annotations

from app.io.dataset_import import DatasetSummary, DatasetUpload, compact_columns
from app.ui.context import PanelGui
from app.ui.text import escape
from promp.datasets import FORMATS, modality_specs, parse_modalities
from promp.rigs import CUTS, RIG_FORMATS, RigOptions

# Under the modalities' field: its syntax, in words a reader sees without hovering.
SYNTAX = (
    "One modality per line: `NAME=COLUMN,COLUMN,...`, e.g. `hand=x,y,z` then `emg=e0,e1,e2` "
    "(`;` or spaces also separate them); for recordings `NAME=STREAM:FIELD,...[@UNIT]`, e.g. "
    "`hand=/pose:pose.position.{x,y,z}@mm`."
)


def one_per_line(text: str) -> str:
    """A mapping's modalities, one per line."""
    return "\n".join(modality_specs(text))


class ImportInputs:
    """The reading's inputs (format, modalities; for a rig's recordings the cut, the rate and
    the marker stream), shown once an upload is previewed."""

    def __init__(self, gui: PanelGui):
        self.quiet = False  # set while the code itself changes the inputs
        self.format = gui.add_dropdown("Format", FORMATS, visible=False)
        self.modalities = gui.add_text(
            "Modalities", "", multiline=True, visible=False,
            hint="NAME=COL,COL,... one per line (or separated by ';' or spaces); for recordings "
            "NAME=STREAM:FIELD,...[@UNIT] (a topic, stream, port or marker, then fields: "
            "pose.position.{x,y,z}; @mm and @deg are converted). 'hand' (x, y, z in metres, the "
            "robot's root frame) is drawn in 3D; other modalities get their own charts",
        )  # fmt: skip
        self.syntax = gui.add_markdown(SYNTAX, visible=False)
        self.cut = gui.add_dropdown(
            "Cut", CUTS, visible=False,
            hint="How a recording becomes demonstrations: by its markers, at its still "
            "periods, one per file (in <class>/ folders), or auto (markers when it has some)",
        )  # fmt: skip
        self.rate = gui.add_number(
            "Rate (Hz)", 0.0, min=0.0, max=10000.0, step=1.0, visible=False,
            hint="The time base the streams are interpolated on; 0: the slowest stream's own "
            "time stamps",
        )  # fmt: skip
        self.markers = gui.add_text(
            "Marker stream", "", visible=False,
            hint="The stream to cut by when a recording has several; empty: its only one",
        )  # fmt: skip
        self.handles = (self.format, self.modalities, self.cut, self.rate, self.markers)

    def set(self, format: str, modalities: str, reset: bool = False) -> None:
        """Set the inputs without re-reading; ``reset`` also puts the recordings' options back
        to their defaults (a new upload)."""
        self.quiet = True
        try:
            self.format.value = format
            self.modalities.value = modalities
            if reset:
                self.cut.value, self.rate.value, self.markers.value = CUTS[0], 0.0, ""
        finally:
            self.quiet = False

    def show(self, visible: bool) -> None:
        """The inputs (the recordings' options only for a rig's format), or none."""
        rig = visible and self.format.value in RIG_FORMATS
        self.format.visible = self.modalities.visible = self.syntax.visible = visible
        self.cut.visible = self.rate.visible = self.markers.visible = rig

    def options(self) -> tuple[dict | None, RigOptions]:
        """The modalities given (None: guessed) and the recordings' options.

        Raises
        ------
        ValueError
            A mapping that does not parse.
        """
        text = self.modalities.value.strip()
        rate = float(self.rate.value) or None
        rig = RigOptions(self.cut.value, rate, self.markers.value.strip())
        return (parse_modalities(text) if text else None), rig


def preview_text(upload: DatasetUpload, summary: DatasetSummary) -> str:
    """What an upload reads as: its format, primitives, columns, those no modality uses, what
    was ignored, how a rig's recordings were read and the demonstrations found, the checks'
    findings (markdown)."""
    lines = [
        f"**{escape(upload.filename)}** ({summary.format}): {escape(summary.describe())}",
        f"Columns: {escape(', '.join(summary.columns))}",
    ]
    if summary.unused:
        lines.append(f"**Not used:** {escape(compact_columns(summary.unused))} (name them in "
                     "a modality to use them)")  # fmt: skip
    if upload.ignored:
        lines.append(f"Ignored: {escape(', '.join(upload.ignored))}")
    if summary.mapping:  # a rig's recordings: how they were read, what they became
        lines += [escape(line) for line in summary.notes]
        lines += ["Demonstrations found:"]
        lines += [escape(line) for line in summary.demonstrations_lines()]
    lines += [escape(line) for line in summary.findings_lines()]
    return "  \n".join(lines)
