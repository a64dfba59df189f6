"""What the planners' manipulation costs can learn from: every executed manipulation with its
measured sr_man, t_man, c_man, cost class (f_en) and the placement attributes of its object.

An executed manipulation is a pickup or place that ran its N_l trials (a precondition failure,
which runs none, is not one). A pickup's attributes are those of its object where the scene put
it (``scene.placement.placement_of``: surface height, depth from the open side, clearance to the
next object, size) plus the generator's label (front / deep / high / clutter); a pickup of an
object the mission already moved has none. A place's attribute is the target surface's height.

``manipulation_rows`` makes the rows (``per_manipulation.csv``); ``manipulation_summary`` the
figures of ``metrics.json["manipulation"]``: the share of graded success rates (0 < sr_man < 1),
the share of each cost class, and per class the distribution of sr_man; ``attribute_table`` the
mean c_man with a bootstrap CI per bin of each attribute.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Optional

from interllm.core.records import MissionRecord
from interllm.core.seeding import bootstrap_seed
from interllm.metrics import stats
from interllm.planning.costs import encode_cost
from interllm.scene.graph import SceneGraph
from interllm.scene.placement import placement_of

CLASSES = ("easy", "medium", "hard")
FIELDS = ("planner", "scene", "mission", "command_index", "kind", "object", "furniture", "sr_man", "t_man",
          "c_man", "cost_class", "label", "height", "depth", "clearance", "size")
# attribute -> [(bin label, lower bound inclusive, upper bound exclusive)] [m]
BINS: dict[str, list[tuple[str, float, float]]] = {
    "height": [("< 0.5 m", 0.0, 0.5), ("0.5-1.0 m", 0.5, 1.0), ("1.0-1.4 m", 1.0, 1.4), (">= 1.4 m", 1.4, 99.0)],
    "depth": [("< 0.15 m", 0.0, 0.15), ("0.15-0.35 m", 0.15, 0.35), (">= 0.35 m", 0.35, 99.0)],
    "clearance": [("< 0.06 m", 0.0, 0.06), (">= 0.06 m", 0.06, 99.0)],
    "size": [("< 0.10 m", 0.0, 0.10), (">= 0.10 m", 0.10, 99.0)],
}


def load_scenes(scenes_dir: str | Path, scene_ids: Iterable[str]) -> dict[str, Optional[SceneGraph]]:
    """{scene id: the scene graph of ``scenes_dir/<id>/scene.json`` as the missions started, or None
    when the file holds only what sr_obj needs (objects and categories, no full graph)}."""
    out: dict[str, Optional[SceneGraph]] = {}
    for sid in sorted(set(scene_ids)):
        try:
            out[sid] = SceneGraph.from_json((Path(scenes_dir) / sid / "scene.json").read_text(encoding="utf-8"))
        except (KeyError, TypeError, ValueError):
            out[sid] = None
    return out


def manipulation_rows(records: Iterable[MissionRecord], scenes: Mapping[str, Optional[SceneGraph]]) -> list[dict]:
    """One row (``FIELDS``) per executed manipulation of every mission record, in mission order."""
    out = []
    for rec in records:
        scene = scenes.get(rec.scene_id)
        moved: set[str] = set()
        for ci, cmd in enumerate(rec.commands):
            for res in cmd.actions:
                a = res.action
                if a.kind not in ("pickup", "place") or not res.trials:
                    continue
                row: dict[str, Any] = {
                    "planner": rec.planner, "scene": rec.scene_id, "mission": rec.mission_id,
                    "command_index": ci + 1, "kind": a.kind, "object": a.obj, "furniture": a.furniture,
                    "sr_man": res.success_rate, "t_man": res.time, "c_man": res.cost,
                    "cost_class": encode_cost(res.cost), "label": "", "height": "", "depth": "",
                    "clearance": "", "size": ""}
                if scene is not None and a.kind == "pickup" and a.obj not in moved and a.obj in scene.objects:
                    p = placement_of(scene, a.obj)
                    row.update(label=scene.objects[a.obj].placement or "front", height=p.height, depth=p.depth,
                               clearance="" if p.clearance is None else p.clearance, size=p.size)
                elif scene is not None and a.kind == "place" and a.furniture in scene.furniture:
                    row["height"] = round(scene.furniture[a.furniture].surface_height, 2)
                if a.kind == "place" and res.success:
                    moved.add(a.obj)
                out.append(row)
    return out


def _share(rows: Sequence[Mapping], pred) -> float:
    return sum(1 for r in rows if pred(r)) / len(rows) if rows else float("nan")


def manipulation_summary(rows: Sequence[Mapping]) -> dict:
    """{"all" and each planner: {n, graded_share, class shares, per class: n, sr_man mean and
    histogram over the N_l-trial success rates}} (shares in [0, 1])."""
    out: dict[str, dict] = {}
    groups = {"all": list(rows)}
    for r in rows:
        groups.setdefault(str(r["planner"]), []).append(r)
    for name, g in sorted(groups.items()):
        d: dict[str, Any] = {"n": len(g), "graded_share": _share(g, lambda r: 0 < float(r["sr_man"]) < 1)}
        for c in CLASSES:
            in_c = [r for r in g if r["cost_class"] == c]
            d[f"{c}_share"] = len(in_c) / len(g) if g else float("nan")
            hist: dict[str, int] = {}
            for r in in_c:
                k = f"{float(r['sr_man']):.2f}"
                hist[k] = hist.get(k, 0) + 1
            d[c] = {"n": len(in_c), "sr_man_mean": (sum(float(r["sr_man"]) for r in in_c) / len(in_c)
                                                    if in_c else float("nan")),
                    "c_man_mean": (sum(float(r["c_man"]) for r in in_c) / len(in_c) if in_c else float("nan")),
                    "sr_man_histogram": dict(sorted(hist.items()))}
        out[name] = d
    return out


def _bin(attr: str, v: Any) -> Optional[str]:
    if v == "" or v is None:
        return None
    for label, lo, hi in BINS[attr]:
        if lo <= float(v) < hi:
            return label
    return None


def attribute_table(rows: Sequence[Mapping], n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
                    method: str = "cluster_bootstrap") -> list[dict]:
    """Mean c_man and sr_man of the pickups per bin of each placement attribute (and per generator
    label): [{attribute, bin, n, c_man, ci_lo, ci_hi, sr_man, hard_share}], CIs by a bootstrap clustered by house."""
    pickups = [r for r in rows if r["kind"] == "pickup" and r["label"] != ""]
    out = []
    keyed: list[tuple[str, str, list[Mapping]]] = []
    for label in sorted({str(r["label"]) for r in pickups}):
        keyed.append(("label", label, [r for r in pickups if r["label"] == label]))
    for attr, bins in BINS.items():
        for b, _, _ in bins:
            keyed.append((attr, b, [r for r in pickups if _bin(attr, r[attr]) == b]))
    for attr, b, g in keyed:
        if not g:
            continue
        m, lo, hi = stats.bootstrap_mean_ci([float(r["c_man"]) for r in g], n_boot, ci,
                                            bootstrap_seed(seed, f"c_man:{attr}:{b}"),
                                            [str(r["scene"]) for r in g], method)
        out.append({"attribute": attr, "bin": b, "n": len(g), "c_man": m, "ci_lo": lo, "ci_hi": hi,
                    "sr_man": sum(float(r["sr_man"]) for r in g) / len(g),
                    "hard_share": _share(g, lambda r: r["cost_class"] == "hard")})
    return out
