"""Metrics of executed missions (paper §V): the numbers, never their prose or pictures.

- ``compute``: per-object/command/mission tables and m_overall; ``summary``: per planner means
  with bootstrap CIs; ``stats``: bootstrap CIs, paired planner comparison, semantic-similarity
  accuracy; ``deliveries``: objects delivered, the position between the two anchors (doing
  nothing, the optimal reference), the γ_obj sensitivity and candidate diversity; ``planner_info``:
  how the runs show each planner and which are anchors (no planner code is loaded);
  ``manipulation``, ``capability``, ``claims``, ``llm_usage``, ``compare``.
- ``cluster_t``: CR2 t intervals clustered by house; ``benchmark_check``: what the simulator
  measures differently from the frozen benchmark; ``mechanism``: the ablation variants' paired
  differences.
- The report built from these numbers is the package ``interllm.report``.

The aggregate and report stages that call them are ``interllm.stages.aggregate`` and
``interllm.stages.report``.
"""

from interllm.metrics.compute import (
    Gammas,
    MetricsInputError,
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

__all__ = ["Gammas", "MetricsInputError", "bootstrap_mean_ci", "compare_planners",
           "compute_tables", "load_runs", "load_scene_categories", "m_overall", "mission_rows",
           "paired_improvement", "read_csv", "semantic_accuracy", "write_csv"]
