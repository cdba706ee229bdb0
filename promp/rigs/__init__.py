"""Recordings straight from real rigs: YARP logs, ROS bags, LSL's XDF, C3D motion capture.

One reader per format, behind :func:`promp.datasets.read_dataset` (``--format
yarp|rosbag|xdf|c3d``), each on the field's own library, installed as an optional extra
(``pip install 'icub-intention-studio[rigs]'``, or one of ``[rosbag]``, ``[xdf]``, ``[c3d]``;
YARP's text logs need none). A missing library is a ValueError naming its extra.

* :mod:`promp.rigs.yarp`: ``dataDumper`` folders, take folders ``<class>/<take>/<port>/data.log``
  or numbered port folders ``<class>/<port>/<port>_NNNNN/data.log`` (:mod:`promp.rigs.yarp_layout`);
* :mod:`promp.rigs.rosbag`: ROS 1 ``.bag``, ROS 2 bags (``.db3``, ``.mcap``), via ``rosbags``;
* :mod:`promp.rigs.xdf`: LabRecorder's ``.xdf``, via ``pyxdf``;
* :mod:`promp.rigs.c3d`: ``.c3d``, via ``ezc3d`` (millimetres converted to metres).

**Mapping** (:mod:`promp.rigs.mapping`): ``NAME=STREAM:FIELD,FIELD,...[@UNIT]``, e.g.
``hand=/icub/left_hand/pose:pose.position.{x,y,z}``,
``head=/tf:head.rotation.{roll,pitch,yaw}``, ``hand=Subject1:LHAND:x,y,z``,
``arm=left_arm_state:0,1,2@deg``. Without one, a mapping is guessed from the first recording
and shown, with what it left out (:func:`guessed_rig_mapping` gives the guess alone, for a
refusal to show it too).

**One clock** (:mod:`promp.rigs.streams`): the streams are put on one time base by their
time stamps (the slowest stream's, or a chosen rate), never by sample index, over the span
they all cover: a stream that starts or stops up to 10 % of the demonstration away from the
others is cut (said in the notes), further it is an error naming it, as is one that pauses.

**Demonstrations** (:mod:`promp.rigs.dataset`, :mod:`promp.rigs.cutting`): one recording per
demonstration in ``<class>/`` folders, or a session cut by its markers (``start CLASS`` ...
``end CLASS``) or at its still periods.
"""

from __future__ import annotations

import argparse

from promp.rigs.dataset import (
    CUTS,
    RIG_FORMATS,
    RigOptions,
    RigRead,
    guessed_rig_mapping,
    read_rig_dataset,
)

__all__ = ["CUTS", "MAPPING_HELP", "RIG_FORMATS", "RigOptions", "RigRead", "guessed_rig_mapping",
           "read_rig_dataset", "add_rig_arguments", "rig_options"]  # fmt: skip

MAPPING_HELP = (
    "for recordings (yarp, rosbag, xdf, c3d): NAME=STREAM:FIELD,FIELD,...[@UNIT], the stream "
    "(a ROS topic, an XDF stream, a YARP port folder, a C3D marker label; everything before "
    "the last ':') and its fields (ROS: dotted paths, pose.position.{x,y,z}, "
    "orientation.{roll,pitch,yaw} of a quaternion, /tf:FRAME.x,y,z; XDF: channel "
    "labels or indices; YARP: value indices 0,1,...; C3D: x,y,z, or ANALOG:LABEL); @mm, @cm "
    "and @deg are converted to metres and radians"
)


def add_rig_arguments(parser: argparse.ArgumentParser) -> None:
    """``--mapping``, ``--cut``, ``--rate`` and ``--markers`` (what :func:`rig_options` reads)."""
    parser.add_argument(
        "--mapping",
        default=None,
        metavar="FILE",
        help="a mapping file: one modality per line (as --modality), '#' comments",
    )
    parser.add_argument(
        "--cut",
        choices=CUTS,
        default="auto",
        help="recordings: 'markers' cuts each by its marker stream ('start CLASS' ... "
        "'end CLASS'), 'still' at its still periods, 'files' takes each whole (one per "
        "demonstration in <class>/ folders); 'auto': markers when it has some, else whole",
    )
    parser.add_argument(
        "--rate",
        type=float,
        default=None,
        metavar="HZ",
        help="recordings: put every stream on a regular time base at this rate; default: the "
        "slowest stream's own time stamps (the others interpolated at them)",
    )
    parser.add_argument(
        "--markers",
        default="",
        metavar="STREAM",
        help="recordings: the marker stream to cut by, when a recording has several",
    )


def rig_options(args: argparse.Namespace) -> RigOptions:
    """The :class:`RigOptions` of parsed :func:`add_rig_arguments` arguments."""
    return RigOptions(cut=args.cut, rate=args.rate, markers=args.markers)
