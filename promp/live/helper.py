"""A helper process for the online predictor: it integrates some primitives' likelihoods over
their speed prior while the session's process does the others, so that an update takes about
three quarters of its time on two cores (the ideal half is not reached: docs/live.md).

An update's cost is recognition (every primitive's likelihood at ~30 candidate speeds, about
three quarters of it) and then the recognised primitive's timing, conditioning and
predictions. The primitives' integrals are independent (:meth:`promp.evidence.Evidence.
integral`). The helper (``python -m promp.live.helper``, spawned by :class:`Helper`) keeps its
own evidence of the movement, extended by the same rows as the session's, and integrates a
fixed share of the primitives (:func:`shares`): each primitive is integrated every update of a
movement by one process alone, with the same kept sums as one process would keep, so the
numbers are the ones one process computes, bit for bit. The session's process integrates the
rest, and prepares the timing, weights and predictions of the primitive recognised last
(:meth:`promp.evidence.Evidence.prepare`) as soon as that primitive's integral is known: the
helper sends it first when it is the helper's.

They talk over the helper's standard input and output in frames of JSON and raw float64
arrays (no pickle): the model once (its JSON file's text), then per update the movement's
new rows and the primitives wanted, and back each primitive's integral. A helper that fails,
exits or does not answer within :data:`ANSWER_TIMEOUT_S` is stopped, and the session's
process integrates every primitive from then on (:attr:`Helper.failure` says why): the
movement under way then differs from one process's numbers at round-off (its sums are
recomputed), the next ones not at all.
"""

from __future__ import annotations

import json
import os
import select
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Sequence

import numpy as np

from promp.evidence.evidence import Evidence, Integral
from promp.observation import Observation

__all__ = ["ANSWER_TIMEOUT_S", "decode", "encode", "Helper", "integral_arrays", "integrals_from",
           "main", "MAX_FRAME", "read_frame", "READY_TIMEOUT_S", "serve", "shares"]

ANSWER_TIMEOUT_S = 5.0  # an update's answer: the helper is stopped past it
READY_TIMEOUT_S = 60.0  # the helper's start (a Python process importing numpy): given up past it
_LENGTH = struct.Struct("<QI")  # a frame's length after this prefix, its JSON header's length
MAX_FRAME = 1 << 28  # bytes (a movement of 10 minutes at 1 kHz x 50 channels is ~240 MB)


def shares(n_primitives: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The primitives the session's process integrates and those the helper does.

    The session's process also computes the recognised primitive's timing, conditioning and
    predictions, about one primitive's integral: it keeps ``(K - 1) // 2`` of the K
    primitives (the last ones), the helper the others."""
    own = (n_primitives - 1) // 2
    return tuple(range(n_primitives - own, n_primitives)), tuple(range(n_primitives - own))


# ---------------------------------------------------------------------------- frames


def encode(header: dict, arrays: Sequence[np.ndarray] = ()) -> bytes:
    """A frame: ``header`` (JSON) and ``arrays`` (float64, C order), their shapes in it."""
    arrays = [np.ascontiguousarray(a, dtype="<f8") for a in arrays]
    text = json.dumps({**header, "shapes": [list(a.shape) for a in arrays]}).encode()
    body = b"".join(a.tobytes() for a in arrays)
    return _LENGTH.pack(len(text) + len(body), len(text)) + text + body


def decode(text: bytes, body: bytes) -> tuple[dict, list[np.ndarray]]:
    """A frame's header and arrays (read-only views of ``body``)."""
    header = json.loads(text)
    arrays, at = [], 0
    for shape in header.pop("shapes"):
        n = int(np.prod(shape, dtype=np.int64))
        arrays.append(np.frombuffer(body, "<f8", n, at).reshape(shape))
        at += 8 * n
    if at != len(body):
        raise ValueError(f"a frame's arrays hold {at} bytes of its {len(body)}")
    return header, arrays


def _read_exactly(read, n: int) -> bytes | None:
    chunks, left = [], n
    while left:
        chunk = read(min(left, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def read_frame(read) -> tuple[dict, list[np.ndarray]] | None:
    """The next frame from ``read(n)`` (None at the end of the stream)."""
    prefix = _read_exactly(read, _LENGTH.size)
    if prefix is None:
        return None
    length, text_length = _LENGTH.unpack(prefix)
    if length > MAX_FRAME or text_length > length:
        raise ValueError(f"a frame of {length} bytes (its header {text_length})")
    data = _read_exactly(read, length)
    if data is None:
        return None
    return decode(data[:text_length], data[text_length:])


def integral_arrays(integral: Integral) -> list[np.ndarray]:
    return [integral.nodes, integral.log_likelihoods, integral.log_prior,
            np.array([integral.log_evidence])]  # fmt: skip


def integrals_from(header: dict, arrays: list[np.ndarray]) -> dict[int, Integral]:
    out = {}
    for j, index in enumerate(header["indices"]):
        x, ll, lp, ev = arrays[4 * j : 4 * j + 4]
        out[int(index)] = Integral(x.copy(), ll.copy(), lp.copy(), float(ev[0]))
    return out


# ---------------------------------------------------------------------------- the session's side


class Helper:
    """The helper process of one online predictor (see the module docstring).

    Parameters
    ----------
    model_text : str
        The model's JSON file's text (:func:`promp.io.model_to_json`).
    alpha_method : str
    modalities : sequence of str
        The observed modalities, in the observation's order.
    command : sequence of str, optional
        The helper's command line (the tests' faulty helpers).
    """

    def __init__(self, model_text: str, alpha_method: str, modalities: Sequence[str],
                 command: Sequence[str] | None = None):  # fmt: skip
        self.failure = ""
        self._ready = False
        self._started = time.monotonic()
        self._sent: tuple[int, int] = (-1, 0)  # the movement and its rows the helper has
        self._waiting = 0  # frames of the update under way not read yet
        try:
            self._process: subprocess.Popen | None = subprocess.Popen(
                list(command or [sys.executable, "-m", "promp.live.helper"]),
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0,
            )  # fmt: skip
        except OSError as exc:  # (no process left: every update in the session's)
            self._process = None
            self.failure = f"it could not start ({exc})"
            return
        # the model is written by a thread: the pipe holds 64 kB and the helper reads only
        # once it has imported numpy (~1 s), which the session's first update must not wait
        # for (it is read whole before the helper says it is ready, and nothing is sent
        # before that)
        setup = encode({"model": model_text, "alpha_method": alpha_method,
                        "modalities": list(modalities)})  # fmt: skip
        threading.Thread(target=self._send, args=(setup,), name="live-helper-setup",
                         daemon=True).start()  # fmt: skip

    @property
    def alive(self) -> bool:
        return not self.failure

    @property
    def waiting(self) -> int:
        """Frames of the update asked not read yet."""
        return self._waiting

    def ready(self, wait: float = 0.0) -> bool:
        """Whether the helper has loaded the model (waiting at most ``wait`` seconds)."""
        if self._ready or self.failure:
            return self._ready and not self.failure
        frame = self._frame(wait) if self._readable(wait) else None
        if frame is not None:
            self._ready = True
        elif not self.failure and time.monotonic() - self._started > READY_TIMEOUT_S:
            self._fail(f"it did not start within {READY_TIMEOUT_S:.0f} s")
        return self._ready and not self.failure

    def submit(self, movement: int, observation: Observation, indices: Sequence[int]) -> bool:
        """Ask for ``indices``' integrals on ``observation`` (movement ``movement`` so far),
        in that order; they come back in two frames: the first index's, then the others'.
        False when the helper failed (nothing asked)."""
        if self.failure:
            return False
        same, rows = movement == self._sent[0], observation.n_observed
        start = self._sent[1] if same and rows >= self._sent[1] else 0
        header = {"movement": int(movement), "start": start, "indices": [int(i) for i in indices]}
        if not self._send(encode(header, [observation.times[start:],
                                          observation.values[start:]])):  # fmt: skip
            return False
        self._sent = (movement, rows)
        self._waiting = 2
        return True

    def collect(self) -> dict[int, Integral] | None:
        """The next frame's integrals of the update asked (None when the helper failed:
        it is stopped; or when its engine refused the observation)."""
        if self.failure or not self._waiting:
            return None
        frame = self._frame(ANSWER_TIMEOUT_S) if self._readable(ANSWER_TIMEOUT_S) else None
        if frame is None:
            self._fail(self.failure or f"it did not answer within {ANSWER_TIMEOUT_S:.0f} s")
            return None
        self._waiting -= 1
        header, arrays = frame
        if "error" in header:  # the engine refused: this process computes it and says why
            self._waiting = 0
            return None
        return integrals_from(header, arrays)

    def forget(self) -> None:
        """Read and drop what the update under way has not read yet."""
        while self._waiting and self.collect() is not None:
            pass
        self._waiting = 0

    def close(self) -> None:
        """Stop the helper (its input closed: it exits; killed if it does not)."""
        process = self._process
        if process is None:
            return
        if process.poll() is None:
            try:
                process.stdin.close()
                process.wait(timeout=2.0)
            except (OSError, subprocess.TimeoutExpired):
                process.kill()
                process.wait()
        for stream in (process.stdin, process.stdout):
            stream.close()
        if not self.failure:
            self.failure = "it was closed"

    def _send(self, frame: bytes) -> bool:
        try:
            self._process.stdin.write(frame)
        except (OSError, ValueError) as exc:
            self._fail(f"it stopped reading ({exc})")
            return False
        return True

    def _readable(self, wait: float) -> bool:
        if self.failure:
            return False
        try:
            ready, _, _ = select.select([self._process.stdout], [], [], wait)
        except (OSError, ValueError) as exc:
            self._fail(str(exc))
            return False
        return bool(ready)

    def _frame(self, wait: float) -> tuple[dict, list[np.ndarray]] | None:
        fd = self._process.stdout.fileno()
        deadline = time.monotonic() + max(wait, ANSWER_TIMEOUT_S)  # (a frame begun: its rest)

        def read(n: int) -> bytes:
            if not select.select([fd], [], [], max(deadline - time.monotonic(), 0.0))[0]:
                return b""
            return os.read(fd, n)

        try:
            frame = read_frame(read)
        except (OSError, ValueError) as exc:
            self._fail(f"it sent something unreadable ({exc})")
            return None
        if frame is None:
            code = self._process.poll()
            self._fail("it exited" if code is not None else "it stopped answering mid-frame")
        return frame

    def _fail(self, why: str) -> None:
        if not self.failure:
            self.failure = why
        self._waiting = 0
        if self._process is not None and self._process.poll() is None:
            self._process.kill()
            self._process.wait()


# ---------------------------------------------------------------------------- the helper's side


def serve(read, write) -> None:
    """The helper's loop: the model, then one answer per update (see the module docstring)."""
    from promp.io import model_from_json

    frame = read_frame(read)
    if frame is None:
        return
    setup, _ = frame
    model = model_from_json(setup["model"])
    alpha_method, modalities = setup["alpha_method"], tuple(setup["modalities"])
    write(encode({"ready": True}))
    movement, times, values, evidence = None, np.empty(0), np.empty((0, 0)), None
    while (frame := read_frame(read)) is not None:
        header, (new_times, new_values) = frame
        if header["movement"] != movement or header["start"] == 0:
            movement, times, values, evidence = header["movement"], new_times, new_values, None
        else:
            times = np.concatenate([times[: header["start"]], new_times])
            values = np.concatenate([values[: header["start"]], new_values])
        first, *rest = header["indices"]
        try:
            obs = Observation(times, values, modalities)
            evidence = Evidence(model, obs, alpha_method) if evidence is None \
                else evidence.extended(obs)  # fmt: skip
            for indices in ([first], rest):
                got = [evidence.integral(i) for i in indices]
                write(encode({"indices": indices},
                             [a for i in got for a in integral_arrays(i)]))  # fmt: skip
        except Exception as exc:  # noqa: BLE001 - said to the session, which computes it
            evidence = None
            write(encode({"error": f"{type(exc).__name__}: {exc}"}))


def main() -> None:
    # Ctrl-C reaches the whole process group: the session stops its helper (its input closed)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # the frames go to the real standard output; a stray print goes to the error stream
    out = os.fdopen(os.dup(1), "wb", buffering=0)
    os.dup2(2, 1)
    source = sys.stdin.buffer

    def write(frame: bytes) -> None:
        out.write(frame)

    serve(source.read, write)


if __name__ == "__main__":
    main()
