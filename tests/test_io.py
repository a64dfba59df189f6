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


@pytest.mark.parametrize("expected", ["right", "wrong"])
def test_model_assembly_writes_a_whole_checked_file_or_nothing(tmp_path, monkeypatch, expected):
    """The packaged GGUF is assembled through the same temp file: a checksum mismatch leaves no
    file at all; a match leaves the model with a new file's usual permissions and no temp."""
    import hashlib
    from types import SimpleNamespace

    from interllm.llm import model_files

    chunks = [tmp_path / "chunks" / f"c{i}" for i in range(2)]
    chunks[0].parent.mkdir()
    for i, c in enumerate(chunks):
        c.write_bytes(bytes([i]) * 1000)
    digest = hashlib.sha256(b"".join(c.read_bytes() for c in chunks)).hexdigest()
    pkg = SimpleNamespace(MODEL_NAME="m.gguf", EXPECTED_SHA256=digest if expected == "right" else "0" * 64,
                          verify_chunks=lambda: None, chunk_paths=lambda: chunks)
    monkeypatch.setattr(model_files, "_packaged", lambda: pkg)
    out = tmp_path / "models"
    if expected == "wrong":
        with pytest.raises(model_files.ModelFileError, match="reinstall"):
            model_files.assemble_packaged_model(out)
        assert os.listdir(out) == []
        return
    target = model_files.assemble_packaged_model(out)
    assert target.read_bytes() == b"".join(c.read_bytes() for c in chunks)
    assert not [n for n in os.listdir(out) if n.endswith(".tmp")]
    plain = tmp_path / "plain"
    plain.write_bytes(b"x")
    assert stat.S_IMODE(target.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode)
