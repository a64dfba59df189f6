"""Wall time of an experiment cold (empty LLM cache) and warm (full cache), same config.

    .venv/bin/python benchmarks/bench_pipeline.py                    # the default experiment (paper)
    .venv/bin/python benchmarks/bench_pipeline.py experiment=quick   # any Hydra overrides
    .venv/bin/python benchmarks/bench_pipeline.py --warm             # committed cache only

--warm skips the cold run: it replays the committed LLM cache (data/llm_cache, read-only) and
compares the missions stage in one process (jobs=1) with worker processes (jobs=0: one per
core), printing per-stage times, their ratio and whether metrics.json is byte-identical.

Runs every stage (scenes, candidates, missions, aggregate, report) in a temporary folder twice:
first with an empty LLM cache (every answer comes from the model), then again from the cache the
first run filled. Prints per-stage wall times, the warm/cold ratio, and whether metrics.json is
byte-identical across the two runs (it must be).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from _usage import overrides  # noqa: E402  (benchmarks/_usage.py, beside this script)
from omegaconf import OmegaConf  # noqa: E402

from interllm.stages.aggregate import run_aggregate  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.missions import run_missions  # noqa: E402
from interllm.stages.report import run_report  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402
from pipeline._hydra import compose  # noqa: E402


def run_once(cfg, data: Path) -> dict[str, float]:
    t = {}
    s = time.perf_counter()
    run_scenes(cfg, data / "scenes")
    t["scenes"] = time.perf_counter() - s
    s = time.perf_counter()
    run_candidates(cfg, data / "scenes", data / "candidates")
    t["candidates"] = time.perf_counter() - s
    s = time.perf_counter()
    run_missions(cfg, data / "scenes", data / "candidates", data / "runs")
    t["missions"] = time.perf_counter() - s
    s = time.perf_counter()
    run_aggregate(cfg, data / "runs", data / "scenes", data / "metrics")
    t["aggregate"] = time.perf_counter() - s
    s = time.perf_counter()
    run_report(cfg, data / "metrics", data / "scenes", data / "runs", data / "report")
    t["report"] = time.perf_counter() - s
    t["total"] = sum(t.values())
    return t


def warm_only(argv: list[str]) -> None:
    import os

    cfg = OmegaConf.to_object(compose(["llm.cache_mode=replay", *argv]))
    cfg.llm.cache_dir = str(Path(__file__).resolve().parent.parent / "data" / "llm_cache")
    times, metrics = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for jobs in (1, 0):
            cfg.jobs = jobs
            times[jobs] = run_once(cfg, Path(tmp) / f"jobs{jobs}")
            metrics[jobs] = (Path(tmp) / f"jobs{jobs}" / "metrics" / "metrics.json").read_bytes()
    print(f"experiment={cfg.experiment}  warm (committed cache, replay)  cores={os.cpu_count()}")
    print(f"{'stage':<12}{'jobs=1 [s]':>12}{'jobs=0 [s]':>12}{'speed-up':>10}")
    for k in times[1]:
        print(f"{k:<12}{times[1][k]:>12.1f}{times[0][k]:>12.1f}{times[1][k] / max(times[0][k], 1e-9):>10.2f}")
    print(f"metrics.json byte-identical jobs=1 vs jobs=0: {metrics[1] == metrics[0]}")


def main(argv: list[str]) -> None:
    argv = overrides(argv, __doc__)
    if "--warm" in argv:
        return warm_only([a for a in argv if a != "--warm"])
    cfg = OmegaConf.to_object(compose(argv))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cfg.llm.cache_dir = str(tmp / "llm_cache")
        cold = run_once(cfg, tmp / "cold")
        warm = run_once(cfg, tmp / "warm")
        same = (tmp / "cold/metrics/metrics.json").read_bytes() == (tmp / "warm/metrics/metrics.json").read_bytes()
        n_cache = sum(1 for _ in (tmp / "llm_cache").rglob("*.json"))
    print(f"experiment={cfg.experiment}  scenes={cfg.scene.n_scenes}  missions/scene={cfg.mission.n_missions}"
          f"  planners={cfg.planner.names}  LLM cache entries={n_cache}")
    print(f"{'stage':<12}{'cold [s]':>12}{'warm [s]':>12}{'warm/cold':>12}")
    for k in cold:
        print(f"{k:<12}{cold[k]:>12.1f}{warm[k]:>12.1f}{warm[k] / max(cold[k], 1e-9):>12.2f}")
    print(f"metrics.json byte-identical cold vs warm: {same}")


if __name__ == "__main__":
    main(sys.argv[1:])
