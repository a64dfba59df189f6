"""Stage scenes: scene graphs, occupancy grids, MuJoCo worlds, missions, their measured feasibility
(feasibility.json) and pictures."""

from interllm.llm.backend import preflight
from interllm.stages.scenes import run_scenes
from pipeline._common import stage_main


def main(cfg, raw, data) -> None:
    preflight(cfg.llm)  # a server that is down stops the pipeline before any stage writes
    run_scenes(cfg, data / "scenes")


if __name__ == "__main__":
    stage_main("scenes", main)
