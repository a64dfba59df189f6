"""A tiny synthetic experiment: aggregate twice (byte-identical metrics.json) and build the report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from interllm.config import ExperimentConfig, from_dict
from interllm.core.actions import Action
from interllm.core.records import CommandRecord, CommandSummary, CostInference, GoalRecord, MissionRecord
from interllm.core.results import ActionResult, man_cost, nav_cost
from interllm.io import write_json
from interllm.metrics.compute import read_csv
from interllm.planners.base import shown_planners
from interllm.stages.aggregate import write_metrics

PLANNERS = {"inter_llm": 0.6, "sayplan": 1.4, "moma_llm": 1.0}  # cost scale: inter_llm cheapest
CATS = ["apple", "bread", "milk", "laptop", "notebook", "cellphone", "book", "newspaper", "mug"]


def _scene(sid):
    objs = [{"id": f"{c}_{k}", "category": c, "furniture": f"shelf_{k}"} for c in CATS for k in (1, 2)]
    return {"id": sid, "objects": objs}


def _record(planner, sid, mid, scale, rng):
    cmds = []
    for ci in range(3):
        cats = CATS[3 * ci:3 * ci + 3]
        target = f"target_{ci}"
        actions, final = [], {}
        for k, cat in enumerate(cats):
            obj = f"{cat}_{1 + int(rng.integers(0, 2))}"
            cc, d, t = int(rng.integers(0, 3) * scale), float(rng.uniform(2, 20) * scale), float(rng.uniform(5, 40))
            actions.append({"action": {"action": "navigate", "furniture": f"shelf_{k}", "room": "r"},
                            "kind": "navigate", "success": True, "cost": nav_cost(cc, t, d, 10), "time": t,
                            "collisions": cc, "distance": d, "success_rate": 1.0})
            sr = float(np.clip(rng.uniform(0.3, 1.0) / scale, 0, 1))
            tm = float(rng.uniform(2, 10))
            actions.append({"action": {"action": "pickup", "object": obj, "furniture": "shelf_1"},
                            "kind": "pickup", "success": sr > 0.5, "cost": man_cost(sr, tm, 100), "time": tm,
                            "collisions": 0, "distance": 0.0, "success_rate": sr})
            if sr > 0.5:
                actions.append({"action": {"action": "place", "object": obj, "furniture": target},
                                "kind": "place", "success": True, "cost": man_cost(1.0, 2.0, 100), "time": 2.0,
                                "collisions": 0, "distance": 0.0, "success_rate": 1.0})
                final[obj] = target
        infs = [{"action": str_a(a), "predicted": ["easy", "medium", "hard", "unknown"][int(rng.integers(0, 4))],
                 "estimate": 5.0} for a in actions if a["kind"] == "pickup"] if planner == "inter_llm" else []
        cmds.append({"command_id": f"c{ci}", "text": "t",
                     "goal": {"categories": cats, "target_furniture": [target], "n_objects": 3},
                     "summary": {"llm_calls": 3, "llm_tokens_in": 900, "llm_tokens_out": 120,
                                 "cost_inferences": infs},
                     "actions": actions, "final_locations": final})
    return _typed({"planner": planner, "scene_id": sid, "mission_id": mid, "commands": cmds, "sim_time": 0.0})


def _typed(d: dict) -> dict:
    """The compact record above as the missions stage writes it (interllm.core.records)."""
    cmds = []
    for c in d["commands"]:
        acts = [ActionResult(Action.from_dict(a["action"]), a["success"], a["cost"], a["time"],
                             collisions=a["collisions"], distance=a["distance"], success_rate=a["success_rate"])
                for a in c["actions"]]
        s = c["summary"]
        summary = CommandSummary(c["command_id"], llm_calls=s["llm_calls"], llm_tokens_in=s["llm_tokens_in"],
                                 llm_tokens_out=s["llm_tokens_out"],
                                 cost_inferences=[CostInference(i["action"], i["predicted"], i["estimate"])
                                                  for i in s["cost_inferences"]])
        g = c["goal"]
        cmds.append(CommandRecord(c["command_id"], c["text"], GoalRecord(tuple(g["categories"]),
                                                                         tuple(g["target_furniture"]), g["n_objects"]),
                                  summary, acts, c["final_locations"]))
    return MissionRecord(d["planner"], d["scene_id"], d["mission_id"], cmds, d["sim_time"]).to_dict()


def str_a(a):
    return f"{a['action']['action']}({a['action']['object']}, {a['action']['furniture']})"


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    root = tmp_path_factory.mktemp("exp")
    import matplotlib
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    for sid in ("s0", "s1"):
        write_json(root / "scenes" / sid / "scene.json", _scene(sid))
    plt.imsave(root / "scenes" / "s0" / "topdown.png", np.arange(64.0).reshape(8, 8))
    for planner, scale in PLANNERS.items():
        for sid in ("s0", "s1"):
            for m in range(3):
                rng = np.random.default_rng([sorted(PLANNERS).index(planner), int(sid[1]), m])
                write_json(root / "runs" / planner / sid / f"m{m:03d}.json",
                           _record(planner, sid, f"m{m:03d}", scale, rng))
    (root / "runs" / "inter_llm" / "s0" / "m000.mcap").write_bytes(b"\x89MCAP0\r\n")
    write_json(root / "runs" / "planners.json", shown_planners(PLANNERS))  # as the missions stage does
    cfg = from_dict({"metrics": {"bootstrap_samples": 300}})
    return root, cfg


def test_metrics_json_byte_identical(experiment):
    root, cfg = experiment
    write_metrics(root / "runs", root / "scenes", cfg, root / "m1")
    write_metrics(root / "runs", root / "scenes", cfg, root / "m2")
    for name in ("metrics.json", "per_object.csv", "cumulative.csv", "per_object_summary.csv",
                 "semantic_accuracy.csv"):
        assert (root / "m1" / name).read_bytes() == (root / "m2" / name).read_bytes(), name
    # a different bootstrap seed changes the CIs but not the means
    cfg2 = from_dict({"metrics": {"bootstrap_samples": 300, "seed": 5}})
    b = write_metrics(root / "runs", root / "scenes", cfg2, root / "m3")
    a = write_metrics(root / "runs", root / "scenes", cfg, root / "m1")
    assert a["planners"]["sayplan"]["m_overall"] == b["planners"]["sayplan"]["m_overall"]
    assert a["planners"]["sayplan"]["m_overall_ci_lo"] != b["planners"]["sayplan"]["m_overall_ci_lo"]
    assert len(read_csv(root / "m1" / "per_object.csv")) == 3 * 2 * 3 * 9


def test_report_builds(experiment, monkeypatch):
    from interllm.report.build import build_report

    root, cfg = experiment
    monkeypatch.chdir(root)  # as a DVC stage runs at the project root
    mdir = root / "m1"
    write_metrics(root / "runs", root / "scenes", cfg, mdir)
    write_metrics(root / "runs", root / "scenes", cfg, root / "t02", temperature=0.2)
    out = build_report(mdir, root / "scenes", root / "runs", root / "report", cfg,
                       temperature_results=[("σ=0.2", root / "t02"), ("σ=1.0", root / "missing")],
                       m_results=[("M=3", mdir), ("M=5", root / "missing")])
    md = out["markdown"].read_text(encoding="utf-8")
    ht = out["html"].read_text(encoding="utf-8")
    for text in ("Table III", "command_1", "obj_9", "Navigation Collision Counts", "Object Fulfillment Rate",
                 "183.0", "interllm replay", "m000.mcap", "Table II", "73%", "M=3"):
        assert text in md, text
    assert "The paper's ordering" in md and " holds on our runs" in md  # inter_llm is built cheapest
    # the replay command names the log relative to where the report was made: every checkout
    # writes the same report (its hash is in dvc.lock)
    replay = [line for line in md.splitlines() if line.startswith("interllm replay ")]
    assert replay and replay[0].startswith("interllm replay runs/"), replay
    assert "<th colspan='3'>command_1</th>" in ht
    n_img = ht.count("src='data:image/png;base64,")
    assert n_img >= 6 and n_img == md.count("![")
    assert "<img src='figures" not in ht and "src='figures" not in ht
    assert (root / "report" / "figures" / "cumulative_m_overall.png").read_bytes()[:4] == b"\x89PNG"
    # σ=0.2 and this run (0.8) both appear in Table II
    assert "| 0.2 |" in md and "| 0.8 |" in md
    # rebuilding gives identical markdown and figures
    first = {p.name: p.read_bytes() for p in (root / "report" / "figures").glob("*.png")}
    build_report(mdir, root / "scenes", root / "runs", root / "report2", cfg,
                 temperature_results=[("σ=0.2", root / "t02")], m_results=[("M=3", mdir)])
    second = {p.name: p.read_bytes() for p in (root / "report2" / "figures").glob("*.png")}
    assert first == second
    assert (root / "report2" / "report.md").read_text(encoding="utf-8").replace("report2", "report") == md


def test_report_missing_metrics_names_stage(tmp_path):
    from interllm.report.build import build_report

    with pytest.raises(FileNotFoundError, match="aggregate"):
        build_report(tmp_path, tmp_path, tmp_path, tmp_path / "out", ExperimentConfig())


@pytest.mark.parametrize("lo, hi, verdict", [(2.0, 9.0, " holds on our runs"), (-4.6, 5.7, "cannot be told"),
                                             (-9.0, -2.0, "does not hold")])
def test_the_ordering_is_judged_by_the_paired_intervals_not_the_mean_rank(lo, hi, verdict):
    from interllm.report.headline import ordering_sentence

    metrics = {"planners": {"inter_llm": {"m_overall": 100.0}, "sayplan": {"m_overall": 101.0}},
               "improvement": {"inter_llm_vs_sayplan": {"pct": 1.0, "ci_lo": lo, "ci_hi": hi}}}
    assert verdict in ordering_sentence(metrics, "inter_llm")  # Inter-LLM has the lowest mean in every case


def test_estimate_variants_are_paired_against_this_run(experiment):
    from interllm.report.build import build_report

    root, cfg = experiment
    mdir = root / "m1"
    write_metrics(root / "runs", root / "scenes", cfg, mdir)
    assert cfg.planner.inter_llm.nav_estimate == "prior"  # this run's estimate: its own row, never a variant of itself
    out = build_report(mdir, root / "scenes", root / "runs", root / "rep_est", cfg,
                       estimate_results=[("paper_sum", mdir), ("prior", mdir), ("weighted_mean", root / "missing")])
    md = out["markdown"].read_text(encoding="utf-8")
    assert "## Cost-estimate variants (planner.inter_llm.nav_estimate)" in md
    section = md.split("## Cost-estimate variants")[1].split("##")[0]
    row = next(line for line in section.splitlines() if line.startswith("| paper_sum |"))
    assert "0.0% [0.0, 0.0]" in row  # the same runs: no difference, and an interval of width 0
    assert "| prior (this run) |" in section and "| prior |" not in section
    assert "weighted_mean" not in section
    assert "none can be told better than prior: it stays the default" in section


def test_the_report_refuses_to_pair_a_sweep_job_of_another_benchmark(experiment):
    """Sweep sections pair runs by scene and mission id, which benchmark versions share: a job of
    another benchmark is named with its benchmark and the fix, before anything is written."""
    from interllm.errors import UserError
    from interllm.report.build import build_report

    root, cfg = experiment
    mdir, odd = root / "m_bench", root / "m_bench_odd"
    for d, name in ((mdir, "paper-v3"), (odd, "paper-v2")):
        write_metrics(root / "runs", root / "scenes", cfg, d)
        metrics = json.loads((d / "metrics.json").read_text(encoding="utf-8"))
        metrics["benchmark"] = {"name": name, "frozen_commit": "0" * 40, "frozen_robot": "manipulathor", "slots": 18,
                                "commands_changed": 0, "slots_changed": 0, "pickups_changed": 0, "starts_moved": 0}
        (d / "metrics.json").write_text(json.dumps(metrics), encoding="utf-8")
    with pytest.raises(UserError, match=r"m_bench_odd \(paper-v2\).*make sweeps"):
        build_report(mdir, root / "scenes", root / "runs", root / "rep_odd", cfg, m_results=[("M=3", odd)])
    assert not (root / "rep_odd").exists()
    build_report(mdir, root / "scenes", root / "runs", root / "rep_same", cfg, m_results=[("M=3", mdir)])
