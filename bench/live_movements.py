"""The movements a live session finds, over LSL on the loopback: takes in, movements out, and
the recognition of each, on the three shared sets as recorded and on guided, busy copies.

For each shared set, each class's first K takes (by name) are replayed and the rest learned
from (the hand, fixed settings). The replayed takes go one after the other through an LSL
outlet (100 Hz declared, mm), each held still 1.5 s before and after (the hand jumps, in one
step, between takes), into a :class:`promp.live.session.LiveSession` started by stillness on
its own threads (the pipeline of ``python -m promp.live``). Two variants:

* ``recorded``: the takes as they are, each sample pushed when due;
* ``guided+busy``: every take (learned from and replayed) slowed in its middle below the idle
  speed, as a guided arm slows near a waypoint (0.5-1 s learned from, 0.5-0.9 s replayed:
  :func:`tests.live_fakes.slowed_middle`), and pushed by a sender that sleeps 0.1-0.35 s now
  and then and pushes its backlog at once, stamped at that push: a pause, then the backlog
  20 us apart (:func:`tests.live_fakes.late_pushes`, :func:`tests.live_fakes.replay_over_lsl`).

Printed per set and variant: ``takes``, ``movements`` (all the session found), ``one_each``
(takes that gave exactly one movement), ``split_offline`` (replayed takes the stillness rule
alone, with no pause learned, cuts in two or more: :func:`promp.stillness.moving_spans`),
``right`` / ``wrong`` (each movement's last prediction within its rows, against the take's
class: the predictions made while the stillness that ended it went on observed still rows it
does not keep),
``as_offline`` (its primitive equals :func:`promp.infer` on the take as the same rule
cuts it offline from the held take: the live movement's rows, on the stamps as sent),
``as_whole`` and ``whole_right`` (the offline answer on the whole take, as the learning saw
its takes: equal to the live one, and right), and the longest pause learned. Every stream
stays on the loopback (``LSLAPICFG`` is ``tests/lsl_loopback.cfg``).

Run: ``.venv/bin/python bench/live_movements.py [--sets heights flt shapes]``. The last line
is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
os.environ["LSLAPICFG"] = str(REPO / "tests" / "lsl_loopback.cfg")  # before pylsl loads
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from promp.data import Layout, Modality  # noqa: E402
from promp.datasets import load_records_dataset  # noqa: E402
from promp.evidence.pipeline import infer  # noqa: E402
from promp.learn import fit  # noqa: E402
from promp.live.segmenter import Segmenter, StillRule  # noqa: E402
from promp.model import Settings  # noqa: E402
from promp.observation import Observation  # noqa: E402
from promp.stillness import moving_spans  # noqa: E402
from tests.live_fakes import guided_split, held, replay_over_lsl  # noqa: E402

DATA = REPO.parent / "shared" / "data"
SETS = {"heights": ("lab-records-heights", 4), "flt": ("lab-records-flt", 4),
        "shapes": ("lab-records-flt-shapes", 2)}  # fmt: skip
LAYOUT = Layout((Modality("hand", ("x", "y", "z"), unit="m"),))
SETTINGS = Settings(n_basis=7, width=1.0, noise_scale=1.5, duration_temperature=1.0,
                    recognition="promp")
VARIANTS = {"recorded": (None, None, False), "guided+busy": ((0.5, 1.0), (0.5, 0.9), True)}


def rule_pause(rule: StillRule) -> float:
    """The still time that ends a movement before any prediction (the longest learned)."""
    return Segmenter("still", 3, [(slice(0, 3), "m")], rule=rule).allowed_pause()


def run(name: str, variant: str, seed: int = 0) -> dict:
    folder, per_class = SETS[name]
    slow, replayed_slow, late = VARIANTS[variant]
    train, replayed = guided_split(load_records_dataset(DATA / folder), per_class, seed, slow,
                                   replayed_slow)  # fmt: skip
    model = fit(train, LAYOUT, SETTINGS)
    stream = f"BenchMovements-{os.getpid()}-{name}-{variant.replace('+', '-')}"
    ended, predictions, spans = replay_over_lsl(model, replayed, stream,
                                                np.random.default_rng(seed + 1), late)  # fmt: skip
    ends = {m.number: float(m.times[-1]) for m in ended}
    # the latest prediction inside the movement as it was cut (those made while the stillness
    # that ended it went on observed still rows the movement does not keep)
    final = {p.movement: p for p in predictions if p.last <= ends.get(p.movement, np.inf) + 1e-9}
    counts = {"takes": len(replayed), "movements": len(ended), "one_each": 0, "split_offline": 0,
              "right": 0, "wrong": 0, "as_offline": 0, "as_whole": 0, "whole_right": 0,
              "unpredicted": 0}  # fmt: skip
    rule = StillRule.of(model, ["hand"])
    for (klass, demo), (pushed, _) in zip(replayed, spans, strict=True):
        xyz = demo.select(["x", "y", "z"])
        counts["split_offline"] += len(moving_spans(demo.times, [(xyz, "m")])) > 1
        whole = infer(model, Observation(demo.times - demo.times[0], xyz, ("hand",))).primitive
        counts["whole_right"] += whole == klass
        around = held(demo, 1.5, 1.5)
        hand = around.select(["x", "y", "z"])
        cuts = moving_spans(around.times, [(hand, "m")], rule_pause(rule), margin_s=rule.before,
                            margin_after_s=rule.after)  # fmt: skip
        a, b = cuts[0] if len(cuts) == 1 else (0, around.n_samples)
        cut = infer(model, Observation(around.times[a:b] - around.times[a], hand[a:b],
                                       ("hand",))).primitive  # fmt: skip
        mine = [m for m in ended if pushed[0] - 1.4 < m.times[0] and m.times[-1] < pushed[-1] + 1.4]
        counts["one_each"] += len(mine) == 1
        for movement in mine:
            p = final.get(movement.number)
            if p is None:
                counts["unpredicted"] += 1
                continue
            counts["right" if p.primitive == klass else "wrong"] += 1
            counts["as_offline"] += p.primitive == cut
            counts["as_whole"] += p.primitive == whole
    counts["longest_pause_learned_s"] = round(max(p.pause(["hand"]) for p in model.primitives), 3)
    return counts


def main(sets=tuple(SETS)) -> dict:
    began = time.monotonic()
    out = {}
    for name in sets:
        for variant in VARIANTS:
            out[f"{name} {variant}"] = run(name, variant)
            print(f"{name:8s} {variant:12s} {out[f'{name} {variant}']}", flush=True)
    out["seconds"] = round(time.monotonic() - began, 1)
    out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sets", nargs="+", choices=tuple(SETS), default=list(SETS))
    args = parser.parse_args()
    print(json.dumps(main(tuple(args.sets))))
