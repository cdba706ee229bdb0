"""``python -m promp.live ... --rerun FILE.rrd --mcap FILE.mcap``: a live session kept as a
viewer file while it runs (Rerun; Foxglove, PlotJuggler and ROS 2 tools), on LSL time.

A :class:`ViewerSink` is one more sink of the session (:mod:`promp.live.sinks`: its own
thread, so a slow disk never stalls the prediction; lossless, so a late sink folds outputs
rather than dropping them). What it writes, on the timeline ``lsl_time`` (seconds of the LSL
clock of the predictor's machine, the session's clock, as the inputs' stamps are mapped to
it):

* ``inputs/MODALITY/COLUMN``: every row of every movement as the pipeline saw it (after the
  time base and the mapping's unit conversion: positions in metres, angles in radians), once;
* ``predictions/probability/PRIMITIVE`` (unit 1), ``predictions/phase`` (the share of the
  movement observed, unit 1), ``predictions/time_left`` (s): each prediction at its last
  observed sample's time;
* ``predictions/remainder/MODALITY``: the predicted rest of the ``--remainder`` modality as a
  3-D path (metres), when it is a position of three columns;
* ``events``: every event of the session (a stream's condition, a movement's start and end, a
  decision), at its time.

The rows between movements are not written: the pipeline keeps them only while it looks for a
start. The file is new (never written over one, checked before the session starts, as the
evaluation's ``--rerun`` is) and written as the session runs; it is complete once the session
is closed (Ctrl-C). A session that is killed loses what the writer's library still buffered
(Rerun's file sink, an MCAP chunk): a viewer file is for looking at a session, not its
crash-safe record (the ``--record`` journals are).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from promp.live.predictor import LivePrediction
from promp.live.sinks import Output
from promp.live.source import LiveInput
from promp.model import ProMPModel
from promp.viewers.formats import writer_for
from promp.viewers.new_file import check_new
from promp.viewers.scene_log import Event, Item, Note, SceneLog, Series, Stamp, Strips, Timeline

__all__ = ["LSL_TIME", "NAME", "REMAINDER_COLOR", "session_log", "SessionItems", "ViewerSink"]

LSL_TIME = Timeline("lsl_time", "seconds",
                    "the LSL clock (local_clock) of the predictor's machine, seconds")  # fmt: skip
REMAINDER_COLOR = (230, 120, 30)
NAME = "promp-live"


class SessionItems:
    """What each output of a session adds to its viewer file (see the module docstring): the
    items of one :class:`promp.live.sinks.Output` (:meth:`of`), remembering each movement's
    rows already written.

    Parameters
    ----------
    model : ProMPModel
    inputs : sequence of LiveInput
        The session's inputs, in the order of the rows' columns.
    """

    def __init__(self, model: ProMPModel, inputs: Sequence[LiveInput]):
        self.model = model
        self.columns: list[tuple[str, str, str]] = []  # (path, label, unit) of each row column
        for live_input in inputs:
            modality = model.layout.modality(live_input.name)
            for column in modality.columns:
                self.columns.append((f"inputs/{modality.name}/{column}",
                                     f"{modality.name} {column}", modality.unit))  # fmt: skip
        self.written: dict[int, int] = {}  # movement number -> its rows written

    def declared(self) -> list[Item]:
        """Every series the file will hold, empty (what a viewer's layout is made from), and a
        note on the units."""
        names = [p.name for p in self.model.primitives]
        empty = np.zeros(0)
        items: list[Item] = [Note("about", "A live session of `python -m promp.live`: inputs, "
                                  "predictions and events on `lsl_time` (seconds of the LSL "
                                  "clock). Positions in metres, angles in radians.")]  # fmt: skip
        items += [Series(path, label, unit, LSL_TIME.name, empty, empty)
                  for path, label, unit in self.columns]  # fmt: skip
        items += [Series(f"predictions/probability/{n}", f"p({n})", "1", LSL_TIME.name, empty,
                         empty) for n in names]  # fmt: skip
        items += [Series("predictions/phase", "observed share", "1", LSL_TIME.name, empty, empty),
                  Series("predictions/time_left", "time left", "s", LSL_TIME.name, empty, empty)]
        return items

    def of(self, output: Output) -> list[Item]:
        """The items ``output`` adds: its movements' new rows, its predictions, its events."""
        items: list[Item] = []
        movements = [b.movement for b in output.boundaries if b.movement is not None]
        if output.movement is not None:
            movements.append(output.movement)
        for movement in movements:
            items += self._rows(movement)
        for prediction in output.predictions:
            items += self._prediction(prediction)
        items += [Event("events", e.text, Stamp(LSL_TIME.name, float(e.time)))
                  for e in output.events]  # fmt: skip
        return items

    def _rows(self, movement) -> list[Item]:
        start = self.written.get(movement.number, 0)
        if len(movement) <= start:
            return []
        self.written[movement.number] = len(movement)
        times, values = movement.times[start:], movement.values[start:]
        return [Series(path, label, unit, LSL_TIME.name, times, values[:, j])
                for j, (path, label, unit) in enumerate(self.columns)]  # fmt: skip

    def _prediction(self, p: LivePrediction) -> list[Item]:
        at = [float(p.last)]
        items: list[Item] = [
            Series(f"predictions/probability/{primitive.name}", f"p({primitive.name})", "1",
                   LSL_TIME.name, at, [float(value)])  # fmt: skip
            for primitive, value in zip(self.model.primitives, p.probabilities, strict=True)
        ]
        items.append(Series("predictions/phase", "observed share", "1", LSL_TIME.name, at,
                            [p.phase.value]))  # fmt: skip
        items.append(Series("predictions/time_left", "time left", "s", LSL_TIME.name, at,
                            [p.remaining.value]))  # fmt: skip
        r = p.remainder
        if r is not None and r.mean.shape[0] >= 2 and r.mean.shape[1] == 3 \
                and self.model.layout.modality(r.modality).unit == "m":  # fmt: skip
            items.append(Strips(f"predictions/remainder/{r.modality}", (r.mean,),
                                REMAINDER_COLOR, at=Stamp(LSL_TIME.name, at[0])))  # fmt: skip
        return items


def session_log(items: Sequence[Item]) -> SceneLog:
    """A live session's items as a :class:`promp.viewers.scene_log.SceneLog` (what a viewer
    file's layout is described from)."""
    return SceneLog(NAME, (LSL_TIME,), tuple(items))


class ViewerSink:
    """A live session's sink writing a new viewer file as it runs (see the module docstring).

    Parameters
    ----------
    path : Path or str
        A new ``.rrd`` (Rerun) or ``.mcap`` file (nothing is written over an existing one).
    model : ProMPModel
    inputs : sequence of LiveInput

    Raises
    ------
    ValueError
        ``path`` exists or has another suffix; the format's extra is not installed.
    """

    lossless = True

    def __init__(self, path: Path | str, model: ProMPModel, inputs: Sequence[LiveInput]):
        suffix = Path(path).suffix.lower()
        writer = writer_for(suffix)  # raises on another suffix, or a missing extra
        self.path = check_new(path, suffix)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.name = f"{'Rerun' if suffix == '.rrd' else 'MCAP'} file"
        self.items = SessionItems(model, inputs)
        self._writer = writer(self.path, NAME, (LSL_TIME,))
        declared = self.items.declared()
        self._writer.describe(session_log(declared))
        self._write(declared)

    def view(self, output: Output) -> Output | None:
        busy = output.events or output.predictions or output.boundaries or output.movement
        return output if busy else None

    def take(self, output: Output) -> tuple:
        self._write(self.items.of(output))
        return ()

    def _write(self, items: Sequence[Item]) -> None:
        for item in items:
            self._writer.write(item)
        flush = getattr(self._writer, "flush", None)  # the MCAP writer keeps items until then
        if flush is not None and items:  # (bounded memory over a long session)
            flush()

    def close(self) -> None:
        self._writer.close()
