"""Resumable re-makes: a run folder that already holds a finished run of the same config and code is
not run again (``resume=true``; the Makefile's ``sweeps`` and ``mechanism`` targets set it).

A run that ends writes ``finished.json`` into its folder last (atomically): the job key and the
sha256 of the metrics.json it wrote. The job key is the sha256 of

- the resolved config, less the settings that choose how a run executes, not what it computes
  (``provenance.EXECUTION_SETTINGS``: jobs, llm.n_threads), and
- every file the results can depend on: the package's and the pipeline's Python files, the
  composed configs (``conf/``), and the benchmark the houses come from (``data/benchmarks/<name>``),
  by relative path and content.

So a re-make interrupted after some jobs re-runs only the jobs without a matching record: a job whose
config, code or benchmark changed since it finished, or whose metrics.json is gone or edited, is
made again. The LLM answers are not part of the key: the answer cache is keyed by prompt and model,
and a run that finds an answer missing asks the model for it (the same answer, ``llm.seed``).

Across machines and sessions: ``pipeline.collect_sweeps`` and ``pipeline.collect_runs`` copy each
job's ``finished.json`` into its committed copy (``COMMITTED_RUNS``). A job with no finished record
in its run folder whose key matches a committed copy is restored from that copy (its metrics and
report) instead of being made again; so a re-make committed part by part resumes on a fresh clone.
"""

from __future__ import annotations

import copy
import hashlib
import json
import shutil
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Optional

from interllm.io import atomic_write_text
from interllm.stages.provenance import EXECUTION_SETTINGS

FINISHED = "finished.json"  # in a run folder: written last by a run that ended
METRICS = Path("data") / "metrics" / "metrics.json"  # a run folder's metrics, relative to it
CODE_GLOBS = (("interllm", "*.py"), ("pipeline", "*.py"), ("conf", "*.yaml"))
# where the collectors put finished jobs' committed copies, relative to the repository
COMMITTED_RUNS = (Path("data") / "sweeps", Path("data") / "mechanism")


def _without_execution_settings(config: Mapping) -> dict:
    """``config`` (a resolved config dict) with ``EXECUTION_SETTINGS`` removed (dotted keys)."""
    out = copy.deepcopy(dict(config))
    for dotted in EXECUTION_SETTINGS:
        *parents, leaf = dotted.split(".")
        node = out
        for p in parents:
            node = node.get(p, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict):
            node.pop(leaf, None)
    out.pop("resume", None)  # whether to resume is not part of what is computed
    return out


def files_digest(root: Path, paths: Iterable[Path]) -> str:
    """sha256 over the sorted (path relative to ``root``, content) of ``paths``."""
    h = hashlib.sha256()
    for p in sorted(paths, key=lambda q: q.relative_to(root).as_posix()):
        h.update(p.relative_to(root).as_posix().encode() + b"\0")
        h.update(hashlib.sha256(p.read_bytes()).digest())
    return h.hexdigest()


def code_files(root: Path) -> list[Path]:
    """The package's and the pipeline's Python files and the configs under the repository ``root``."""
    return [p for folder, pattern in CODE_GLOBS for p in (root / folder).rglob(pattern)
            if p.is_file() and "__pycache__" not in p.parts]


def job_key(resolved_config: Mapping, root: Path, benchmark: Optional[Path]) -> str:
    """The sha256 that names what a run computes (module doc); ``benchmark``: the folder of the
    frozen benchmark the run reads (None when it draws its own houses)."""
    cfg = json.dumps(_without_execution_settings(resolved_config), sort_keys=True, default=str)
    parts = [cfg, files_digest(root, code_files(root))]
    if benchmark is not None and benchmark.is_dir():
        parts.append(files_digest(benchmark, [p for p in benchmark.rglob("*") if p.is_file()]))
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def finished_run(run_dir: Path, key: str) -> bool:
    """True when ``run_dir`` holds a finished run with job key ``key`` whose metrics.json is the one
    it wrote."""
    record, metrics = run_dir / FINISHED, run_dir / METRICS
    try:
        d = json.loads(record.read_text())
        return d.get("key") == key and metrics.is_file() and d.get("metrics_sha256") == _sha256(metrics)
    except (OSError, ValueError, AttributeError):
        return False


def mark_finished(run_dir: Path, key: str) -> Path:
    """Write ``run_dir/finished.json`` for the run that just ended (atomically; its last write)."""
    record = run_dir / FINISHED
    atomic_write_text(record, json.dumps({"key": key, "metrics_sha256": _sha256(run_dir / METRICS)},
                                         indent=1, sort_keys=True) + "\n")
    return record


def forget_finished(run_dir: Path) -> None:
    """Remove ``run_dir``'s record before a run starts writing into it: a run that then fails part
    way leaves outputs of two runs, which must not pass for the earlier finished one."""
    (run_dir / FINISHED).unlink(missing_ok=True)


def _committed_layout(copy_dir: Path) -> dict[Path, Path]:
    """{folder of the committed copy: the run-folder path it came from} for the two layouts the
    collectors write: a sweep job's ``data/`` (collect_sweeps), a run's ``metrics/`` and ``report/``
    (collect_runs)."""
    if (copy_dir / METRICS).is_file():
        return {copy_dir / "data": Path("data")}
    return {copy_dir / "metrics": METRICS.parent, copy_dir / "report": Path("data") / "report"}


def committed_copy(key: str, roots: Iterable[Path]) -> Optional[Path]:
    """The committed copy (a folder under one of ``roots``) of a finished job with key ``key`` whose
    metrics.json is the one that job wrote; None when there is none."""
    for root in roots:
        for record in sorted(root.rglob(FINISHED)) if root.is_dir() else ():
            copy_dir = record.parent
            metrics = copy_dir / METRICS if (copy_dir / METRICS).is_file() else copy_dir / "metrics" / METRICS.name
            try:
                d = json.loads(record.read_text())
                if d.get("key") == key and d.get("metrics_sha256") == _sha256(metrics):
                    return copy_dir
            except (OSError, ValueError, AttributeError):
                continue
    return None


def restore_committed(run_dir: Path, key: str, roots: Iterable[Path]) -> Optional[Path]:
    """Copy the committed copy of the finished job ``key`` (``committed_copy``) into ``run_dir`` and
    record it as finished there; the copy restored, or None (nothing written) when there is none."""
    copy_dir = committed_copy(key, roots)
    if copy_dir is None:
        return None
    for src, rel in _committed_layout(copy_dir).items():
        if src.is_dir():
            shutil.copytree(src, run_dir / rel, dirs_exist_ok=True)
    mark_finished(run_dir, key)
    return copy_dir
