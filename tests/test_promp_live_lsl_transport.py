"""The LSL transport (promp.live.lsl) on the loopback (tests/lsl_loopback.cfg): a stream's
description as its info tells it, an outlet found, opened and pulled (samples on this
machine's clock, in order, with their values; markers as text), an outlet's refusals. Each
wait is for a state (the stream listed, the samples arrived), with a generous deadline."""

from __future__ import annotations

import inspect
import socket
import threading
import time

import numpy as np
import pytest

from promp.live.transport import OutletSpec, StreamLost
from tests.conftest import PATIENCE_S

pylsl = pytest.importorskip("pylsl")
lsl = pytest.importorskip("promp.live.lsl")
from tests import lsl_push  # noqa: E402

DEADLINE_S = PATIENCE_S  # a real stream's discovery on a loaded machine


def info_with(labels=None, units=None, n=3, fmt=None):
    """An info of ``n`` channels; a label ``"*note"`` is an element among the channels that
    is not one (another program's)."""
    fmt = pylsl.cf_double64 if fmt is None else fmt
    info = pylsl.StreamInfo("Hand", "Mocap", n, 100.0, fmt, "src-1")
    if labels is not None:
        channels = info.desc().append_child("channels")
        for label, unit in zip(labels, units, strict=True):
            channel = channels.append_child(label[1:] if label[:1] == "*" else "channel")
            channel.append_child_value("label", label)
            channel.append_child_value("unit", unit)
    return info


def test_a_description_is_what_the_info_tells():
    d = lsl.describe(info_with(("x", "y", "z"), ("mm", "mm", "mm")))
    assert (d.name, d.type, d.source_id, d.rate, d.format) == ("Hand", "Mocap", "src-1", 100.0,
                                                              "double64")  # fmt: skip
    assert d.labels == ("x", "y", "z") and d.units == ("mm", "mm", "mm")
    assert lsl.describe(info_with(fmt=pylsl.cf_float32)).format == "float32"
    assert lsl.describe(info_with(fmt=pylsl.cf_string, n=1)).is_markers
    assert lsl.describe(info_with(fmt=pylsl.cf_undefined)).format == "undefined"


def test_only_the_channel_elements_describe_the_channels():
    labels, units = ("x", "*note", "y", "z"), ("mm", "", "mm", "rad")
    d = lsl.describe(info_with(labels, units))
    assert d.labels == ("x", "y", "z") and d.units == ("mm", "mm", "rad")


def test_channels_not_all_described_are_unnamed():
    assert lsl.describe(info_with()).labels == ("", "", "")
    short = lsl.describe(info_with(("x", "y"), ("m", "m")))  # 2 of 3 described
    assert short.labels == ("", "", "") and short.units == ("", "", "")
    longer = info_with(("a", "b", "c", "d"), ("1", "2", "3", "4"))
    assert lsl.describe(longer).labels == ("a", "b", "c")  # the first n


def test_an_outlet_is_double64_or_string_with_a_unit_per_label():
    with pytest.raises(ValueError):
        lsl.LslOutlet(OutletSpec("X", "T", "s", ("a",), ("",), format="float32"))
    with pytest.raises(ValueError):
        lsl.LslOutlet(OutletSpec("X", "T", "s", ("a", "b"), ("m",)))


def found(transport, name: str):
    deadline = time.monotonic() + DEADLINE_S
    while time.monotonic() < deadline:
        streams = [s for s in transport.find(0.5) if s.name == name]
        if streams:
            return streams[0]
    raise AssertionError(f"{name} not found in {DEADLINE_S} s")


def pulled(inlet, n: int):
    times, values = [], []
    deadline = time.monotonic() + DEADLINE_S
    while len(times) < n and time.monotonic() < deadline:
        t, v = inlet.pull()
        times += list(t)
        values += list(v)
        time.sleep(0.01)
    return np.asarray(times), values


def test_an_outlet_is_found_opened_and_pulled_on_this_machine_s_clock():
    transport = lsl.LslTransport()
    name = f"promp-test-{time.monotonic_ns()}"
    spec = OutletSpec(name, "Mocap", "promp-test", ("x", "y"), ("m", "m"), rate=50.0)
    outlet = lsl.LslOutlet(spec)
    stream = found(transport, name)
    assert stream.rate == 50.0 and stream.source_id == "promp-test" and stream.uid
    inlet = transport.open(stream)
    d = inlet.description  # the full info: the channels' description too
    assert d.uid == stream.uid and d.labels == ("x", "y") and d.units == ("m", "m")
    assert d.host == socket.gethostname()
    assert inlet._inlet.info().desc().child_value("producer") == "promp.live"
    assert outlet.wait_for_consumers(DEADLINE_S)
    now = transport.clock() - 5.0  # stamped by the sender, not when it was pushed
    rows = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    outlet.push(rows, now)
    times, values = pulled(inlet, 3)
    assert len(times) == 3
    np.testing.assert_array_equal(np.asarray(values), rows)
    assert np.allclose(times, now + inlet.offset(), atol=1e-6)
    assert abs(inlet.offset()) < 1.0  # the same machine
    empty_t, empty_v = inlet.pull()
    assert empty_t.size == 0 and np.asarray(empty_v).shape == (0, 2)
    inlet.close()
    inlet.close()  # twice: nothing left to close
    outlet.close()


def test_markers_are_pulled_as_text():
    transport = lsl.LslTransport()
    name = f"promp-marks-{time.monotonic_ns()}"
    outlet = transport.outlet(OutletSpec(name, "Markers", "promp-test", ("label",), ("",),
                                         format="string"))  # fmt: skip
    stream = found(transport, name)
    assert stream.is_markers
    inlet = transport.open(stream)
    assert outlet.wait_for_consumers(DEADLINE_S)
    before = lsl.local_clock()
    now = transport.clock()
    assert isinstance(before, float) and before <= now  # the same clock, LSL's
    outlet.push(["start left", 7], now)
    _, labels = pulled(inlet, 2)
    assert labels == ["start left", "7"]
    outlet.close()


def opened_pair(name: str):
    transport = lsl.LslTransport()
    outlet = transport.outlet(OutletSpec(name, "Mocap", "promp-test", ("x",), ("m",), rate=100.0))
    inlet = transport.open(found(transport, name))
    assert outlet.wait_for_consumers(DEADLINE_S)
    return transport, outlet, inlet


def test_the_clock_correction_is_renewed_only_when_it_moves_more_than_its_step():
    transport, outlet, inlet = opened_pair(f"promp-offset-{time.monotonic_ns()}")
    estimate = [lsl.OFFSET_STEP_S]  # LSL's estimate of the sender's clock offset, s
    inlet._offset = 0.0
    inlet._inlet.time_correction = lambda timeout=None: estimate[0]
    inlet.pull()
    assert inlet.offset() == 0.0  # a move of exactly the step: kept
    estimate[0] = 0.5
    now = transport.clock()
    outlet.push([[1.0]], now)
    times, _ = pulled(inlet, 1)
    assert inlet.offset() == 0.5 and times.tolist() == [pytest.approx(now + 0.5, abs=1e-9)]
    estimate[0] = 0.5 + lsl.OFFSET_STEP_S / 2
    inlet.pull()
    assert inlet.offset() == 0.5  # a wobble under the step: the samples are not shifted
    outlet.close()


def test_a_closed_outlet_s_inlet_says_its_stream_is_lost():
    transport, outlet, inlet = opened_pair(f"promp-lost-{time.monotonic_ns()}")
    outlet.close()
    deadline = time.monotonic() + DEADLINE_S
    with pytest.raises(StreamLost):
        while time.monotonic() < deadline:
            inlet.pull()
            time.sleep(0.05)
    inlet.close()


def test_a_pull_takes_every_sample_waiting_however_many():
    transport, outlet, inlet = opened_pair(f"promp-many-{time.monotonic_ns()}")
    for n in (1, 4100):  # one sample; more than one chunk of the inlet's (4096)
        rows = np.arange(n, dtype=float)[:, None]
        outlet.push(rows, transport.clock())
        deadline = time.monotonic() + DEADLINE_S
        while inlet._inlet.samples_available() < n and time.monotonic() < deadline:
            time.sleep(0.01)
        times, values = inlet.pull()
        assert times.size == n and np.array_equal(values, rows)
    outlet.close()


def test_the_first_look_waits_for_the_resolver_s_first_answers():
    transport = lsl.LslTransport()
    transport.find(0.3)
    assert lsl.local_clock() >= transport._since + 0.3  # (a lower bound: load only adds)


def test_a_look_that_may_not_wait_does_not_wait(monkeypatch):
    slept = []
    monkeypatch.setattr(lsl.time, "sleep", slept.append)
    transport = lsl.LslTransport()
    transport.find(0.0)
    transport.find(-1.0)
    assert slept == []


def test_a_stream_another_look_found_is_opened_by_its_uid():
    name = f"promp-uid-{time.monotonic_ns()}"
    outlet = lsl.LslOutlet(OutletSpec(name, "Mocap", "promp-test", ("x",), ("m",), rate=100.0))
    stream = found(lsl.LslTransport(), name)
    inlet = lsl.LslTransport().open(stream)  # a transport that never looked: resolved by uid
    assert inlet.description.uid == stream.uid
    inlet.close()
    outlet.close()


@pytest.mark.parametrize("fmt", ["int16", "float32"])
def test_a_stream_s_samples_are_pulled_as_double_whatever_its_format(fmt):
    name = f"promp-{fmt}-{time.monotonic_ns()}"
    info = pylsl.StreamInfo(name, "Mocap", 2, 100.0, getattr(pylsl, f"cf_{fmt}"), "promp-test")
    outlet = lsl_push.outlet(info)  # another program's: any channel format
    transport = lsl.LslTransport()
    inlet = transport.open(found(transport, name))
    assert outlet.wait_for_consumers(DEADLINE_S)
    outlet.push_chunk([[1, -2], [300, 4]], transport.clock())
    _, values = pulled(inlet, 2)
    values = np.asarray(values)  # (the rows of the pulls, gathered)
    assert values.dtype == np.float64 and values.tolist() == [[1.0, -2.0], [300.0, 4.0]]
    inlet.close()


def test_a_stream_the_transport_found_is_opened_without_asking_the_network_again(monkeypatch):
    name = f"promp-known-{time.monotonic_ns()}"
    outlet = lsl.LslOutlet(OutletSpec(name, "Mocap", "promp-test", ("x",), ("m",), rate=100.0))
    transport = lsl.LslTransport()
    stream = found(transport, name)
    asked = []
    monkeypatch.setattr(lsl.pylsl, "resolve_bypred", lambda *a, **k: asked.append(a) or [])
    inlet = transport.open(stream)  # from the info of the look, even with the network silent
    assert inlet.description.uid == stream.uid and asked == []
    inlet.close()
    outlet.close()


def test_a_stream_not_found_by_a_look_is_asked_for_by_uid_for_a_bounded_time(monkeypatch):
    asked = []

    def resolve(predicate, minimum=1, timeout=pylsl.FOREVER):  # pylsl's, on a silent network
        asked.append((predicate, minimum, timeout))
        return []

    monkeypatch.setattr(lsl.pylsl, "resolve_bypred", resolve)
    stream = lsl.describe(info_with())  # another transport's look: uid "" here
    with pytest.raises(StreamLost):
        lsl.LslTransport().open(stream)
    # the first answer is enough; no answer in OPEN_TIMEOUT_S: the stream is gone
    assert asked == [(f"uid='{stream.uid}'", 1, lsl.OPEN_TIMEOUT_S)]


def test_a_pull_never_waits_for_lsl():
    transport, outlet, inlet = opened_pair(f"promp-nowait-{time.monotonic_ns()}")
    waits = []  # the timeout of each of LSL's calls a pull makes, as pylsl reads it

    def spied(method):
        def call(*args, **kwargs):
            bound = inspect.signature(method).bind(*args, **kwargs)
            bound.apply_defaults()
            waits.append(bound.arguments["timeout"])
            return method(*args, **kwargs)
        return call

    for name in ("time_correction", "pull_chunk"):
        setattr(inlet._inlet, name, spied(getattr(inlet._inlet, name)))
    inlet.pull()  # nothing there
    outlet.push([[1.0], [2.0]], transport.clock())
    times, _ = pulled(inlet, 2)
    assert len(times) == 2 and len(waits) >= 4 and set(waits) == {0.0}
    outlet.close()


class _CountingOutlet:
    """Records what :class:`lsl.LslOutlet` hands to liblsl, call by call."""

    def __init__(self, info, chunk_size=0, max_buffered=360):
        self.calls = []
        self.obj = 1  # open (a handle liblsl never sees: the test does not close it)

    def push_chunk(self, x, timestamp=0.0, pushthrough=True):
        self.calls.append(("chunk", np.asarray(x).tolist(), list(timestamp), pushthrough))

    def push_sample(self, x, timestamp=0.0, pushthrough=True):
        self.calls.append(("sample", list(x), timestamp, pushthrough))


@pytest.mark.parametrize("fmt, rows, sent", [
    ("double64", np.arange(100.0).reshape(50, 2), np.arange(100.0).reshape(50, 2).tolist()),
    ("string", ["start left", 7], [["start left"], ["7"]]),
])  # fmt: skip
def test_an_outlet_hands_a_push_to_liblsl_in_one_call_every_row_with_its_stamp(
    monkeypatch, fmt, rows, sent
):
    # each call into liblsl gives up the interpreter's lock; a remainder of 50 rows pushed
    # row by row waited for it 50 times behind a session thread that was inferring
    monkeypatch.setattr(lsl.pylsl, "StreamOutlet", _CountingOutlet)
    labels = ("a", "b") if fmt == "double64" else ("label",)
    outlet = lsl.LslOutlet(OutletSpec("X", "T", "s", labels, ("",) * len(labels), format=fmt))
    outlet.push(rows, 12.5)
    assert outlet._outlet.calls == [("chunk", sent, [12.5] * len(sent), True)]
    outlet.push(np.zeros((0, 2)) if fmt == "double64" else [], 13.0)  # nothing to push
    assert len(outlet._outlet.calls) == 1


def held_elsewhere(lock) -> tuple[threading.Event, threading.Event]:
    """``lock`` taken by another thread until the second event is set (the first: taken)."""
    taken, free = threading.Event(), threading.Event()

    def hold() -> None:
        with lock:
            taken.set()
            free.wait()

    threading.Thread(target=hold, daemon=True).start()
    assert taken.wait(DEADLINE_S)
    return taken, free


def test_an_outlet_is_destroyed_only_while_no_inlet_of_this_process_is_being_opened():
    # liblsl crashes when an outlet dies while another thread opens an inlet on it
    # (bench/lsl_lifecycle.py): a close waits for the opening under way, then destroys it
    outlet = lsl.LslOutlet(OutletSpec(f"promp-life-{time.monotonic_ns()}", "Mocap", "t", ("x",),
                                      ("m",), rate=100.0))  # fmt: skip
    _, free = held_elsewhere(lsl.LIFECYCLE)  # an inlet being opened
    closed = threading.Event()
    threading.Thread(target=lambda: (outlet.close(), closed.set()), daemon=True).start()
    assert not closed.wait(0.3)
    free.set()
    assert closed.wait(DEADLINE_S)
    assert not outlet._outlet.obj  # destroyed now, not by the garbage collector later
    with pytest.raises(ValueError, match="is closed"):
        outlet.push([[1.0]], 0.0)  # a clear error, not liblsl on a freed handle
    assert outlet.wait_for_consumers(1.0) is False
    outlet.close()  # twice: nothing


def test_an_inlet_is_opened_under_the_lifecycle_lock_and_destroyed_when_closed(monkeypatch):
    transport, outlet, inlet = opened_pair(f"promp-life-in-{time.monotonic_ns()}")
    inlet.close()
    assert not inlet._inlet.obj
    with pytest.raises(StreamLost, match="closed"):
        inlet.pull()
    inlet.close()  # twice: nothing
    free_while_opening = []
    opening = pylsl.StreamInlet.open_stream

    def probe() -> None:  # from another thread: is the lock free?
        free = lsl.LIFECYCLE.acquire(False)
        if free:
            lsl.LIFECYCLE.release()
        free_while_opening.append(free)

    def spied(self, timeout=pylsl.FOREVER):
        asked = threading.Thread(target=probe)
        asked.start()
        asked.join()
        return opening(self, timeout)

    monkeypatch.setattr(pylsl.StreamInlet, "open_stream", spied)
    again = transport.open(found(transport, outlet._name))
    assert free_while_opening == [False]
    again.close()
    outlet.close()
