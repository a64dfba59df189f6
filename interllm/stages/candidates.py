"""Stage candidates: the M initial plan candidates of every command, shared by every planner."""

from __future__ import annotations

from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.io import child_path, ensure_dir, write_json
from interllm.llm.backend import preflight
from interllm.llm.health import check_failure_share
from interllm.planners.candidates import generate_initial_candidates
from interllm.progress import progress
from interllm.stages.inputs import PROBE_FILE, load_scene_and_missions, scene_ids, stage_client
from interllm.stages.validate import check_registered


def run_candidates(cfg: ExperimentConfig, scenes_dir: Path, out_dir: Path) -> None:
    """``out_dir/<scene_id>.json``: {mission id: {command id: [plan, ...]}}; the call log beside them.
    Nothing is written when too many LLM calls failed (``llm.max_failure_share``)."""
    check_registered(cfg, planners=False)  # an unknown backend or mode fails before any output
    probe = preflight(cfg.llm)  # server up, model served, modes supported (the conformance probe)
    out_dir = ensure_dir(out_dir)
    if probe is not None:
        write_json(out_dir / PROBE_FILE, probe)
    else:
        (out_dir / PROBE_FILE).unlink(missing_ok=True)  # an earlier run's server is not this run's
    call_log = out_dir / "llm_calls.jsonl"
    call_log.unlink(missing_ok=True)  # what an earlier (killed) run left here
    client = stage_client(cfg, call_log, "candidates", probe=probe)
    try:
        loaded = {sid: load_scene_and_missions(scenes_dir, sid, cfg) for sid in scene_ids(scenes_dir)}
        jobs = [(sid, m) for sid, (_, missions) in loaded.items() for m in missions]
        by_scene: dict[str, dict] = {}
        for sid, mission in progress(jobs, "candidates", total=len(jobs)):
            by_scene.setdefault(sid, {})[mission.id] = generate_initial_candidates(
                loaded[sid][0], mission, client.with_context(scene=sid, mission=mission.id), cfg)
        check_failure_share(call_log, cfg.llm, "candidates stage")  # before any candidates are written
        for sid, cands in by_scene.items():
            write_json(child_path(out_dir, f"{sid}.json", what="the scene id's file name"), cands)
    finally:
        client.close()
