"""The folds of a sweep (:mod:`promp.evaluate.sweep`): which demonstrations each holds out
together and tests, and where they run.

A fold holds out one demonstration (leave-one-out) or a whole group (``groups``: a subject's
or a session's demonstrations, :mod:`promp.evaluate.groups`), and tests those of them the
sweep holds out. Leave-one-out folds share the choice of the automatic settings by blocks
(:func:`choice_blocks`): the settings that serve a fold are chosen without its block, hence
without the demonstration it tests.

Folds are independent: :func:`run_folds` runs them in order, on several processes (joblib) or
on a Dask cluster, and yields their trials in the folds' order, so the results are identical
wherever they ran. A worker process ends within :data:`PARENT_WATCH_S` of the process that
started it, however that one ended (``kill -9`` included): a killed evaluation leaves no worker
behind.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence

import numpy as np

from promp.content_key import canonical_dataset, content_key
from promp.data import Demonstration

__all__ = [
    "CHOICE_BLOCKS", "Fold", "MIN_TRAINING", "PARENT_WATCH_S", "Pair", "Progress",
    "block_choices", "check_groups", "chosen_settings", "choice_blocks", "exit_with_parent",
    "group_folds", "planned_folds", "run_folds", "without",
]  # fmt: skip

Pair = tuple[int, int]  # (primitive index, demonstration index)
MIN_TRAINING = 2  # demonstrations a primitive keeps in every fold: a fit needs two
Progress = Callable[[int, int], None]
Fold = tuple[tuple[Pair, ...], tuple[Pair, ...]]  # (held out together, tested)
# Blocks of a leave-one-out sweep's choice of the automatic settings: each block's choice is
# made once, without the block, and serves the folds that test its demonstrations.
CHOICE_BLOCKS = 10


def _run_chunk(fold: Callable[[Fold], list], chunk: Sequence[Fold]) -> list[list]:
    return [fold(f) for f in chunk]


def run_folds(
    fold: Callable[[Fold], list],
    folds: list[Fold],
    jobs: int,
    scheduler: str | None,
    progress: Progress | None,
) -> Iterator[list]:
    """Each fold's trials, in the order of ``folds``; ``progress`` counts the demonstrations
    tested.

    In parallel, the folds travel in chunks (four per worker): each chunk carries the dataset
    once, rather than once per fold.
    """
    total = sum(len(tested) for _, tested in folds)
    done = 0
    if jobs == 1 and scheduler is None:
        for f in folds:
            yield fold(f)
            done += len(f[1])
            if progress is not None:
                progress(done, total)
        return
    import joblib

    if scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError:
            raise ValueError(
                "the Dask backend needs the 'cluster' extra: pip install 'dask[distributed]'"
            ) from None
        client = Client(scheduler)
        workers = max(1, sum(client.nthreads().values()))
        config = joblib.parallel_config(backend="dask")
    else:
        client = None
        workers = jobs if jobs > 0 else (os.cpu_count() or 1)
        config = joblib.parallel_config(backend="loky", n_jobs=jobs, initializer=exit_with_parent,
                                        initargs=(os.getpid(),))  # fmt: skip
    n_chunks = min(len(folds), 4 * workers)
    chunks = [list(c) for c in np.array_split(np.arange(len(folds)), n_chunks) if c.size]
    try:
        with config:
            parallel = joblib.Parallel(return_as="generator")
            results = parallel(
                joblib.delayed(_run_chunk)(fold, [folds[i] for i in chunk]) for chunk in chunks
            )
            position = 0
            for trials_of_chunk in results:
                for trials in trials_of_chunk:
                    done += len(folds[position][1])
                    position += 1
                    yield trials
                    if progress is not None:
                        progress(done, total)
    finally:
        if client is not None:
            client.close()


PARENT_WATCH_S = 0.5  # how often a worker looks whether the evaluation that started it is alive


def exit_with_parent(parent: int) -> None:
    """A worker's initializer: the worker ends once the process ``parent`` (its parent) has
    ended. joblib's workers outlive a parent killed by a signal otherwise (until their idle
    timeout, minutes later), still computing the folds of a sweep nobody waits for."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_WATCH_S)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def check_groups(
    dataset: Mapping[str, Sequence[Demonstration]], groups: Mapping[str, Sequence[Pair]]
) -> None:
    """ValueError unless every demonstration of ``dataset`` is in exactly one of ``groups``
    and holding out any group leaves every primitive at least :data:`MIN_TRAINING`
    demonstrations to learn from (the message names the group and the primitive)."""
    names = list(dataset)
    owner: dict[Pair, str] = {}
    for group, pairs in groups.items():
        for k, j in pairs:
            pair = (int(k), int(j))
            if not (0 <= pair[0] < len(names) and 0 <= pair[1] < len(dataset[names[pair[0]]])):
                raise ValueError(f"group {group!r}: no demonstration (primitive index, index) "
                                 f"{pair}")  # fmt: skip
            if pair in owner:
                raise ValueError(f"{names[pair[0]]}/{dataset[names[pair[0]]][pair[1]].name} is "
                                 f"in two groups, {owner[pair]!r} and {group!r}")  # fmt: skip
            owner[pair] = group
    for k, demos in enumerate(dataset.values()):
        for j, demo in enumerate(demos):
            if (k, j) not in owner:
                raise ValueError(f"{names[k]}/{demo.name} is in no group: every demonstration "
                                 "needs one")  # fmt: skip
    for group, pairs in groups.items():
        for k, name in enumerate(names):
            left = len(dataset[name]) - sum(1 for kk, _ in pairs if int(kk) == k)
            if left < MIN_TRAINING:
                raise ValueError(
                    f"holding out the group {group!r} leaves {name!r} {left} demonstration(s) "
                    f"to learn from; a fit needs at least {MIN_TRAINING}: group the "
                    "demonstrations so that every primitive has takes in two groups or more"
                )


def group_folds(
    dataset: Mapping[str, Sequence[Demonstration]],
    groups: Mapping[str, Sequence[Pair]],
    held_out: Sequence[Pair],
) -> list[Fold]:
    """One fold per group that holds a demonstration of ``held_out``: the group's pairs held
    out, those of ``held_out`` tested (in ``held_out``'s order)."""
    check_groups(dataset, groups)
    folds = []
    for pairs in groups.values():
        held = tuple(sorted((int(k), int(j)) for k, j in pairs))
        mine = set(held)
        tested = tuple(pair for pair in held_out if pair in mine)
        if tested:
            folds.append((held, tested))
    return folds


def choice_blocks(
    dataset: Mapping[str, Sequence[Demonstration]], n_blocks: int = CHOICE_BLOCKS
) -> dict[Pair, int]:
    """The block of every demonstration of ``dataset`` ({(primitive index, index): block}) for
    the choice of the automatic settings in a leave-one-out sweep.

    Choosing the settings costs a fold of the 70 x 15 set three times its fit
    (docs/evaluation.md, "The standing rule"), and every fold chose them again from nearly the
    same demonstrations. In blocks, the settings are chosen ``n_blocks`` times, each on every
    demonstration outside one block, and a fold tests its demonstration with the choice made
    without that demonstration's block: nested, as each fold's own choice was (nothing that
    chose the settings saw the trial under test), from 90 % of the demonstrations instead of
    all but one (ten-fold inside, leave-one-out outside). A set of ``n_blocks``
    demonstrations or fewer has a block per demonstration: every fold's own choice, as before.

    The demonstrations are dealt in the order of their content keys
    (:func:`promp.content_key.content_key`), every ``n_blocks``-th to the same block: the
    blocks, and so the choices and the table, do not depend on the files' names, order or
    units.
    """
    if n_blocks < 1:
        raise ValueError(f"choose the settings in one block or more, got {n_blocks}")
    keyed = sorted(
        (content_key(demo), (k, j))
        for k, demos in enumerate(dataset.values())
        for j, demo in enumerate(demos)
    )
    return {pair: rank % n_blocks for rank, (_, pair) in enumerate(keyed)}


def without(
    dataset: Mapping[str, Sequence[Demonstration]], held: Sequence[Pair]
) -> dict[str, list[Demonstration]]:
    """``dataset`` without the demonstrations ``held`` ((primitive index, index) pairs), each
    primitive's in the order of their content."""
    out = set(held)
    return canonical_dataset({
        name: [d for i, d in enumerate(demos) if (kk, i) not in out]
        for kk, (name, demos) in enumerate(dataset.items())
    })  # fmt: skip


def block_choices(
    methods: Mapping[str, Callable[[], object]],
    dataset: Mapping[str, Sequence[Demonstration]],
    held_out: Sequence[Pair],
    dt: float,
    where: tuple[int, str | None],
    n_blocks: int,
    stop: Callable[[], bool] | None = None,
    progress: Progress | None = None,
) -> dict[Pair, dict[str, object]] | None:
    """The settings of every method that chooses them (its ``choose(train, dt)``, unless its
    ``chooses`` is false), chosen once per block of :func:`choice_blocks` that holds a
    demonstration of ``held_out``, on every demonstration outside the block: {held-out pair:
    {method name: settings}} (``where``: :func:`run_folds`' jobs and scheduler). A block whose
    choice fails (``ValueError``: e.g. a primitive left with a single demonstration) serves
    nothing, and its folds choose for themselves. None when ``stop()`` turned true after a
    block. ``progress`` is called with (blocks chosen, blocks), first with none chosen."""
    choosers = {name: f for name, f in methods.items() if _chooses(f())}
    if not choosers:
        return {}
    blocks = choice_blocks(dataset, n_blocks)
    members: dict[int, list[Pair]] = {}
    for pair, block in sorted(blocks.items()):
        members.setdefault(block, []).append(pair)
    needed = sorted({blocks[pair] for pair in held_out})
    tasks: list[Fold] = [(tuple(members[block]), ()) for block in needed]
    choose = functools.partial(_choose_without, choosers, dataset, dt)
    out: dict[Pair, dict[str, object]] = {}
    if progress is not None:
        progress(0, len(tasks))
    for done, ((block_pairs, _), made) in enumerate(
            zip(tasks, run_folds(choose, tasks, *where, None), strict=True), 1):  # fmt: skip
        for pair in block_pairs:
            out[pair] = dict(made)
        if progress is not None:
            progress(done, len(tasks))
        if stop is not None and stop():
            return None
    return out


def chosen_settings(choices: Mapping[Pair, Mapping[str, object]]) -> dict[str, list[dict]]:
    """The settings each method chose, one entry per block of :func:`block_choices` (in the
    blocks' order), as JSON: {method name: [settings]}."""
    out: dict[str, list[dict]] = {}
    seen: set[int] = set()
    for _, made in sorted(choices.items()):
        for name, settings in made.items():
            if dataclasses.is_dataclass(settings) and id(settings) not in seen:
                seen.add(id(settings))
                out.setdefault(name, []).append(dataclasses.asdict(settings))
    return out


def _chooses(method: object) -> bool:
    """Whether ``method`` chooses settings from its training set: it has ``choose``, and its
    ``chooses`` (if it says) is true."""
    return callable(getattr(method, "choose", None)) and bool(getattr(method, "chooses", True))


def _choose_without(
    methods: Mapping[str, Callable[[], object]],
    dataset: Mapping[str, Sequence[Demonstration]],
    dt: float,
    task: Fold,
) -> list[tuple[str, object]]:
    """Each method's settings chosen on ``dataset`` without the demonstrations ``task[0]``
    (None where the choice raised ``ValueError``)."""
    train = without(dataset, task[0])
    made = []
    for name, factory in methods.items():
        try:
            made.append((name, factory().choose(train, dt)))
        except ValueError:
            made.append((name, None))
    return made


def planned_folds(
    methods: Mapping[str, Callable[[], object]],
    dataset: Mapping[str, Sequence[Demonstration]],
    held_out: Sequence[Pair],
    groups: Mapping[str, Sequence[Pair]] | None,
    dt: float,
    where: tuple[int, str | None],
    n_blocks: int,
    stop: Callable[[], bool] | None = None,
    choosing: Progress | None = None,
) -> tuple[list[Fold], dict[Pair, dict[str, object]] | None]:
    """A sweep's folds (one per demonstration of ``held_out``, or per group of ``groups``:
    :func:`group_folds`) and the settings chosen for them (:func:`block_choices` in
    ``n_blocks`` blocks, telling ``choosing`` how far it is; none with ``groups`` or
    ``n_blocks`` 0; None when ``stop()`` turned true while choosing).

    Raises
    ------
    ValueError
        ``n_blocks`` below 0, or the groups' own refusals (:func:`check_groups`).
    """
    if n_blocks < 0:
        raise ValueError(f"choice_blocks must be 0 (a choice per fold) or more, got {n_blocks}")
    if groups is not None:
        return group_folds(dataset, groups, held_out), {}
    folds: list[Fold] = [(((k, j),), ((k, j),)) for k, j in held_out]
    if not n_blocks:
        return folds, {}
    return folds, block_choices(methods, dataset, held_out, dt, where, n_blocks, stop, choosing)
