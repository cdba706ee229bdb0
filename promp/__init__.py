"""Multi-modal Probabilistic Movement Primitives: learn, recognise, predict (numpy/scipy only)."""
