"""The command line's settings of ours (``--basis``, ``--width``, ``--shrinkage``,
``--noise-scale``, ``--duration-temperature``, ``--select``, ``--recognition``), each left to
every fit's choice by default, and the :class:`promp.model.Settings` they give."""

from __future__ import annotations

import argparse

from promp.model import SELECT_RULES, Settings, recognition_bandwidth

__all__ = ["add_settings_arguments", "settings_of"]


def add_settings_arguments(parser: argparse.ArgumentParser) -> None:
    """The learning settings of ours (each left to every fit's choice by default)."""
    parser.add_argument(
        "--basis",
        type=int,
        default=None,
        metavar="M",
        help="basis functions per dimension (ours); default: chosen by every fit from its "
        "training demonstrations (promp.selection)",
    )
    parser.add_argument(
        "--width",
        type=float,
        default=None,
        help="basis width, in spacings (ours); default: chosen by every fit",
    )
    parser.add_argument(
        "--shrinkage",
        default="auto",
        help="'auto': each primitive's covariance under a prior pooled across primitives, its "
        "strength by marginal likelihood, chosen inside every fold; or a fixed shrinkage "
        "intensity in (0, 1] of each primitive's own sample covariance (ours)",
    )
    parser.add_argument(
        "--noise-scale",
        type=float,
        default=None,
        help="multiplies the estimated observation noise (ours); default: chosen by every fit",
    )
    parser.add_argument(
        "--duration-temperature",
        type=float,
        default=None,
        help="the power of the likelihood in the speed's posterior, which the duration's "
        "interval comes from, in (0, 1] (ours); default: chosen by every fit",
    )
    parser.add_argument(
        "--select",
        choices=SELECT_RULES,
        default="loo",
        help="how every fit chooses the settings not given (ours): 'loo', the recognition "
        "log-loss of each training demonstration left out in closed form (one fit per "
        "candidate basis); 'cv', inner folds refitted for every candidate (slower)",
    )
    parser.add_argument(
        "--recognition",
        default="auto",
        metavar="auto|promp|mixture:H",
        help="how ours scores each primitive's evidence: 'promp' (its one Gaussian over the "
        "weights and the speed), or 'mixture:H', the mixture over its training "
        "demonstrations, each a kernel of bandwidth H in (0, 1] (promp.evidence.mixture); "
        "default 'auto': chosen by every fit (promp.selection.recognition_choice)",
    )


def settings_of(args: argparse.Namespace) -> Settings:
    """The :class:`promp.model.Settings` of ours that the arguments give.

    Raises
    ------
    ValueError
        A value out of its range (with the argument's name).
    """
    try:
        shrinkage = None if args.shrinkage == "auto" else float(args.shrinkage)
    except ValueError:
        raise ValueError(
            f"--shrinkage expects a number in (0, 1] or 'auto', got {args.shrinkage!r}"
        ) from None
    recognition = None if args.recognition == "auto" else args.recognition
    try:
        recognition_bandwidth(recognition)
    except ValueError as exc:
        raise ValueError(f"--recognition: {exc}") from None
    return Settings(
        n_basis=args.basis,
        width=args.width,
        shrinkage=shrinkage,
        noise_scale=args.noise_scale,
        duration_temperature=args.duration_temperature,
        select=args.select,
        recognition=recognition,
    )
