"""The scenes stage writes the same houses in one process and in worker processes, and a failing
house is named by the stage, not lost in a worker."""

from __future__ import annotations

import pytest

from interllm.config import from_dict
from interllm.errors import StageError
from interllm.stages.scenes import run_scenes

TINY = {"name": "tiny", "n_rooms": 4, "n_furniture": 8, "n_objects": 12, "n_scenes": 2}


def _files(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_one_or_two_workers_write_the_same_scenes(tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    outs = {}
    for jobs in (1, 2):
        cfg = from_dict({"scene": TINY, "jobs": jobs})
        assert run_scenes(cfg, tmp_path / f"scenes{jobs}") == ["tiny_s0000", "tiny_s0001"]  # in order
        outs[jobs] = _files(tmp_path / f"scenes{jobs}")
    assert sorted(outs[1]) == sorted(outs[2]) and len(outs[1]) >= 2 * 7  # every file of every house, nothing else
    moved = [str(f) for f in outs[1] if outs[1][f] != outs[2][f]]
    assert not moved, f"written differently by two workers: {moved}"


def test_a_house_that_fails_in_a_worker_is_named(tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    imported = tmp_path / "houses"
    for k, text in (("a", "{}"), ("b", "{\"id\": \"b\"}")):
        (imported / k).mkdir(parents=True)
        (imported / k / "scene.json").write_text(text)
    cfg = from_dict({"scene": {"import_path": str(imported)}, "jobs": 2})
    with pytest.raises(StageError, match=r"scenes stage: scene [01] failed: .*scene\.json"):
        run_scenes(cfg, tmp_path / "out")
