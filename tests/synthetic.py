"""Synthetic multi-modal demonstrations with known structure, for the engine's tests."""

from __future__ import annotations

import numpy as np

from promp.data import Demonstration, Layout, Modality

HAND = Modality("hand", ("x", "y", "z"), unit="m", kind="linear")
HEAD = Modality("head", ("roll", "pitch", "yaw"), unit="rad", kind="angle")
LAYOUT = Layout((HAND, HEAD))
COLUMNS = ("x", "y", "z", "roll", "pitch", "yaw")


def smooth_profile(z: np.ndarray, amplitude: np.ndarray, centre: float) -> np.ndarray:
    """A sigmoid-like rise of ``amplitude`` (d,) around phase ``centre``: shape (n, d)."""
    s = 1.0 / (1.0 + np.exp(-(z - centre) * 10.0))
    return s[:, None] * amplitude[None, :]


def make_demo(
    rng: np.random.Generator,
    target: np.ndarray,
    *,
    duration: float = 2.0,
    rate: float = 50.0,
    noise: float = 1e-3,
    jitter: float = 0.01,
    name: str = "",
) -> Demonstration:
    """One demonstration going from 0 to ``target`` (6,) with random amplitude and timing."""
    n = int(round(duration * rate)) + 1
    times = np.arange(n) / rate
    z = times / times[-1]
    amplitude = target * (1.0 + jitter * rng.standard_normal(target.shape))
    centre = 0.5 + 0.05 * rng.standard_normal()
    values = smooth_profile(z, amplitude, centre) + noise * rng.standard_normal((n, 6))
    return Demonstration(times, values, COLUMNS, name=name)


def make_dataset(
    seed: int = 0,
    n_demos: int = 8,
    targets: dict[str, np.ndarray] | None = None,
    noise: float = 1e-3,
) -> dict[str, list[Demonstration]]:
    """Primitives going to well-separated targets, durations varying +-30 %."""
    rng = np.random.default_rng(seed)
    if targets is None:
        targets = {
            "left": np.array([0.2, -0.2, 0.1, 0.0, 0.3, -0.6]),
            "right": np.array([0.2, 0.2, 0.1, 0.0, 0.3, 0.6]),
        }
    return {
        name: [
            make_demo(
                rng, target, duration=2.0 * rng.uniform(0.7, 1.3), noise=noise, name=f"{name}{i}"
            )
            for i in range(n_demos)
        ]
        for name, target in targets.items()
    }


# A handover study recorded in sessions: a person's hand (m) and 8 EMG channels (mV) per take.
EMG = Modality("emg", tuple(f"emg{c}" for c in range(8)), unit="mV", kind="linear")
HANDOVER_LAYOUT = Layout((HAND, EMG))
HANDOVER_GOALS = {
    "give": np.array([0.40, 0.12, 0.20]),
    "place": np.array([0.40, -0.12, 0.20]),
    "show": np.array([0.30, 0.00, 0.35]),
}


def handover_sessions(
    seed: int = 0,
    sessions: int = 6,
    session_effect: bool = True,
    dominant: int = 5,
    others: int = 0,
    rate: float = 50.0,
) -> dict[str, list[Demonstration]]:
    """Handovers recorded in ``sessions`` sessions, named ``session<s>/take<i>``, sampled at
    ``rate`` (Hz), in the columns of :data:`HANDOVER_LAYOUT`.

    The hand reaches its primitive's goal along a path the three share until ~60 % of the
    movement (early on, the hand cannot tell them apart). Every EMG channel is an activation
    burst whose timing and size depend a little on the primitive, on top of the session's
    baseline (the electrodes placed anew: up to 1 mV per channel, with ``session_effect``;
    none without). Each session records one primitive (``dominant`` takes of primitive
    ``s mod 3``, and ``others`` of each other one), as a study recorded in blocks does: within
    a session, the baseline says which primitive was recorded, which leave-one-out can
    exploit and a new session does not allow.
    """
    rng = np.random.default_rng(seed)
    names = list(HANDOVER_GOALS)
    pattern = rng.uniform(0.1, 0.2, (len(names), 8))  # each primitive's burst sizes (mV)
    centres = 0.45 + 0.04 * rng.standard_normal((len(names), 8))
    out: dict[str, list[Demonstration]] = {name: [] for name in names}
    for s in range(sessions):
        baseline = rng.uniform(0.0, 1.0, 8) if session_effect else np.zeros(8)
        for k, name in enumerate(names):
            for i in range(dominant if k == s % len(names) else others):
                duration = 1.6 * rng.uniform(0.8, 1.2)
                times = np.arange(int(round(duration * rate)) + 1) / rate
                z = times / times[-1]
                shared = np.outer(np.sin(0.5 * np.pi * z) ** 2, np.array([0.35, 0.0, 0.25]))
                split = 1.0 / (1.0 + np.exp(-(z - 0.75) * 14.0))
                goal = HANDOVER_GOALS[name] * (1.0 + 0.04 * rng.standard_normal(3))
                hand = shared + np.outer(split, goal - np.array([0.35, 0.0, 0.25]))
                hand += 0.002 * rng.standard_normal(hand.shape)
                burst = np.exp(-0.5 * ((z[:, None] - centres[k]) / 0.12) ** 2)
                emg = baseline + pattern[k] * (1.0 + 0.3 * rng.standard_normal(8)) * burst
                emg += 0.03 * rng.standard_normal(emg.shape)
                out[name].append(Demonstration(times, np.hstack([hand, emg]),
                                               HAND.columns + EMG.columns,
                                               name=f"session{s}/take{i}"))  # fmt: skip
    return out
