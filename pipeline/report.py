"""Stage report: the paper's tables and figures from our runs (Markdown + self-contained HTML)."""

from interllm.stages.report import run_report
from pipeline._common import stage_main

if __name__ == "__main__":
    stage_main("report", lambda cfg, raw, data: run_report(
        cfg, data / "metrics", data / "scenes", data / "runs", data / "report"))
