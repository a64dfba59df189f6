"""Stage scenes: scene graphs, occupancy grids, MuJoCo worlds, missions, their measured feasibility
(feasibility.json) and pictures."""

from interllm.stages.scenes import run_scenes
from pipeline._common import stage_main


def main(cfg, raw, data) -> None:
    run_scenes(cfg, data / "scenes")


if __name__ == "__main__":
    stage_main("scenes", main)
