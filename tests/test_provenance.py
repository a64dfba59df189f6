"""What a run records of its checkout. The DVC stage's outputs are hashed into dvc.lock, so they must
not change with the git commit: otherwise a fresh clone's `make repro` leaves dvc.lock modified
although every result is the same bytes. A run outside DVC (pipeline.run's folders) keeps the commit."""

from __future__ import annotations

import subprocess

from interllm.stages.provenance import DVC_CHECKOUT, for_run_log, provenance
from pipeline._hydra import compose, to_config


def _git(repo, *args: str) -> None:
    subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                   check=True, capture_output=True, timeout=30)


def _provenance_at_two_commits(tmp_path, monkeypatch, record_commit: bool) -> tuple[dict, dict]:
    cfg = to_config(compose(["llm=oracle"]))
    _git(tmp_path, "init", "-q")
    monkeypatch.chdir(tmp_path)
    out = []
    for i in range(2):
        (tmp_path / "f.txt").write_text(str(i))
        _git(tmp_path, "add", "f.txt")
        _git(tmp_path, "commit", "-q", "-m", str(i))
        out.append(provenance(cfg, {"seed": 0}, record_commit=record_commit))
    return out[0], out[1]


def test_the_dvc_stages_provenance_and_run_logs_are_the_same_at_every_commit(tmp_path, monkeypatch):
    first, second = _provenance_at_two_commits(tmp_path, monkeypatch, record_commit=False)
    assert first == second and first["git_commit"] == DVC_CHECKOUT
    assert for_run_log(first) == for_run_log(second)


def test_a_run_outside_dvc_records_its_commit(tmp_path, monkeypatch):
    first, second = _provenance_at_two_commits(tmp_path, monkeypatch, record_commit=True)
    assert first["git_commit"] != second["git_commit"]
    assert len(first["git_commit"]) == 40


def test_a_model_that_cannot_be_identified_fails_the_run_and_names_the_key(tmp_path):
    """Not recorded as "unavailable": the LLM cache is keyed by the same hash, so such a run is not
    reproducible."""
    import pytest

    from interllm.llm.model_files import ModelFileError
    from interllm.stages.provenance import model_sha256

    cfg = to_config(compose([f"llm.model={tmp_path / 'missing.gguf'}"]))
    with pytest.raises(ModelFileError, match="llm.model"):
        model_sha256(cfg)
    assert len(model_sha256(to_config(compose([])))) == 64  # the packaged GGUF's sha256
