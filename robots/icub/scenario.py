"""Simulated demonstrations of the paper's experiment: the robot's hand and the partner's head.

The experiment of Dermy, Charpillet and Ivaldi: the robot's left hand carries an object from the
same start (the pick position) to the same drop point above a bin along two different movements,
**curved** and **direct**. Their beginnings look alike (both lift the object first), so early hand
observations are ambiguous; the partner's head, which looks where the hand is going, tells them
apart. ``--third`` adds **second_bin**, a direct movement to the other bin.

Each demonstration is built like a human-guided one:

- Path: a smooth cubic spline (lifting vertically at the start) through via points: the grasp, a
  lift point 9 cm above it, for ``curved`` an apex bowing 13 cm up and 3 cm towards the partner
  halfway, and the drop point. Via points are jittered by ~1.2 cm (the start, the end and the
  lift's horizontal position by 3 mm), once per demonstration.
- Timing: minimum-jerk along the arc length (bell-shaped speed, zero velocity at both ends), the
  duration drawn uniformly within +-30 % of 3 s.
- Reachability: every sample goes through the IK of the left arm with the **torso locked** (the
  arm alone is guided, as in kinesthetic teaching), warm-started along the path; the hand
  positions written are the forward kinematics of the IK solutions, so the data is exactly what
  the robot can do.
- Head: the partner looks where the hand will be 0.5-1.0 s later (clipped to the end of the
  movement), the head follows with a first-order lag of 0.1-0.2 s, and the angles carry the
  noise of a webcam head-pose estimator: 2 deg white noise plus a slow drift (1.5 deg, time
  constant 1 s), a small per-demonstration roll bias and head-position offset. Angles follow the
  convention of :mod:`robots.icub.scene`. Seen from the partner, the curved movement's bow is
  mostly upwards, so the head's pitch tells curved from direct (on average the head rises up
  to ~5 deg more for curved, early, since the gaze leads) while the yaw tells which bin the
  hand goes to.

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
from scipy.interpolate import CubicSpline

from promp.data import Demonstration
from promp.datasets import write_csv_demo
from robots.icub.ik import solve_ik
from robots.icub.kinematics import ArmChain, load_arm
from robots.icub.model import DEFAULT_ROBOT
from robots.icub.scene import DEFAULT_SCENE, Scene, head_orientation_looking_at

PRIMITIVES = ("curved", "direct")
THIRD_PRIMITIVE = "second_bin"
ALL_PRIMITIVES = (*PRIMITIVES, THIRD_PRIMITIVE)
COLUMNS = ("x", "y", "z", "roll", "pitch", "yaw")
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
        Height of the lift point above the grasp.
    curve_rise, curve_out : float
        The curved movement's apex: this much above and towards the partner (-x) from the middle
        of the straight lift-to-drop segment.
    via_jitter, end_jitter : float
        Standard deviation of the via points' jitter; ``end_jitter`` for the start, the end and
        the lift point's horizontal position.
    gaze_lead, head_lag : (float, float)
        Ranges of the gaze's look-ahead and of the head's first-order time constant, drawn once
        per demonstration.
    head_noise_deg, head_drift_deg, head_drift_time : float
        White noise and slow drift (Ornstein-Uhlenbeck: stationary std, time constant) of the
        estimated head angles.
    roll_bias_deg, head_position_jitter : float
        Per-demonstration roll offset and head position offset (standard deviations).
    """

    base_duration: float = 3.0
    duration_spread: float = 0.3
    lift: float = 0.09
    curve_rise: float = 0.13
    curve_out: float = 0.03
    via_jitter: float = 0.012
    end_jitter: float = 0.003
    gaze_lead: tuple[float, float] = (0.5, 1.0)
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
        for name in ("gaze_lead", "head_lag"):
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


def minimum_jerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk progress ``10 tau^3 - 15 tau^4 + 6 tau^5`` for ``tau`` in [0, 1], same shape."""
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))


def via_points(
    primitive: str, scene: Scene, rng: np.random.Generator, params: ScenarioParams
) -> np.ndarray:
    """The jittered via points of one demonstration of ``primitive``, shape (n_via, 3)."""
    if primitive not in ALL_PRIMITIVES:
        raise ValueError(f"unknown primitive {primitive!r}; known: {', '.join(ALL_PRIMITIVES)}")
    pick = np.array(scene.pick_position, dtype=float)
    drop = scene.bins[1 if primitive == THIRD_PRIMITIVE else 0].drop_position
    lift = pick + np.array([0.0, 0.0, params.lift])
    points = [pick, lift]
    if primitive == "curved":
        points.append(0.5 * (lift + drop) + np.array([-params.curve_out, 0.0, params.curve_rise]))
    points.append(drop)
    # Start and end vary little (same object, same bin); the lift mostly in height; the apex
    # freely. One draw per demonstration: the path's shape is consistent within it.
    jitter = np.full((len(points), 3), params.via_jitter)
    jitter[[0, -1]] = params.end_jitter
    jitter[1, :2] = params.end_jitter
    return np.array(points) + rng.normal(size=(len(points), 3)) * jitter


def path_positions(points: np.ndarray, progress: np.ndarray) -> np.ndarray:
    """Positions along the smooth path through ``points`` at arc-length fractions ``progress``.

    Parameters
    ----------
    points : array, shape (n_via, 3)
        Via points; the path leaves the first one vertically (lifting) and ends at the last.
    progress : array, shape (n,)
        Fractions of the path's length in [0, 1].

    Returns
    -------
    array, shape (n, 3)
    """
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    u = np.concatenate([[0.0], np.cumsum(chords)])
    spline = CubicSpline(u, points, bc_type=((1, np.array([0.0, 0.0, 1.0])), "natural"))
    dense_u = np.linspace(0.0, u[-1], 2000)
    dense = spline(dense_u)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    return spline(np.interp(np.asarray(progress) * arc[-1], arc, dense_u))


def track_with_ik(arm: ArmChain, targets: np.ndarray, label: str) -> np.ndarray:
    """Hand positions, shape (n, 3), of IK solutions (torso locked) along ``targets`` (n, 3).

    Raises
    ------
    ValueError
        If a target is out of the arm's reach (more than 1 mm away).
    """
    q = solve_ik(arm, targets[0], arm.rest, lock_torso=True, restarts=5).q
    hand = np.empty_like(targets)
    for k, target in enumerate(targets):
        result = solve_ik(arm, target, q, lock_torso=True, position_tolerance=1e-5)
        if result.position_error_m > MAX_TRACKING_ERROR_M:
            raise ValueError(
                f"{label}: the path leaves the left arm's reach at {np.round(target, 3).tolist()} "
                f"(closest {1e3 * result.position_error_m:.1f} mm away)"
            )
        q = result.q
        hand[k] = arm.position(q)
    return hand


def head_angles_following(
    times: np.ndarray,
    hand: np.ndarray,
    head_position: np.ndarray,
    rng: np.random.Generator,
    params: ScenarioParams,
) -> np.ndarray:
    """The partner's head angles while watching the hand, shape (n, 3): roll, pitch, yaw (rad).

    The gaze leads the hand (looks where it will be ``gaze_lead`` s later), the head lags the gaze
    (first-order, ``head_lag``), and estimator noise is added (see the module docstring).

    Parameters
    ----------
    times : array, shape (n,)
    hand : array, shape (n, 3)
        Hand positions at ``times``.
    head_position : array, shape (3,)
    rng : numpy.random.Generator
    params : ScenarioParams
    """
    lead = rng.uniform(*params.gaze_lead)
    lag = rng.uniform(*params.head_lag)
    looked_at = np.minimum(times + lead, times[-1])
    gaze_points = np.column_stack([np.interp(looked_at, times, hand[:, k]) for k in range(3)])
    _, pitch, yaw = head_orientation_looking_at(gaze_points, head_position)
    wanted = np.column_stack([np.zeros_like(pitch), pitch, yaw])
    head = np.empty_like(wanted)
    head[0] = wanted[0]
    for k in range(1, len(times)):
        a = np.exp(-(times[k] - times[k - 1]) / lag)
        head[k] = a * head[k - 1] + (1.0 - a) * wanted[k]

    n = len(times)
    white = rng.normal(scale=np.deg2rad(params.head_noise_deg), size=(n, 3))
    drift = np.empty((n, 3))
    drift_std = np.deg2rad(params.head_drift_deg)
    drift[0] = rng.normal(scale=drift_std, size=3)
    for k in range(1, n):  # Ornstein-Uhlenbeck, exact discretisation
        a = np.exp(-(times[k] - times[k - 1]) / params.head_drift_time)
        drift[k] = a * drift[k - 1] + np.sqrt(1.0 - a * a) * drift_std * rng.normal(size=3)
    roll_bias = np.deg2rad(params.roll_bias_deg) * rng.normal()
    head[:, 0] += roll_bias
    return head + white + drift


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
    targets = path_positions(points, minimum_jerk(times / times[-1]))
    hand = track_with_ik(arm, targets, name or primitive)
    head_position = np.asarray(scene.partner_head) + rng.normal(
        scale=params.head_position_jitter, size=3
    )
    head = head_angles_following(times, hand, head_position, rng, params)
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
