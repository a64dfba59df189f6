"""Stage missions: every planner on every mission in MuJoCo, logged to MCAP. Its outputs are hashed
into dvc.lock, so they do not record the git commit (the commit holding dvc.lock says it)."""

from interllm.stages.missions import run_missions
from pipeline._common import stage_main

if __name__ == "__main__":
    stage_main("missions", lambda cfg, raw, data: run_missions(
        cfg, data / "scenes", data / "candidates", data / "runs", resolved_config=raw,
        record_commit=False), llm=True)
