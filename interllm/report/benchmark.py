"""The report header's line about the benchmark the runs' houses and missions come from
(metrics.json's ``benchmark``, ``interllm.metrics.benchmark_check``)."""

from __future__ import annotations


def benchmark_sentence(b: dict) -> str:
    """The report header's line about the benchmark (metrics.json's ``benchmark``)."""
    unknown = (f" Unknown for scene(s) {', '.join(b['unknown'])}: their feasibility.json is missing or unreadable."
               if b and b.get("unknown") else "")
    if b and not b.get("name") and b.get("unknown") and not b.get("slots"):
        return f"Houses and missions: where they come from (a benchmark or a draw) is not known.{unknown}"
    if not b or not b.get("name"):
        return ("Houses and missions: drawn from this run's own simulator measurement (no versioned benchmark, "
                "`benchmark: ''`): a run with another simulator or robot may ask other commands." + unknown)
    changed = (f"**{b['slots_changed']} of {b['slots']} slots** measure differently now "
               f"({b['commands_changed']} command(s) changed, {b['pickups_changed']} object(s) whose pickup "
               f"changed, {b['starts_moved']} start(s) moved; each listed in the scenes' feasibility.json)"
               if b["commands_changed"] or b["pickups_changed"] or b["starts_moved"]
               else f"all {b['slots']} slots measure as when frozen")
    return (f"Benchmark: **{b['name']}** (houses and missions frozen at commit {str(b['frozen_commit'])[:12]} with "
            f"robot {b['frozen_robot']}, re-measured by this run's simulator): {changed}.{unknown}")
