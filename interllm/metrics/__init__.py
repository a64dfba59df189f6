"""Metrics of executed missions (paper §V): per-object/command/mission tables, m_overall,
bootstrap CIs, paired planner comparison, semantic-similarity accuracy, the report. Objects
delivered, the position between the nothing and optimal references, the γ_obj sensitivity and
candidate diversity are in ``interllm.metrics.deliveries`` (it loads the planner registry).

``aggregate(runs_dir, scenes_dir, cfg, out_dir)`` is the aggregate stage;
``build_report(metrics_dir, scenes_dir, runs_dir, out_dir, cfg)`` the report stage (import it from
``interllm.metrics.report``; it pulls in matplotlib).
"""

from interllm.metrics.compute import (
    Gammas,
    MetricsInputError,
    aggregate,
    compute_tables,
    load_runs,
    load_scene_categories,
    m_overall,
    mission_rows,
    read_csv,
    write_csv,
)
from interllm.metrics.stats import (
    bootstrap_mean_ci,
    compare_planners,
    paired_improvement,
    semantic_accuracy,
)

__all__ = ["Gammas", "MetricsInputError", "aggregate", "bootstrap_mean_ci", "compare_planners",
           "compute_tables", "load_runs", "load_scene_categories", "m_overall", "mission_rows",
           "paired_improvement", "read_csv", "semantic_accuracy", "write_csv"]
