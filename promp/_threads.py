"""One BLAS thread for the method's many small factorisations, set once for the process.

A scrub step factorises dozens of matrices of a few hundred rows at most. OpenBLAS splits each
across its threads, whose start-up and hand-over cost more than the work: measured with
``bench/inference.py`` on two cores, a step with ten primitives of 180 weights took twice as
long with OpenBLAS's two threads as with one, and on a machine whose other core is busy a
thread waiting for its partner stalls the studio's loop.

**Once for the process, when promp is imported.** A BLAS library's thread count belongs to
the whole process, not to a thread, and the studio infers on several threads at once (its loop,
the recognition chart's worker, an evaluation). A limit set and restored around each call let
one thread's exit give the library its threads back under another thread still inferring, and
threadpoolctl (>= 3.6) lets only one Python thread change OpenBLAS's count: a limit asked for
from any other thread is silently ignored. So promp limits every BLAS library loaded with numpy
and SciPy to one thread once, at import (:func:`limit_blas_threads`), and never changes it
again: every thread sees the same limit, and results do not depend on which thread computed
them. A program that wants more threads for its own algebra sets them after importing promp
(``threadpoolctl.threadpool_limits``); promp then runs with what it set.
"""

from __future__ import annotations

# numpy's and SciPy's BLAS are loaded before the limit is set (scipy.linalg brings its own
# OpenBLAS): a library loaded later keeps its own threads.
import numpy  # noqa: F401
import scipy.linalg  # noqa: F401
import threadpoolctl

_limited: threadpoolctl.ThreadpoolController | None = None


def limit_blas_threads() -> None:
    """Limit every BLAS library loaded now to one thread, once for the process (see the
    module docstring); later calls do nothing."""
    global _limited
    if _limited is None:
        controller = threadpoolctl.ThreadpoolController()
        controller.limit(limits=1, user_api="blas")  # kept: never restored
        _limited = controller


def promp_blas_threads() -> set[int]:
    """The thread counts of the BLAS libraries promp limited (numpy's and SciPy's) now."""
    limit_blas_threads()
    return {lib["num_threads"] for lib in _limited.info() if lib["user_api"] == "blas"}


limit_blas_threads()
