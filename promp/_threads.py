"""One BLAS thread for the inference's many small factorisations.

A scrub step factorises dozens of matrices of a few hundred rows at most. OpenBLAS splits each
across its threads, whose start-up and hand-over cost more than the work: measured with
``bench/inference.py`` on two cores, a step with ten primitives of 180 weights took twice as
long with OpenBLAS's two threads as with one, and on a machine whose other core is busy a
thread waiting for its partner stalls the studio's loop. The studio has threads of its own (the
loop, the learner) and the evaluation runs its folds in processes, so the inference runs its
linear algebra on the calling thread: :func:`one_blas_thread` limits every BLAS library loaded
in the process (threadpoolctl) for the duration of a call, and restores the limit after.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

P = ParamSpec("P")
R = TypeVar("R")


@functools.cache
def _controller() -> ThreadpoolController:
    # Built once, on first use, after numpy and scipy have loaded their BLAS (~2 ms to scan
    # the process's libraries); each limit afterwards costs ~30 us.
    return ThreadpoolController()


@contextlib.contextmanager
def one_blas_thread_context() -> Iterator[None]:
    with _controller().limit(limits=1, user_api="blas"):
        yield


def one_blas_thread(function: Callable[P, R]) -> Callable[P, R]:
    """Run ``function`` with every BLAS library limited to one thread."""

    @functools.wraps(function)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with one_blas_thread_context():
            return function(*args, **kwargs)

    return wrapper
