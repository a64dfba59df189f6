"""Stage scenes: scene graphs, occupancy grids, MuJoCo worlds, missions and pictures."""

from interllm.experiment import run_scenes
from pipeline._common import stage_main

if __name__ == "__main__":
    stage_main("scenes", lambda cfg, raw, data: run_scenes(cfg, data / "scenes"))
