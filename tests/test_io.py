"""Atomic writes: the old file survives a failed write; new files get the usual permissions."""

import os
import stat

import pytest

from interllm.io import atomic_write_bytes, read_json, write_json


def test_new_file_gets_the_same_permissions_as_open_gives(tmp_path):
    atomic_write_bytes(tmp_path / "atomic.bin", b"x")
    with open(tmp_path / "plain.bin", "wb") as f:
        f.write(b"x")
    mode = stat.S_IMODE((tmp_path / "plain.bin").stat().st_mode)
    assert stat.S_IMODE((tmp_path / "atomic.bin").stat().st_mode) == mode


def test_failed_write_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    p = tmp_path / "m.json"
    write_json(p, {"a": 1})

    class Boom:
        pass

    with pytest.raises(TypeError):
        write_json(p, {"a": Boom()})
    assert read_json(p) == {"a": 1}
    assert sorted(os.listdir(tmp_path)) == ["m.json"]


@pytest.mark.parametrize("fails", ["fsync", "replace"])
def test_a_write_that_fails_on_disk_keeps_the_old_file_and_leaves_no_temp(tmp_path, monkeypatch, fails):
    p = tmp_path / "m.bin"
    atomic_write_bytes(p, b"old")

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, fails, boom)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_bytes(p, b"new contents")
    monkeypatch.undo()
    assert p.read_bytes() == b"old"
    assert sorted(os.listdir(tmp_path)) == ["m.bin"]


def test_umask_is_read_not_guessed():
    from interllm.io import _umask

    mask = os.umask(0o027)
    try:
        assert _umask() == 0o027
    finally:
        os.umask(mask)
