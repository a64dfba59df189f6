"""The missions stage with the scenes stage's manipulation measurements reused, against measuring
again in every mission (issue #39, item 2).

    .venv/bin/python benchmarks/bench_measurements.py                   # the default experiment
    .venv/bin/python benchmarks/bench_measurements.py experiment=quick  # any Hydra overrides

Runs the scenes stage once into a temporary folder, then the missions stage twice in this process
(``jobs=1``, answers replayed from the committed ``data/llm_cache``):

- **reused**: as the pipeline runs it, the world starts from the scenes stage's
  ``measurements.json`` and keeps its initial-map measurements across missions
  (``interllm.sim.measurements``);
- **again**: the alternative, every mission measures what it needs itself (the store never
  answers; the behaviour before the store).

Prints, per run, the missions stage's wall time, the measurements made and those the store served
with the seconds they took, and whether every mission record of the two runs is byte-identical
(it must be: a measurement on the initial map depends on its key alone). The floor of the reused
run is measuring each distinct (action, layout) once: ``made`` in the reused run, of which the
scenes stage's share is already paid for.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import collections
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from _usage import overrides  # noqa: E402  (benchmarks/_usage.py, beside this script)
from omegaconf import OmegaConf  # noqa: E402

from interllm.sim import measurements  # noqa: E402
from interllm.sim.manipulator import Manipulator  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.missions import run_missions  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402
from pipeline._hydra import compose  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def counting(counts: collections.Counter, from_file: set):
    """Wrap ``Manipulator.measure`` and ``MeasurementStore.get`` to count measurements made, their
    seconds, and the store's answers (``from_file``: the keys the scenes stage wrote)."""
    measure, get = Manipulator.measure, measurements.MeasurementStore.get

    def timed_measure(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return measure(self, *args, **kwargs)
        finally:
            counts["made"] += 1
            counts["seconds"] += time.perf_counter() - t0

    def counted_get(self, key):
        got = get(self, key)
        if got is not measurements.MISSING:
            counts["served"] += 1
            counts["served from the scenes stage" if key in from_file else "served from earlier missions"] += 1
        return got

    Manipulator.measure, measurements.MeasurementStore.get = timed_measure, counted_get
    return measure, get


def run(cfg, out: Path, reuse: bool, from_file: set) -> tuple[float, collections.Counter]:
    counts: collections.Counter = collections.Counter()
    measure, get = counting(counts, from_file)
    if not reuse:  # the alternative: the store never answers, so every mission measures again
        measurements.MeasurementStore.get = lambda self, key: measurements.MISSING
    try:
        t0 = time.perf_counter()
        run_missions(cfg, out / "scenes", out / "candidates", out / ("runs_reused" if reuse else "runs_again"))
        return time.perf_counter() - t0, counts
    finally:
        Manipulator.measure, measurements.MeasurementStore.get = measure, get


def main(argv: list[str]) -> None:
    cfg = OmegaConf.to_object(compose(overrides(argv, __doc__)))
    cfg.jobs = 1
    cfg.llm.cache_mode = "replay"  # the committed answers: this measures the simulator, not the model
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        t0 = time.perf_counter()
        run_scenes(cfg, out / "scenes")
        scenes_s = time.perf_counter() - t0
        files = sorted((out / "scenes").glob(f"*/{measurements.MEASUREMENTS_FILE}"))
        from_file = {(e["action"], measurements._tuples(e["layout"]))
                     for p in files for e in json.loads(p.read_text())["entries"]}
        n_file = len(from_file)
        run_candidates(cfg, out / "scenes", out / "candidates")
        results = {name: run(cfg, out, reuse, from_file) for name, reuse in (("reused", True), ("again", False))}
        same = all((out / "runs_reused" / p.relative_to(out / "runs_again")).read_bytes() == p.read_bytes()
                   for p in sorted((out / "runs_again").rglob("m*.json")))
        n_records = len(list((out / "runs_again").rglob("m*.json")))
    print(f"experiment={cfg.experiment}: scenes stage {scenes_s:.1f} s, {n_file} measurements in "
          f"{len(files)} {measurements.MEASUREMENTS_FILE} files")
    print(f"{'missions stage':<16}{'wall [s]':>10}{'made':>8}{'their s':>10}{'served':>8}")
    for name, (wall, c) in results.items():
        print(f"{name:<16}{wall:>10.1f}{c['made']:>8}{c['seconds']:>10.1f}{c['served']:>8}")
    served = results["reused"][1]
    print(f"served by the reused run's store: {served['served from the scenes stage']} from the scenes stage, "
          f"{served['served from earlier missions']} from earlier missions")
    ratio = results["reused"][0] / max(results["again"][0], 1e-9)
    print(f"reused / again: {ratio:.2f} of the wall time; "
          f"{results['reused'][1]['made'] / max(results['again'][1]['made'], 1):.2f} of the measurements")
    print(f"mission records byte-identical ({n_records}): {same}")


if __name__ == "__main__":
    main(sys.argv[1:])
