"""Stage report: the paper's tables and figures from our runs (Markdown + self-contained HTML), with
the ablation results of Hydra multiruns where they exist."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import yaml

from interllm.config import ExperimentConfig
from interllm.config_planners import upgrade_legacy_planner_keys
from interllm.metrics.compare import flatten
from interllm.report.build import build_report
from interllm.report.sweeps import ENCODING_DEFAULTS, ENCODING_KEYS, encoding_label


def run_report(cfg: ExperimentConfig, metrics_dir: Path, scenes_dir: Path, runs_dir: Path,
               out_dir: Path, *, temperature_results: Iterable[tuple[str, Path]] = (),
               m_results: Iterable[tuple[str, Path]] = (),
               estimate_results: Iterable[tuple[str, Path]] = (),
               oracle_results: Iterable[tuple[float, Path]] = (),
               encoding_results: Iterable[tuple[str, str, Path]] = ()) -> None:
    """The report; ablation results are (label, metrics_dir) pairs (``find_sweep_results``,
    ``find_estimate_results``), oracle results (llm.oracle_error, metrics_dir) pairs
    (``find_oracle_results``), encoding results (group, variant, metrics_dir)
    (``find_encoding_results``)."""
    build_report(Path(metrics_dir), Path(scenes_dir), Path(runs_dir), Path(out_dir), cfg,
                 temperature_results=list(temperature_results), m_results=list(m_results),
                 estimate_results=list(estimate_results), oracle_results=list(oracle_results),
                 encoding_results=list(encoding_results))


# the sweep of a job composed before experiments declared theirs (``sweep`` in conf/experiment/)
_SWEEP_OF_EXPERIMENT = {"temperature_ablation": "temperature", "m_ablation": "m",
                        "estimate_comparison": "estimate", "oracle_sweep": "oracle",
                        "encoding_comparison": "encoding"}


def sweep_of(c: dict) -> str:
    """The report section a job's config declares it feeds (``sweep``)."""
    return str(c.get("sweep") or _SWEEP_OF_EXPERIMENT.get(str(c.get("experiment")), ""))


def job_config(cfg_file: Path) -> dict:
    """A job's ``.hydra/config.yaml``, in today's layout: a job composed before each planner had its
    own node keeps its planner settings as flat keys (``planner.nav_estimate``), moved here into
    their nodes (``planner.inter_llm.nav_estimate``)."""
    c = yaml.safe_load(cfg_file.read_text()) or {}
    if isinstance(c.get("planner"), dict):
        c["planner"] = upgrade_legacy_planner_keys(c["planner"])
    return c


def _jobs(roots: Iterable[Path], sweep: str) -> list[tuple[dict, Path]]:
    """(the job's .hydra/config.yaml, its metrics dir) of every job under ``roots`` that declares
    ``sweep`` and produced metrics.json."""
    out = []
    for root in roots:
        for cfg_file in sorted(Path(root).rglob(".hydra/config.yaml")):
            metrics = cfg_file.parent.parent / "data" / "metrics"
            c = job_config(cfg_file)
            if sweep_of(c) == sweep and (metrics / "metrics.json").is_file():
                out.append((c, metrics))
    return out


def _get(c: dict, key: str, default: object = None) -> object:
    """The value of a dotted ``key`` ("llm.oracle_costs") in a job's config, ``default`` if absent."""
    for part in key.split("."):
        if not isinstance(c, dict) or part not in c:
            return default
        c = c[part]
    return c


def _encoding(c: dict) -> tuple[str, str]:
    """(llm.oracle_costs, planner.inter_llm.cost_encoding) of a job's config (the defaults where the config has none)."""
    (oc_key, ce_key), (oc_default, ce_default) = ENCODING_KEYS, ENCODING_DEFAULTS
    return str(_get(c, oc_key, oc_default)), str(_get(c, ce_key, ce_default))


def find_oracle_results(*roots: Path) -> list[tuple[float, Path]]:
    """Jobs declaring ``sweep: oracle`` (and ``sweep: encoding``, whose jobs are oracle runs too)
    under ``roots`` with metrics: [(llm.oracle_error, metrics_dir)], sorted by the
    error, one job per error (an oracle_sweep one first). When the jobs also sweep the cost
    encoding (``find_encoding_results``), only those with the paper's encoding (or, without any,
    the first encoding by name) form the oracle axis, one job per error."""
    jobs = _jobs(roots, "oracle") + _jobs(roots, "encoding")
    encs = {_encoding(c) for c, _ in jobs}
    keep = ENCODING_DEFAULTS if ENCODING_DEFAULTS in encs or not encs else min(encs)
    by_error: dict[float, Path] = {}
    for c, m in jobs:  # an oracle_sweep job first, then an encoding_comparison one at the same error
        if _encoding(c) == keep:
            by_error.setdefault(float(c["llm"]["oracle_error"]), m)
    return sorted(by_error.items())


# keys that do not change what a run measures (where it writes, how many threads / workers)
_IRRELEVANT = ("data_dir", "jobs", "verbose", "llm.cache_dir", "llm.cache_mode", "llm.n_threads")


def find_encoding_results(*roots: Path) -> list[tuple[str, str, Path]]:
    """Jobs under ``roots`` (any experiment) with metrics that differ only in ``llm.oracle_costs``
    and/or ``planner.inter_llm.cost_encoding`` (read from each job's ``.hydra/config.yaml``, as the other
    sweeps are; keys in ``_IRRELEVANT`` are ignored): [(group, variant, metrics_dir)] where variant
    is ``encoding_label(oracle_costs, cost_encoding)`` and group names the settings the jobs of a group
    share and other groups do not ("" for a single group); only groups with at least two variants,
    sorted."""
    jobs = []
    for root in roots:
        for cfg_file in sorted(Path(root).rglob(".hydra/config.yaml")):
            metrics = cfg_file.parent.parent / "data" / "metrics"
            if (metrics / "metrics.json").is_file():
                jobs.append((job_config(cfg_file), metrics))
    groups: dict[tuple, dict[str, Path]] = {}
    for c, m in jobs:
        rest = {k: v if isinstance(v, str) else repr(v) for k, v in flatten(c).items()  # lists: hashable
                if k not in ENCODING_KEYS and k not in _IRRELEVANT}
        groups.setdefault(tuple(sorted(rest.items())), {}).setdefault(encoding_label(*_encoding(c)), m)
    groups = {k: v for k, v in groups.items() if len(v) >= 2}
    varying = sorted({k for g in groups for k, v in g if any(dict(h).get(k) != v for h in groups)})
    out = []
    for g, variants in groups.items():
        d = dict(g)
        label = ", ".join(f"{k}={d[k] if k in d else '(absent)'}" for k in varying)
        out += [(label, v, m) for v, m in variants.items()]
    return sorted(out)


def find_estimate_results(*roots: Path) -> list[tuple[str, Path]]:
    """Jobs declaring ``sweep: estimate`` under ``roots`` with metrics: [(planner.inter_llm.nav_estimate,
    metrics_dir)], sorted by the variant's name."""
    return sorted((str(c["planner"]["inter_llm"]["nav_estimate"]), m) for c, m in _jobs(roots, "estimate"))


def find_sweep_results(*roots: Path) -> tuple[list[tuple[str, Path]], list[tuple[str, Path]]]:
    """Ablation results of Hydra multiruns under ``roots``: jobs whose ``.hydra/config.yaml``
    declares ``sweep: temperature`` or ``sweep: m`` and that produced ``data/metrics/metrics.json``.

    Returns (temperature_results, m_results) as (label, metrics_dir) pairs, sorted by value.
    """
    temps = sorted((float(c["llm"]["temperature"]), m) for c, m in _jobs(roots, "temperature"))
    ms = sorted((int(c["planner"]["M"]), m) for c, m in _jobs(roots, "m"))
    return ([(f"{t:.1f}", p) for t, p in temps], [(f"M={m}", p) for m, p in ms])
