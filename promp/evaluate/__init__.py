"""Leave-one-out evaluation of the method on any dataset (``python -m promp.evaluate``).

The sweep is :func:`promp.evaluate.sweep.leave_one_out` (also ``promp.leave_one_out``); the
command line (``cli``), its reports and kept runs (``report``, ``runs``, ``compare``), the
figures (``plots``), the methods compared (``methods``; the original toolbox's, ``seed``), the
grouped sweep beside leave-one-out (``groups``, ``grouped``, ``group_gap``) and the outer check
of fixed settings (``fixed_settings``) are its modules. Nothing is imported
here: ``import promp.evaluate.sweep`` loads what it needs.
"""

__all__: list[str] = []
