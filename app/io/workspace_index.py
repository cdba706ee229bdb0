"""The workspace's index, ``studio.json``: its format, and the checks of what it lists.

::

    {"format": "icub-intention-studio/workspace", "version": 1,
     "layout": [{"name": "hand", "columns": ["x", "y", "z"], "unit": "m", "kind": "linear"}, ...],
     "primitives": [{"name": "curved", "color": [213, 94, 0]}, ...],
     "settings": {"n_basis": 7, ...},
     "frame": {"placement": {"translation_m": [x, y, z], "yaw_rad": yaw}}}

The layout lists the modalities (:func:`layout_listing`); a workspace the studio creates has
the studio's (:data:`robots.icub.layout.STUDIO_LAYOUT`, hand and head). Primitive names are
safe file names
(:func:`check_name`). The settings are those of :class:`promp.model.Settings` the workspace sets;
absent ones take the engine's defaults. ``frame``, for data recorded elsewhere, says how its
hand was placed in the iCub's frame or that it stays in its own (:mod:`app.io.hand_frame`;
absent: the iCub's). The index on disk and one in an imported archive are checked alike
(:func:`check_index`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields

from app.io.demo_checks import DemoChecks
from app.io.hand_frame import ICUB_FRAME, HandFrame
from promp.data import Layout, Modality
from promp.datasets import MODALITY_NAME
from promp.model import Settings
from robots.icub.layout import HAND, STUDIO_LAYOUT

FORMAT = "icub-intention-studio/workspace"
VERSION = 1
INDEX_NAME = "studio.json"
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]{0,39}$")
# Primitive colours, in order: saturated and far apart in hue (after Okabe and Ito's
# colour-blind-safe set), none close to the scene's neutral table, bins and object, nor to the
# robot's pale blue-grey. Each new primitive takes the next.
PALETTE = (
    (213, 94, 0),
    (0, 114, 178),
    (0, 158, 115),
    (204, 121, 167),
    (230, 159, 0),
    (86, 180, 233),
    (120, 70, 160),
    (140, 30, 60),
)


def check_name(name: str, what: str = "primitive") -> str:
    """A safe file name: letters, digits, '_' and '-', 1-40 characters."""
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise ValueError(
            f"invalid {what} name {name!r}: use 1-40 letters, digits, '_' or '-', "
            "starting with a letter or digit"
        )
    return name


def check_color(color: Sequence[int]) -> tuple[int, int, int]:
    rgb = tuple(int(c) for c in color)
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise ValueError(f"a colour is three integers in 0-255, got {color!r}")
    return rgb  # type: ignore[return-value]


def check_layout(layout: Layout) -> Layout:
    """``layout`` if the studio can use it: safe modality names, and a ``hand`` modality, when
    there is one, of 3 linear columns in metres (it drives the 3D view, the tubes and the arm).

    Raises
    ------
    ValueError
        What is wrong and what is expected.
    """
    for modality in layout.modalities:
        if not MODALITY_NAME.match(modality.name):
            raise ValueError(
                f"invalid modality name {modality.name!r}: use 1-40 letters, digits, '_' or "
                "'-', starting with a letter"
            )
        for column in modality.columns:
            if not column or column == "t" or "," in column or "\n" in column:
                raise ValueError(f"modality {modality.name!r}: invalid column name {column!r}")
    if HAND.name in layout.names:
        hand = layout.modality(HAND.name)
        shape = (len(hand.columns), hand.unit, hand.kind)
        if shape != (len(HAND.columns), HAND.unit, HAND.kind):
            raise ValueError(
                "the modality 'hand' drives the 3D view: it needs 3 linear columns in metres "
                f"(x, y, z in the robot's root frame), got {list(hand.columns)} in "
                f"{hand.unit or 'no unit'}; name it otherwise to import it as a plain signal"
            )
    return layout


def layout_listing(layout: Layout) -> list[dict]:
    """The modalities as ``studio.json`` lists them."""
    return [
        {"name": m.name, "columns": list(m.columns), "unit": m.unit, "kind": m.kind}
        for m in layout.modalities
    ]


def layout_from_listing(listing: object, label: str) -> Layout:
    """The inverse of :func:`layout_listing`, checked (``ValueError`` starting with ``label``)."""
    if not isinstance(listing, list) or not listing:
        raise ValueError(f"{label}: 'layout' must be a non-empty list of modalities")
    modalities = []
    for i, item in enumerate(listing):
        if not isinstance(item, dict):
            raise ValueError(f"{label}: modality {i} must be an object")
        columns = item.get("columns")
        if not (
            isinstance(item.get("name"), str)
            and isinstance(columns, list)
            and all(isinstance(c, str) for c in columns)
            and isinstance(item.get("unit", ""), str)
        ):
            raise ValueError(
                f"{label}: modality {i} needs a 'name', a list of 'columns', a 'unit' text"
            )
        try:
            unit, kind = item.get("unit", ""), item.get("kind", "linear")
            modalities.append(Modality(item["name"], tuple(columns), unit, kind))
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
    try:
        return check_layout(Layout(tuple(modalities)))
    except ValueError as exc:
        raise ValueError(f"{label}: {exc}") from None


@dataclass
class PrimitiveEntry:
    name: str
    color: tuple[int, int, int]


def index_json(
    primitives: Sequence[PrimitiveEntry],
    settings: Mapping,
    layout: Layout = STUDIO_LAYOUT,
    checks: DemoChecks | None = None,
    frame: HandFrame = ICUB_FRAME,
) -> str:
    """The text of ``studio.json`` (``checks``: :mod:`app.io.demo_checks`, written when it holds
    something; ``frame``: :mod:`app.io.hand_frame`, written unless the iCub's)."""
    index = {
        "format": FORMAT,
        "version": VERSION,
        "layout": layout_listing(layout),
        "primitives": [{"name": p.name, "color": list(p.color)} for p in primitives],
        "settings": dict(settings),
    }
    if checks:
        index["checks"] = checks.to_json()
    if frame.to_json() is not None:
        index["frame"] = frame.to_json()
    return json.dumps(index, indent=1)


_SETTING_NAMES = {f.name for f in fields(Settings)}


@dataclass(frozen=True)
class Index:
    """A decoded, checked ``studio.json``."""

    primitives: list[PrimitiveEntry]
    settings: dict
    layout: Layout
    checks: DemoChecks = DemoChecks()
    frame: HandFrame = ICUB_FRAME


def check_index(index: object, label: str) -> Index:
    """The primitives, learning settings and layout of a decoded ``studio.json``; a
    ``ValueError`` starting with ``label`` says what is wrong (the workspace on disk and an
    imported archive are checked alike). A workspace written before layouts were stored
    has the studio's (hand, head)."""
    if not isinstance(index, dict) or index.get("format") != FORMAT:
        raise ValueError(f"{label}: not a studio workspace index ('format' is not {FORMAT!r})")
    if index.get("version") != VERSION:
        raise ValueError(
            f"{label}: unsupported workspace version {index.get('version')!r}; "
            f"this studio reads version {VERSION}"
        )
    layout = layout_from_listing(index["layout"], label) if "layout" in index else STUDIO_LAYOUT
    raw = index.get("primitives", [])
    if not isinstance(raw, list):
        raise ValueError(f"{label}: 'primitives' must be a list")
    primitives: list[PrimitiveEntry] = []
    for i, entry in enumerate(raw):
        if not isinstance(entry, dict) or "name" not in entry or "color" not in entry:
            raise ValueError(f"{label}: primitive {i} needs a 'name' and a 'color'")
        try:
            name = check_name(entry["name"])
            color = entry["color"]
            if not (
                isinstance(color, list)
                and all(isinstance(c, int) and not isinstance(c, bool) for c in color)
            ):
                raise ValueError(f"a colour is three integers in 0-255, got {color!r}")
            rgb = check_color(color)
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
        if name in {p.name for p in primitives}:
            raise ValueError(f"{label}: primitive {name!r} is listed twice")
        primitives.append(PrimitiveEntry(name, rgb))
    settings = index.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError(f"{label}: 'settings' must be an object")
    unknown = sorted(set(settings) - _SETTING_NAMES)
    if unknown:
        raise ValueError(f"{label}: unknown setting(s) {unknown}")
    # null (or absent) n_basis / width / noise_scale: chosen from the demonstrations
    n_basis, width = settings.get("n_basis"), settings.get("width")
    if n_basis is not None and (not isinstance(n_basis, int) or isinstance(n_basis, bool)):
        raise ValueError(f"{label}: 'n_basis' must be an integer, got {settings['n_basis']!r}")
    if width is not None and (not isinstance(width, (int, float)) or isinstance(width, bool)):
        raise ValueError(f"{label}: 'width' must be a number, got {settings['width']!r}")
    try:
        Settings(**settings)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{label}: invalid learning settings ({exc})") from None
    checks = DemoChecks.from_json(index["checks"], label) if "checks" in index else DemoChecks()
    frame = HandFrame.from_json(index.get("frame"), label, layout)
    return Index(primitives, dict(settings), layout, checks, frame)
