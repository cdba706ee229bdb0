"""Leave-one-out evaluation of the method on any dataset (``python -m promp.evaluate``)."""
