"""Multi-modal Probabilistic Movement Primitives: learn, recognise, predict (numpy/scipy only)."""

# Every BLAS library on one thread, once for the process (see promp/_threads.py).
from promp import _threads  # noqa: F401
