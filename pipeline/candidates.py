"""Stage candidates: the M initial plan candidates per command from the cached local LLM."""

from interllm.stages.candidates import run_candidates
from pipeline._common import stage_main

if __name__ == "__main__":
    stage_main("candidates", lambda cfg, raw, data: run_candidates(cfg, data / "scenes", data / "candidates"), llm=True)
