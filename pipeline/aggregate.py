"""Stage aggregate: per-object/command/mission metrics, CIs, paired comparisons (DVC metrics+plots)."""

from interllm.stages.aggregate import run_aggregate
from pipeline._common import stage_main

if __name__ == "__main__":
    stage_main("aggregate", lambda cfg, raw, data: run_aggregate(
        cfg, data / "runs", data / "scenes", data / "metrics", data / "candidates"))
