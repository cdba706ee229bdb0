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
