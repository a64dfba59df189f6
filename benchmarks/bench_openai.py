"""The missions stage against a local OpenAI-compatible server, with 1 and 2 worker processes, beside
the embedded backend in the same run.

    .venv/bin/python benchmarks/bench_openai.py            # about 15 minutes on 2 cores

Every setting starts from an empty LLM cache, so every request reaches the model: the quick
experiment's scene and mission in generate mode (the paper's loop), MoMa-LLM and SayPlan with one
candidate. The server is llama-cpp-python's own (``python -m llama_cpp.server``) on the embedded
GGUF, so both backends run the same model on the same cores. Printed per setting: requests sent,
the missions stage's wall time, and requests per second.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from _usage import no_arguments  # noqa: E402  (benchmarks/_usage.py, beside this script)
from helpers.openai_server import llama_server  # noqa: E402

from interllm.config import from_dict  # noqa: E402
from interllm.llm.model_files import resolve_model_path  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.missions import run_missions  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402


def config(tmp: Path, llm: dict, jobs: int):
    return from_dict({"jobs": jobs, "scene": {"n_scenes": 1}, "mission": {"n_missions": 1},
                      "planner": {"names": ["moma_llm", "sayplan"], "M": 1},
                      "llm": {"proposal_mode": "generate", "cost_inference_mode": "generate", "max_tokens": 256,
                              "cache_dir": str(tmp / "cache"), "max_failure_share": 1.0, **llm}})


def run(name: str, llm: dict, jobs: int) -> None:
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        cfg = config(tmp, llm, jobs)
        run_scenes(cfg, tmp / "scenes")
        run_candidates(cfg, tmp / "scenes", tmp / "candidates")
        t0 = time.perf_counter()
        run_missions(cfg, tmp / "scenes", tmp / "candidates", tmp / "runs")
        wall = time.perf_counter() - t0
        calls = [json.loads(x) for x in (tmp / "runs" / "llm_calls.jsonl").read_text().splitlines()]
        asked = sum(1 for c in calls if not c["cache_hit"])
        print(f"{name:32s} jobs={jobs}  {asked:4d} requests  missions stage {wall:7.1f} s  "
              f"{asked / wall:5.2f} requests/s", flush=True)


def main() -> int:
    os.environ["INTERLLM_PROGRESS"] = "0"
    model = str(resolve_model_path(""))
    print(f"model {model}; {os.cpu_count()} cores")
    for jobs in (1, 2):
        run("embedded (in process)", {}, jobs)
    with llama_server(model) as base:
        server = {"backend": "openai", "model": "gemma3-270m", "base_url": base}
        for jobs in (1, 2):
            run("openai -> llama_cpp.server", server, jobs)
    return 0


if __name__ == "__main__":
    no_arguments(sys.argv[1:], __doc__)
    raise SystemExit(main())
