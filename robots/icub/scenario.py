"""Simulated demonstrations of the paper's experiment: the robot's hand and the partner's head.

The experiment of Dermy, Charpillet and Ivaldi: the robot's left hand carries an object from the
same start (the pick position) to the same drop point above a bin along two different movements,
**curved** and **direct**. Their beginnings are the same (both lift the object first), so early
hand observations are ambiguous; the partner's head, which looks ahead to where the hand is
going, tells them apart. ``--third`` adds **second_bin**, a direct movement to the other bin.

Each demonstration is built like a human-guided one:

- Path: the **lift** is common to all: from the grasp straight up to a lift point 11 cm above
  it. Then ``direct`` turns towards the drop point and carries the object there (rising ~4 cm
  more on the way); ``curved`` keeps rising and arches over an apex 20 cm above the middle of
  the lift-to-drop segment and 8 cm towards the robot's midline, then comes down onto the drop
  point. The path is smooth through these via points (:func:`robots.icub.motion.smooth_path`),
  and its pieces depend only on their end via points, so the lift is exactly the same curve
  whichever movement follows it. Via points are jittered by ~1.2 cm (the start, the end and the
  lift point's horizontal position by 3 mm), once per demonstration.
- Timing: minimum jerk along the arc length ``s``, the duration ``T`` drawn uniformly within
  +-30 % of 3 s. Early hand observations are only ambiguous if the first ~40 % of the *time*
  coincides, which one minimum-jerk law over paths of different lengths would not give (the
  curved path, nearly twice as long, would be ahead from the first sample). So every movement
  starts with the law of the plain carry (through the same grasp, lift and drop points) and
  covers the extra length of a detour with a second minimum-jerk submovement from
  ``shared_fraction`` (0.45) on (:func:`robots.icub.motion.arc_progress`). ``direct`` and
  ``second_bin`` are then exactly minimum jerk; all start and end at rest. The hand reaches the
  end of the lift at ~42 % of the movement, so the hands of curved and direct coincide (up to
  the per-demonstration jitter) until ~40 %; then direct turns towards the bin while curved
  keeps rising, and from 45 % curved speeds up to cover its detour: the mean hands are ~1.5 cm
  apart at 45 %, ~6 cm at 50 % and ~19 cm at 60-70 %. (Starting the extra submovement a little
  after the direct movement starts turning, rather than at the same instant, keeps the very
  beginning of the divergence out of the first 40 %.)
- Reachability: every sample goes through the IK of the left arm with the **torso locked** (the
  arm alone is guided, as in kinesthetic teaching), warm-started along the path; the hand
  positions written are the forward kinematics of the IK solutions, so the data is exactly what
  the robot can do.
- Head: the partner's gaze leads the hand from landmark to landmark, as people's gaze does in
  manipulation (:mod:`robots.icub.gaze`). The partner looks at the object until it leaves
  the table (the hand has risen 2 mm, ~9 % of the movement), then after a latency of 0-0.15 s
  at the next landmark: the apex for ``curved``, the drop point above the bin otherwise. For
  ``curved`` the gaze moves on from the apex to the drop point 0.1-0.3 s before the hand
  reaches the apex (at ~66 % of the movement). The head follows the gaze with a first-order
  lag of 0.1-0.2 s. Seen from the partner, the apex is ~12 deg higher (pitch) and ~10 deg more
  to the partner's left (yaw) than the drop point, so from ~15 % to ~60 % of the movement,
  while the hands still coincide or have only begun to part, the mean head angles of the two
  movements differ by ~15 deg, several times their spread between demonstrations (2-4 deg per
  angle); the yaw at the end tells which bin the hand goes to.
- Head-pose estimator noise: 2 deg white noise plus a slow drift (Ornstein-Uhlenbeck, 1.5 deg,
  time constant 1 s) on each angle, a small per-demonstration roll bias and head-position
  offset (1 cm, which shifts every angle a little).

Why these values. The apex is about as far from the bin, seen from the partner, as the left arm
reaches with the torso locked (with room for 5 standard deviations of its jitter), so that the
head's early difference is several times its spread. The gaze switch is tied to the lift-off, an
event of the movement (gaze in manipulation is time-locked to such events), rather than to a time
after the start: every demonstration then switches at about the same phase, ~10-15 %, so the head
is uninformative at 10 % and clearly informative by 20 %. A switch spread over time (0.1-0.4 s
after the start) gave a head signal that was still ambiguous at 20 % in the short demonstrations,
where the combined hand and head did worse than the head alone: with few demonstrations per
primitive, the very clean hand adds evidence of its own that is spurious while the paths coincide
(chiefly which primitive has a training duration closest to the observed one), and it outweighs a
weak head signal. With ``python -m promp.evaluate`` (ML alpha, 20 demonstrations per primitive,
seeds 0-3) the head recognises without error from 20 % observed, the hand alone stays at chance
until 40 % and is without error from 50 %, and hand and head together recognise as the head does
(at most one more error, at 20 %).

All columns share one time base, sampled at a fixed rate (default 40 Hz, allowed 30-50 Hz).
Deterministic: demonstration ``i`` of primitive ``k`` draws from ``SeedSequence([seed, k, i])``,
so adding the third primitive or more demonstrations does not change the others.

Command line::

    python -m robots.icub.scenario OUT_DIR [--seed 0] [--demos 20] [--third] [--rate 40]

writes ``OUT_DIR/<primitive>/<primitive>_<i>.csv`` (header ``t,x,y,z,roll,pitch,yaw``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from promp.data import Demonstration
from promp.datasets import write_csv_demo
from robots.icub.gaze import head_angles_following, landmark_gaze
from robots.icub.ik import solve_ik
from robots.icub.kinematics import ArmChain, load_arm
from robots.icub.layout import STUDIO_LAYOUT
from robots.icub.model import DEFAULT_ROBOT
from robots.icub.motion import arc_progress, smooth_path
from robots.icub.scene import DEFAULT_SCENE, Scene

PRIMITIVES = ("curved", "direct")
THIRD_PRIMITIVE = "second_bin"
ALL_PRIMITIVES = (*PRIMITIVES, THIRD_PRIMITIVE)
COLUMNS = STUDIO_LAYOUT.columns  # x, y, z, roll, pitch, yaw
DEMOS_RANGE = (2, 1000)
RATE_RANGE_HZ = (30.0, 50.0)
DEFAULT_RATE_HZ = 40.0
# Largest distance between a sample of the planned path and the IK's hand position.
MAX_TRACKING_ERROR_M = 1e-3


@dataclass(frozen=True)
class ScenarioParams:
    """How the simulated teacher and partner behave (lengths in m, times in s, angles in deg).

    Attributes
    ----------
    base_duration, duration_spread : float
        Durations are uniform in ``base_duration * (1 +- duration_spread)``.
    lift : float
        Height of the lift point above the grasp: the first part of every movement.
    shared_fraction : float
        Fraction of the movement's duration, in (0, 1), from which the curved movement's extra
        submovement starts; before it, every movement has the timing of the direct one.
    curve_rise, curve_side, curve_out : float
        The curved movement's apex: this much above, towards the robot's midline (+y) and
        towards the partner (-x) from the middle of the straight lift-to-drop segment.
    via_jitter, end_jitter : float
        Standard deviation of the via points' jitter; ``end_jitter`` for the start, the end and
        the lift point's horizontal position.
    lift_off : float
        How far the hand rises (the object leaves the table) before the gaze leaves the object.
    gaze_latency : (float, float)
        Range of the delay after that lift-off at which the gaze moves to the next landmark,
        drawn once per demonstration.
    gaze_lead, head_lag : (float, float)
        Ranges of how long before the hand reaches the apex the gaze moves on to the drop
        point, and of the head's first-order time constant, drawn once per demonstration.
    head_noise_deg, head_drift_deg, head_drift_time : float
        White noise and slow drift (Ornstein-Uhlenbeck: stationary std, time constant) of the
        estimated head angles.
    roll_bias_deg, head_position_jitter : float
        Per-demonstration roll offset and head position offset (standard deviations).
    """

    base_duration: float = 3.0
    duration_spread: float = 0.3
    lift: float = 0.11
    shared_fraction: float = 0.45
    curve_rise: float = 0.20
    curve_side: float = 0.08
    curve_out: float = 0.0
    via_jitter: float = 0.012
    end_jitter: float = 0.003
    lift_off: float = 0.002
    gaze_latency: tuple[float, float] = (0.0, 0.15)
    gaze_lead: tuple[float, float] = (0.1, 0.3)
    head_lag: tuple[float, float] = (0.10, 0.20)
    head_noise_deg: float = 2.0
    head_drift_deg: float = 1.5
    head_drift_time: float = 1.0
    roll_bias_deg: float = 2.0
    head_position_jitter: float = 0.01

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            values = value if isinstance(value, tuple) else (value,)
            if not all(np.isfinite(v) and v >= 0.0 for v in values):
                raise ValueError(f"ScenarioParams.{name} must be finite and >= 0, got {value!r}")
        if self.base_duration <= 0.0 or not self.duration_spread < 1.0:
            raise ValueError("ScenarioParams needs base_duration > 0 and duration_spread < 1")
        if self.lift <= 0.0 or not 0.0 < self.shared_fraction < 1.0:
            raise ValueError("ScenarioParams needs lift > 0 and 0 < shared_fraction < 1")
        for name in ("gaze_latency", "gaze_lead", "head_lag"):
            low, high = getattr(self, name)
            if not low <= high:
                raise ValueError(f"ScenarioParams.{name} must be a (low, high) range")
        if self.head_lag[0] <= 0.0 or self.head_drift_time <= 0.0:
            raise ValueError("ScenarioParams needs head_lag > 0 and head_drift_time > 0")


def _check_int(value: object, name: str, low: int, high: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < low or (high is not None and value > high):
        bounds = f">= {low}" if high is None else f"between {low} and {high}"
        raise ValueError(f"{name} must be {bounds}, got {value}")
    return int(value)


def _check_rate(rate_hz: object) -> float:
    try:
        rate = float(rate_hz)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"rate_hz must be a number, got {rate_hz!r}") from exc
    low, high = RATE_RANGE_HZ
    if not np.isfinite(rate) or not low <= rate <= high:
        raise ValueError(f"rate_hz must be between {low:g} and {high:g} Hz, got {rate_hz!r}")
    return rate


def via_points(
    primitive: str, scene: Scene, rng: np.random.Generator, params: ScenarioParams
) -> np.ndarray:
    """The jittered via points of one demonstration of ``primitive``, shape (n_via, 3).

    The grasp, the lift point, for ``curved`` the apex, and the drop point.
    """
    if primitive not in ALL_PRIMITIVES:
        raise ValueError(f"unknown primitive {primitive!r}; known: {', '.join(ALL_PRIMITIVES)}")
    pick = np.array(scene.pick_position, dtype=float)
    drop = scene.bins[1 if primitive == THIRD_PRIMITIVE else 0].drop_position
    lift = pick + np.array([0.0, 0.0, params.lift])
    points = [pick, lift]
    if primitive == "curved":
        offset = np.array([-params.curve_out, params.curve_side, params.curve_rise])
        points.append(0.5 * (lift + drop) + offset)
    points.append(drop)
    # Start and end vary little (same object, same bin); the lift mostly in height; the apex
    # freely. One draw per demonstration: the path's shape is consistent within it.
    jitter = np.full((len(points), 3), params.via_jitter)
    jitter[[0, -1]] = params.end_jitter
    jitter[1, :2] = params.end_jitter
    return np.array(points) + rng.normal(size=(len(points), 3)) * jitter


def track_with_ik(arm: ArmChain, targets: np.ndarray, label: str) -> np.ndarray:
    """IK solutions (torso locked) along ``targets`` (n, 3), each warm-started from the last.

    Returns the joint configurations, shape (n, n_joints).

    Raises
    ------
    ValueError
        If a target is out of the arm's reach (more than 1 mm away).
    """
    q = solve_ik(arm, targets[0], arm.rest, lock_torso=True, restarts=5).q
    joints = np.empty((targets.shape[0], q.shape[0]))
    for k, target in enumerate(targets):
        result = solve_ik(arm, target, q, lock_torso=True, position_tolerance=1e-5)
        if result.position_error_m > MAX_TRACKING_ERROR_M:
            raise ValueError(
                f"{label}: the path leaves the left arm's reach at {np.round(target, 3).tolist()} "
                f"(closest {1e3 * result.position_error_m:.1f} mm away)"
            )
        q = result.q
        joints[k] = q
    return joints


def generate_demonstration(
    arm: ArmChain,
    scene: Scene,
    primitive: str,
    rng: np.random.Generator,
    rate_hz: float = DEFAULT_RATE_HZ,
    params: ScenarioParams | None = None,
    name: str = "",
) -> Demonstration:
    """One demonstration of ``primitive``: columns x, y, z (m), roll, pitch, yaw (rad)."""
    params = ScenarioParams() if params is None else params
    rate = _check_rate(rate_hz)
    points = via_points(primitive, scene, rng, params)
    duration = params.base_duration * rng.uniform(
        1.0 - params.duration_spread, 1.0 + params.duration_spread
    )
    n = int(round(duration * rate)) + 1
    times = np.arange(n) / rate
    path = smooth_path(points)
    # The timing of the plain carry through the same grasp, lift and drop points.
    direct_length = smooth_path(points[[0, 1, -1]]).length if len(points) > 3 else path.length
    tau = times / times[-1]
    progress = arc_progress(tau, path.length, direct_length, params.shared_fraction)
    joints = track_with_ik(arm, path.at(progress), name or primitive)
    hand = np.array([arm.position(q) for q in joints])

    head_position = np.asarray(scene.partner_head) + rng.normal(
        scale=params.head_position_jitter, size=3
    )
    # Landmarks: the object (where the hand starts), the apex, the drop point.
    landmarks = np.vstack([points[:1], points[2:]])
    knot_tau = np.interp(path.knot_arc[[0, *range(2, len(points))]], progress, tau)
    lifted = float(np.interp(params.lift_off, progress, times))
    shift = lifted + rng.uniform(*params.gaze_latency)
    lead = rng.uniform(*params.gaze_lead)
    gaze = landmark_gaze(times, landmarks, knot_tau * times[-1], shift, lead)
    head = head_angles_following(times, gaze, head_position, rng, params)
    return Demonstration(times, np.column_stack([hand, head]), COLUMNS, name=name)


def generate_scenario(
    seed: int = 0,
    n_demos: int = 20,
    third: bool = False,
    rate_hz: float = DEFAULT_RATE_HZ,
    *,
    robot: str = DEFAULT_ROBOT,
    scene: Scene = DEFAULT_SCENE,
    params: ScenarioParams | None = None,
) -> dict[str, list[Demonstration]]:
    """The simulated dataset: {primitive: [demonstrations]} (see the module docstring).

    Parameters
    ----------
    seed : int
        Random seed, >= 0; the same seed gives the same dataset.
    n_demos : int
        Demonstrations per primitive, 2 to 1000.
    third : bool
        Add the third primitive (``second_bin``).
    rate_hz : float
        Sampling rate shared by all columns, 30 to 50 Hz.
    robot : str
        ``icub-models`` robot whose left arm performs the movements.
    scene : Scene
        Where the object, the bins and the partner are.
    params : ScenarioParams, optional
        Behaviour of the teacher and the partner.

    Returns
    -------
    dict of str to list of Demonstration
        ``curved`` and ``direct`` (and ``second_bin``), ``n_demos`` each, named
        ``<primitive>_<i>``, columns ``x, y, z, roll, pitch, yaw``.

    Raises
    ------
    ValueError
        For a seed < 0, a demo count or rate out of range, an unknown robot, a URDF without the
        left-arm chain, a scene without the bins needed or that the arm cannot reach.
    """
    seed = _check_int(seed, "seed", 0)
    n_demos = _check_int(n_demos, "n_demos", *DEMOS_RANGE)
    rate = _check_rate(rate_hz)
    params = ScenarioParams() if params is None else params
    primitives = ALL_PRIMITIVES if third else PRIMITIVES
    needed_bins = 2 if third else 1
    if len(scene.bins) < needed_bins:
        raise ValueError(
            f"the scene has {len(scene.bins)} bin(s); {needed_bins} needed"
            + (" for the third primitive" if third else "")
        )
    arm = load_arm(robot)
    width = max(3, len(str(n_demos - 1)))
    dataset: dict[str, list[Demonstration]] = {}
    for primitive in primitives:
        k = ALL_PRIMITIVES.index(primitive)
        dataset[primitive] = [
            generate_demonstration(
                arm,
                scene,
                primitive,
                np.random.default_rng(np.random.SeedSequence([seed, k, i])),
                rate,
                params,
                name=f"{primitive}_{i:0{width}d}",
            )
            for i in range(n_demos)
        ]
    return dataset


def write_scenario(out_dir: Path, dataset: dict[str, list[Demonstration]]) -> list[Path]:
    """Write ``dataset`` as ``out_dir/<primitive>/<name>.csv`` (atomically); the paths written."""
    written = []
    for primitive, demos in dataset.items():
        for demo in demos:
            path = Path(out_dir) / primitive / f"{demo.name}.csv"
            write_csv_demo(path, demo)
            written.append(path)
    return written


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m robots.icub.scenario",
        description="Write the simulated curved/direct dataset (hand + partner's head) as "
        "OUT_DIR/<primitive>/<demo>.csv with header t,x,y,z,roll,pitch,yaw.",
    )
    parser.add_argument(
        "out_dir", type=Path, metavar="OUT_DIR", help="folder to write (new or empty)"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed, >= 0 (default 0)")
    parser.add_argument(
        "--demos", type=int, default=20, help="demonstrations per primitive, 2-1000 (default 20)"
    )
    parser.add_argument(
        "--third", action="store_true", help=f"add the third primitive ({THIRD_PRIMITIVE})"
    )
    parser.add_argument(
        "--rate",
        type=float,
        default=DEFAULT_RATE_HZ,
        help="sampling rate in Hz, 30-50 (default 40)",
    )
    parser.add_argument(
        "--robot", default=DEFAULT_ROBOT, help=f"icub-models robot (default {DEFAULT_ROBOT})"
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="write into a non-empty OUT_DIR (same names are replaced)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status (2 on bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    out_dir: Path = args.out_dir
    try:
        if out_dir.exists() and not out_dir.is_dir():
            raise ValueError(f"{out_dir} exists and is not a folder")
        if out_dir.is_dir() and any(out_dir.iterdir()) and not args.force:
            raise ValueError(f"{out_dir} is not empty: choose a new folder or pass --force")
        dataset = generate_scenario(args.seed, args.demos, args.third, args.rate, robot=args.robot)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    written = write_scenario(out_dir, dataset)
    counts = ", ".join(f"{p}: {len(d)}" for p, d in dataset.items())
    print(f"wrote {len(written)} demonstrations ({counts}) at {args.rate:g} Hz to {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
