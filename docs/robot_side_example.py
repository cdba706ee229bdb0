"""Robot-side use of a model exported from the studio, with ``promp`` alone (no viser).

Replays a recorded movement sample by sample, as a robot would receive it, and every few
samples recognises the primitive, conditions it on what was seen and predicts the rest::

    python -m robots.icub.scenario /tmp/scenario            # or any CSV t,x,y,z,roll,pitch,yaw
    python docs/robot_side_example.py model.json /tmp/scenario/curved/curved_000.csv
"""

import argparse

import numpy as np

from promp.datasets import read_csv_demo
from promp.evidence.pipeline import infer
from promp.inference import Observation
from promp.io import load_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="model JSON exported from the studio's Data tab")
    parser.add_argument("csv", help="a movement to replay: CSV with t and the model's columns")
    parser.add_argument("--every", type=int, default=10, help="infer every N samples")
    parser.add_argument("--observe", default="hand,head", help="observed modalities")
    args = parser.parse_args()

    model = load_model(args.model)
    observed = args.observe.split(",")
    columns = [c for m in model.layout.modalities if m.name in observed for c in m.columns]
    angles = [m.kind == "angle" for m in model.layout.modalities if m.name in observed
              for _ in m.columns]  # fmt: skip
    hand = model.layout.dims(["hand"])
    stream = read_csv_demo(args.csv)  # stands for the robot's sensors

    times, rows = [], []
    for t, row in zip(stream.times, stream.select(columns), strict=True):
        times.append(t)  # one new sample: time (s) and the observed columns
        rows.append(row)
        if len(times) % args.every:
            continue
        values = np.array(rows)
        values[:, angles] = np.unwrap(values[:, angles], axis=0)  # angles must not jump
        obs = Observation(np.array(times), values, tuple(observed))
        try:
            result = infer(model, obs)  # recognise, condition, predict
        except ValueError as exc:  # e.g. a non-finite sample
            print(f"t={t:5.2f} s  no recognition: {exc}")
            continue
        reco, prediction = result.recognition, result.prediction
        end = prediction.mean[-1, hand]
        interval = result.timing.duration  # the predicted end, median and 90 % interval
        probabilities = " ".join(
            f"{p.name}={q:.2f}" for p, q in zip(model.primitives, reco.probabilities, strict=True)
        )
        print(
            f"t={t:5.2f} s  primitive={reco.primitive}  [{probabilities}]  "
            f"duration={prediction.duration:.2f} s [{interval.low:.2f}, {interval.high:.2f}]  "
            f"end=({end[0]:+.3f}, {end[1]:+.3f}, {end[2]:+.3f}) m"
        )


if __name__ == "__main__":
    main()
