"""Live sessions: a lab's sensors streamed in over the Lab Streaming Layer (LSL), the partner's
movement predicted as it happens, the prediction published for the robot.

A pipeline of small stages on one clock (the session's LSL ``local_clock``), each testable
with a fake upstream and a recorded stream, only the transport knowing LSL:

* :mod:`promp.live.source`: the inputs' streams (chosen by name, type or source id, channels
  and units in the rig formats' mapping syntax, ``hand=MocapHand:0,1,2@mm``:
  :mod:`promp.live.inputs`), their samples on the session's clock, a late sender's bursts put
  back at their rate (:mod:`promp.live.restamp`), their faults (:mod:`promp.live.status`);
* :mod:`promp.live.timebase`: the inputs, at their own rates, on one time base (the XDF
  reader's :func:`promp.rigs.streams.on_one_clock`);
* :mod:`promp.live.segmenter`: where each movement starts and ends (stillness, by the rule
  the model learned its demonstrations with, a marker stream, or calls);
* :mod:`promp.live.predictor`: the movement so far through :func:`promp.evidence.infer`
  (part of each update's recognition in a helper process on two cores,
  :mod:`promp.live.helper`: the same numbers);
* :mod:`promp.live.commitment`: with ``--decide``, :class:`promp.decision.CommitRule` on each
  movement's predictions (the moment the robot acts);
* sinks (:mod:`promp.live.sinks`: each on its own thread, behind a bounded queue):
  :mod:`promp.live.outlets` (the prediction as LSL streams) and :mod:`promp.live.recorder`
  (each movement a demonstration; a journal a kill cannot undo).

:func:`promp.live.pipeline.step` is the stages' pure step (no clock, no stream, no file);
:class:`promp.live.session.LiveSession` is the thin runner around it, its sinks given when it
is made (:mod:`promp.live.intake` gathers what arrives; the studio's loop reads its
:class:`~promp.live.session.LiveSnapshot`); ``python -m promp.live`` is the headless command
(:mod:`promp.live.cli`). :mod:`promp.live.transport` says what a transport does and
:mod:`promp.live.lsl` is the one over LSL (the only module that imports ``pylsl``: the
optional extra ``live``); :func:`lsl_available` tells whether it can load, and why not.
"""

from __future__ import annotations

__all__ = ["lsl_available"]


def lsl_available() -> tuple[bool, str]:
    """Whether LSL can be used here, and if not, the message saying why and what to do."""
    from promp.live.transport import LSLUnavailable

    try:
        import promp.live.lsl  # noqa: F401
    except LSLUnavailable as exc:
        return False, str(exc)
    return True, ""
