"""Viewer files: what the studio and the evaluation show, for Rerun (``.rrd``) and for
Foxglove, PlotJuggler and ROS 2 tools (MCAP with Foxglove's schemas).

A :class:`promp.viewers.scene_log.SceneLog` holds 3-D items and scalar series at paths, static
or at times of named timelines; ``rerun_writer`` and ``mcap_writer`` write the same log to
either format (their libraries, the ``rerun`` and ``mcap`` extras, imported on first use);
``trial`` and ``regions`` draw an inference. Nothing is imported here.
"""

__all__: list[str] = []
