"""A recording's journal (promp.live.journal) driven by hand: the append-only file (created
new, each write whole or cut back to the records acknowledged before it, short writes
completed, fsync-ed at creation, every FSYNC_S and when closed), the journal's header and
rows, what read_journal refuses, and the journals of a folder, oldest first."""

from __future__ import annotations

import errno
import json
import os

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import promp.live.journal
from promp.live.journal import MAGIC, AppendFile, Journal, journals, read_journal


class Disk:
    """The journal's ``os``: writes of at most ``chunk`` bytes, ``fail`` raised by the next
    write after writing half its data (a full disk), ``ftruncate`` failing when asked, every
    fsync counted; and its ``time``: a monotonic clock the test sets."""

    def __init__(self, chunk: int = 1 << 20):
        self.chunk, self.fail, self.truncate_fails = chunk, None, False
        self.synced: list[int] = []
        self.now = 100.0

    def __getattr__(self, name):
        return getattr(os, name)

    def write(self, fd: int, data: bytes) -> int:
        if self.fail is not None:
            os.write(fd, data[: len(data) // 2])
            raise self.fail
        return os.write(fd, data[: self.chunk])

    def ftruncate(self, fd: int, size: int) -> None:
        if self.truncate_fails:
            raise OSError(errno.EIO, "cannot truncate")
        os.ftruncate(fd, size)

    def fsync(self, fd: int) -> None:
        os.fstat(fd)  # an open file's descriptor
        self.synced.append(fd)

    def monotonic(self) -> float:
        return self.now


@pytest.fixture
def disk(monkeypatch) -> Disk:
    disk = Disk()
    monkeypatch.setattr(promp.live.journal, "os", disk)
    monkeypatch.setattr(promp.live.journal, "time", disk)
    return disk


def test_an_append_file_is_made_new_synced_and_appended_whole(tmp_path, disk) -> None:
    path = tmp_path / "deep" / "er" / "a.log"  # its folders made
    disk.chunk = 3  # the operating system takes 3 bytes a call: every byte written still
    f = AppendFile(path, "head\n")
    assert f.path == path and not f.closed and len(disk.synced) == 1
    assert os.stat(path).st_mode & 0o777 == 0o644 & ~_umask()
    f.write("one\n")
    f.write("two and more\n")
    assert path.read_text() == "head\none\ntwo and more\n" and len(disk.synced) == 1
    disk.now += promp.live.journal.FSYNC_S  # not past it yet
    f.write("3\n")
    assert len(disk.synced) == 1
    disk.now += 0.001  # past it: synced, then not again until FSYNC_S later
    f.write("4\n")
    f.write("5\n")
    assert len(disk.synced) == 2
    disk.now += promp.live.journal.FSYNC_S + 0.001
    f.write("6\n")
    assert len(disk.synced) == 3
    f.close()
    assert f.closed and len(disk.synced) == 4
    f.close()  # twice: nothing more
    assert len(disk.synced) == 4
    with pytest.raises(ValueError):
        f.write("after\n")
    assert path.read_text() == "head\none\ntwo and more\n3\n4\n5\n6\n"
    with pytest.raises(FileExistsError):
        AppendFile(path, "again\n")
    assert path.read_text().startswith("head\n")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_a_failed_write_is_cut_back_to_the_records_before_it(tmp_path, disk) -> None:
    f = AppendFile(tmp_path / "a.log", "h\n")
    f.write("first\n")
    f.write("second\n")
    disk.fail = OSError(errno.ENOSPC, "full")
    with pytest.raises(OSError) as failed:
        f.write("third, torn\n")
    assert failed.value.errno == errno.ENOSPC
    assert (tmp_path / "a.log").read_text() == "h\nfirst\nsecond\n"
    disk.fail = None
    f.write("third\n")  # once there is room: after the records acknowledged
    assert (tmp_path / "a.log").read_text() == "h\nfirst\nsecond\nthird\n"
    disk.fail, disk.truncate_fails = RuntimeError("odd"), True
    with pytest.raises(RuntimeError):  # the write's own error, not the truncation's
        f.write("fourth\n")
    f.close()


def test_a_file_whose_header_cannot_be_written_is_removed(tmp_path, disk) -> None:
    disk.fail = OSError(errno.ENOSPC, "full")
    open_files = len(os.listdir("/proc/self/fd"))
    with pytest.raises(OSError):
        AppendFile(tmp_path / "a.log", "header\n")
    assert not (tmp_path / "a.log").exists()
    assert len(os.listdir("/proc/self/fd")) == open_files  # closed
    disk.fail = None
    AppendFile(tmp_path / "a.log", "header\n").close()  # made anew: nothing was left
    assert (tmp_path / "a.log").read_text() == "header\n"


def test_a_journal_holds_its_header_and_rows_from_its_start(tmp_path) -> None:
    path = tmp_path / "j.journal"
    journal = Journal(path, ["x", "y"], "take-3", "left", 10)
    assert (journal.path, journal.columns, journal.start) == (path, ("x", "y"), 10.0)
    assert journal.acknowledged == 0
    assert journal.append(np.zeros(0), np.zeros((0, 2))) == 0  # nothing: nothing written
    lines = path.read_text().splitlines()
    assert len(lines) == 2 and lines[0].startswith(MAGIC) and lines[1] == "t,x,y"
    header = json.loads(lines[0][len(MAGIC):])
    assert header == {"name": "take-3", "label": "left", "start": 10.0, "columns": ["x", "y"]}
    values = np.array([[1, 2], [3, 4], [5, 6]])  # integers: written as numbers
    assert journal.append([10.0, 10.25, 10.5], values) == 3
    assert journal.append([11.0 + 1e-13], [[0.1, 1 / 3]]) == 4
    assert path.read_text().splitlines()[-1].endswith(",0.10000000000000001,0.33333333333333331")
    assert journal.append([12.0], [[1e-7, -2.5e11]]) == 5
    assert path.read_text().splitlines()[-1] == "2,9.9999999999999995e-08,-250000000000"
    assert journal.acknowledged == 5
    journal.close()
    with pytest.raises(ValueError):
        journal.append([12.0], [[0.0, 0.0]])
    demo, read = read_journal(path)
    assert read == header and demo.name == "take-3" and demo.columns == ("x", "y")
    assert_array_equal(demo.times, np.array([10.0, 10.25, 10.5, 11.0 + 1e-13, 12.0]) - 10.0)
    assert_array_equal(demo.values, [[1, 2], [3, 4], [5, 6], [0.1, 1 / 3], [1e-7, -2.5e11]])
    assert path.read_text().splitlines()[2] == "0,1,2"


@pytest.mark.parametrize("first", [
    "# promp-live journal 1 {not json",
    '# promp-live journal 1 {"label": "x", "start": 0}',  # no name
    '# promp-live journal 1 {"name": "x", "start": 0}',  # no label
    "# promp-live journal 1 [1, 2]",  # not an object
    "# promp-live journal 2 {}",
    "t,x",
])  # fmt: skip
def test_a_file_that_is_not_a_whole_journal_is_refused(tmp_path, first) -> None:
    path = tmp_path / "j.journal"
    path.write_text(f"{first}\nt,x\n0,1\n1,2\n")
    with pytest.raises(ValueError):
        read_journal(path)


def test_a_journal_that_cannot_be_read_is_refused(tmp_path) -> None:
    with pytest.raises(ValueError):
        read_journal(tmp_path / "absent.journal")
    (tmp_path / "bad.journal").write_bytes(MAGIC.encode() + b'{"name": "\xff"}\n')
    with pytest.raises(ValueError):
        read_journal(tmp_path / "bad.journal")
    (tmp_path / "short.journal").write_text(MAGIC + '{"name": "n", "label": ""}\nt,x\n0,1\n1,')
    with pytest.raises(ValueError):  # one whole row: not a demonstration
        read_journal(tmp_path / "short.journal")
    (tmp_path / "ok.journal").write_text(MAGIC + '{"name": 7, "label": 1}\nt,x\n0,1\n1,2\n2,')
    demo, header = read_journal(str(tmp_path / "ok.journal"))
    assert demo.name == "7" and demo.n_samples == 2 and header["label"] == 1


def test_the_journals_of_a_folder_oldest_first(tmp_path) -> None:
    assert journals(tmp_path / "absent") == []
    names = ["q", "c", "m", "b", "z", "f", "k"]  # of one age: by name
    for name, age in [(n + ".journal", 1) for n in names] + [("a.journal", 2), ("x.csv", 0)]:
        (tmp_path / name).write_text("")
        os.utime(tmp_path / name, (1e9 + age, 1e9 + age))
    assert [p.name for p in journals(str(tmp_path))] == [
        *(n + ".journal" for n in sorted(names)), "a.journal"]
