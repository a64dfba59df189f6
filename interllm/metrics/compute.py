"""Per-object, per-command and per-mission metrics of executed missions (paper §V).

Input: one typed MissionRecord per run (``interllm.core.records``), read from
``data/runs/<planner>/<scene>/<mission>.json``.

The paper's unit is the *object*. How executed actions become per-object metrics:

* **Slots.** Command c asking for ``n = goal.n_objects`` objects has exactly n slots. Slot k is the
  k-th distinct object the robot manipulated in that command, in order of first manipulation
  (normally its first ``pickup``; a ``place`` of an object carried over from an earlier command
  also opens a slot). Objects beyond the n-th (e.g. a replacement after a failed pickup the planner
  gave up on) are folded into slot n: their actions add to slot n's costs (the per-slot cost
  attribution is unchanged).
* **Counting delivered objects.** sr_obj counts distinct delivered goal objects, up to n per
  command: slot k < n has the sr_obj of its object; slot n counts as fulfilled if any object
  folded into it is, and every further fulfilled object folded into slot n (beyond the first)
  fills the earliest slot still unfulfilled. So Σ sr_obj over a command = min(n, number of
  distinct fulfilled objects), and a replacement delivered after a failure counts, while the
  failed object's slot keeps its own costs.
* **Navigation.** A ``navigate`` action is attributed to the object of the next pickup/place in the
  same command, or to the previous one if none follows; if the command manipulated nothing at all,
  its navigation goes to slot 1.
* **Unfilled slots** (the planner never manipulated a k-th object) have ``sr_man = 0``,
  ``sr_obj = 0`` and zero cc/d/t, so m_overall = γ_man + γ_obj for them.
* ``cc`` = Σ collisions, ``d`` = Σ distance [m] of the slot's navigate actions; ``t_nav`` /
  ``t_man`` = Σ simulated time [s] of its navigate / pickup+place actions, ``t_exe = t_nav + t_man``;
  ``sr_man`` = mean ``success_rate`` of its pickup/place actions (0 without any).
* ``sr_obj`` ∈ {0, 1} per slot, counted as above from whether an object is *fulfilled*: it has a
  category in ``goal.categories`` (from the scene graph, never from the LLM), the robot delivered
  it in this command (a successful place of it), it did not stand on a target when the command
  began (an object already there is no goal; a pick-and-put-back is no progress), and its location
  after the command (``final_locations``; if absent, its last successful place in the command) is
  one of ``goal.target_furniture``.
* ``m_overall = γ_nav·cc + t_exe + d + γ_man·(1 − sr_man) + γ_obj·(1 − sr_obj)``
  (γ_nav, γ_man: ``SimConfig``; γ_obj: ``MetricsConfig``).

Per-command rows sum cc, d, t and m_overall over the command's slots and average sr_man and
sr_obj; per-mission rows do the same over all slots of the mission. ``object_index`` numbers the
slots 1..N along the mission (obj_1..obj_9 in the paper's Table III); ``m_overall_cum`` is the
running sum of m_overall along it (the paper's overall-metric figure).

Tables are lists of dicts (no pandas); ``write_csv`` writes them with the csv module.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

from interllm.core.records import CommandRecord, MissionRecord
from interllm.core.results import ActionResult
from interllm.errors import UserError
from interllm.io import atomic_write_text, read_json
from interllm.llm.calllog import read_records

MANIPULATION_KINDS = ("pickup", "place")
PER_OBJECT_FIELDS = ("planner", "scene", "mission", "command_index", "command", "slot", "object_index",
                     "object", "category", "filled", "n_actions", "cc", "d", "t_nav", "t_man", "t_exe",
                     "sr_man", "sr_obj", "m_overall", "m_overall_cum")
PER_COMMAND_FIELDS = ("planner", "scene", "mission", "command_index", "command", "n_objects",
                      "n_filled", "n_fulfilled", "cc", "d", "t_exe", "sr_man", "sr_obj", "m_overall",
                      "llm_calls", "llm_tokens_in", "llm_tokens_out", "regenerations", "replans",
                      "dropped_candidates")
PER_MISSION_FIELDS = ("planner", "scene", "mission", "n_commands", "n_objects", "n_fulfilled", "cc", "d",
                      "t_exe", "sr_man", "sr_obj", "m_overall", "llm_calls", "llm_tokens_in",
                      "llm_tokens_out", "sim_time")


class MetricsInputError(UserError, ValueError):
    """A run record or scene file is malformed; the message names the file and the key."""


@dataclass(frozen=True)
class Gammas:
    """Normalising factors of m_overall: γ_nav [s/collision], γ_man [s], γ_obj [s]."""

    nav: float = 10.0
    man: float = 100.0
    obj: float = 100.0

    @classmethod
    def from_config(cls, cfg: Any) -> Gammas:
        """From an ExperimentConfig (``sim.gamma_nav``, ``sim.gamma_man``, ``metrics.gamma_obj``)."""
        return cls(nav=float(cfg.sim.gamma_nav), man=float(cfg.sim.gamma_man),
                   obj=float(cfg.metrics.gamma_obj))

    @classmethod
    def from_mapping(cls, cfg: Mapping) -> Gammas:
        """From a config as a mapping (a run log's recorded config); a missing key keeps its default."""
        sim, met = cfg.get("sim") or {}, cfg.get("metrics") or {}
        return cls(nav=float(sim.get("gamma_nav", cls.nav)), man=float(sim.get("gamma_man", cls.man)),
                   obj=float(met.get("gamma_obj", cls.obj)))


def m_overall(cc: float, t_exe: float, d: float, sr_man: float, sr_obj: float, g: Gammas) -> float:
    """m_overall = γ_nav·cc + t_exe + d + γ_man·(1 − sr_man) + γ_obj·(1 − sr_obj).

    cc: collisions; t_exe: simulated time [s]; d: navigated distance [m]; sr_man, sr_obj in [0, 1].
    """
    return g.nav * cc + t_exe + d + g.man * (1.0 - sr_man) + g.obj * (1.0 - sr_obj)


# ---- reading ---------------------------------------------------------------------------------
def _require(d: Mapping, key: str, where: str) -> Any:
    if not isinstance(d, Mapping) or key not in d:
        raise MetricsInputError(f"{where}: missing key '{key}' (see MissionRecord in "
                                f"interllm/metrics/compute.py)")
    return d[key]


def call_log_counts(path: str | os.PathLike) -> dict:
    """Calls and failed calls (an error: unparseable after the repairs, or the backend failed) of a
    JSONL call log, in all and per planner; a missing log counts nothing."""
    out: dict[str, Any] = {"calls": 0, "failed": 0, "failed_by_planner": {}}
    for r in read_records(path):
        out["calls"] += 1
        if r.get("error"):
            out["failed"] += 1
            planner = str(r.get("planner") or "")
            out["failed_by_planner"][planner] = out["failed_by_planner"].get(planner, 0) + 1
    return out


def load_runs(runs_dir: str | os.PathLike) -> list[MissionRecord]:
    """All MissionRecords under ``runs_dir/<planner>/<scene>/<mission>.json``, in sorted path order."""
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        raise MetricsInputError(f"runs folder {runs_dir} does not exist; run the 'missions' stage "
                                f"first or pass the folder holding <planner>/<scene>/<mission>.json")
    return [MissionRecord.from_dict(read_json(p), str(p)) for p in sorted(runs_dir.glob("*/*/*.json"))]


def load_scene_categories(scenes_dir: str | os.PathLike, scene_ids: Iterable[str]) -> dict[str, dict]:
    """{scene_id: {object_id: category}} and initial furniture, from ``scenes_dir/<id>/scene.json``.

    Returns {scene_id: {"category": {obj: cat}, "furniture": {obj: furniture}}}.
    """
    out: dict[str, dict] = {}
    for sid in sorted(set(scene_ids)):
        p = Path(scenes_dir) / sid / "scene.json"
        if not p.is_file():
            raise MetricsInputError(f"scene file {p} is missing; object categories (for sr_obj) come "
                                    f"from it. Run the 'scenes' stage or pass the right scenes_dir")
        d = read_json(p)
        objs = _require(d, "objects", str(p))
        out[sid] = {"category": {o["id"]: o["category"] for o in objs},
                    "furniture": {o["id"]: o.get("furniture") for o in objs}}
    return out


# ---- per object --------------------------------------------------------------------------------
def assign_slots(actions: Sequence[ActionResult], n_slots: int) -> tuple[list[int], list[list[str]]]:
    """Slot index (0-based) of every action and the objects of every slot (rules in module doc)."""
    n_slots = max(1, int(n_slots))
    slot_of_obj: dict[str, int] = {}
    objects: list[list[str]] = [[] for _ in range(n_slots)]
    man_slot: list[Optional[int]] = []
    for a in actions:
        if a.action.kind in MANIPULATION_KINDS and a.action.obj is not None:
            o = str(a.action.obj)
            if o not in slot_of_obj:
                k = min(len(slot_of_obj), n_slots - 1)
                slot_of_obj[o] = k
                objects[k].append(o)
            man_slot.append(slot_of_obj[o])
        else:
            man_slot.append(None)
    out: list[int] = []
    for i, s in enumerate(man_slot):
        if s is not None:
            out.append(s)
            continue
        nxt = next((x for x in man_slot[i + 1:] if x is not None), None)
        prev = next((x for x in reversed(man_slot[:i]) if x is not None), None)
        out.append(nxt if nxt is not None else prev if prev is not None else 0)
    return out, objects


def _location(obj: str, command: CommandRecord, scene: Mapping) -> Optional[str]:
    """Where ``obj`` is after the command: ``final_locations`` (objects picked up in it), else its
    last successful place in the command, else where the scene had it."""
    if obj in command.final_locations:
        return command.final_locations[obj]
    loc = None
    for a in command.actions:
        if a.action.obj == obj and a.success:
            k = a.action.kind
            loc = a.action.furniture if k == "place" else "held" if k == "pickup" else loc
    if loc is not None:
        return loc
    return scene.get("furniture", {}).get(obj)


def delivered(obj: str, command: CommandRecord) -> bool:
    """Whether the robot put ``obj`` down during the command (a successful place of it)."""
    return any(a.success and a.action.kind == "place" and a.action.obj == obj for a in command.actions)


def fulfilled(obj: str, command: CommandRecord, scene: Mapping, before: Optional[str] = None) -> bool:
    """sr_obj of one object: right category (scene graph), delivered in this command and ended on a
    target furniture, having started the command elsewhere (``before``: where it stood when the
    command began; an object already on a target is no goal, and picking it up and putting it back
    is no progress)."""
    targets = set(command.goal.target_furniture)
    cat = scene.get("category", {}).get(obj)
    return (cat in set(command.goal.categories) and delivered(obj, command) and before not in targets
            and _location(obj, command, scene) in targets)


def _moved(where: dict, command: CommandRecord) -> None:
    """Update ``where`` (object -> furniture or "held") with the command's successful pickups and places."""
    for a in command.actions:
        if a.success and a.action.obj is not None and a.action.kind in MANIPULATION_KINDS:
            where[a.action.obj] = "held" if a.action.kind == "pickup" else str(a.action.furniture)


class MissionRows:
    """The metric rows of one mission, built command by command (``add``): the aggregate stage adds a
    mission record's commands, a replay the commands a run log recorded (``run_log_object_rows``).

    scene: {"category": {obj: cat}, "furniture": {obj: furniture}} (``load_scene_categories``).
    """

    def __init__(self, planner: str, scene_id: str, mission_id: str, scene: Mapping, g: Gammas) -> None:
        self.planner, self.scene_id, self.mission_id, self.scene, self.g = planner, scene_id, mission_id, scene, g
        self.objects: list[dict] = []
        self.commands: list[dict] = []
        self._cum = 0.0
        self.where: dict[str, str] = dict(scene.get("furniture", {}))  # object -> furniture / "held"

    def add(self, c: CommandRecord) -> tuple[list[dict], dict]:
        """The per-object rows and the per-command row of the next command of the mission."""
        ci = len(self.commands)
        n = max(1, int(c.goal.n_objects))
        actions = list(c.actions)
        slot_of, slot_objs = assign_slots(actions, n)
        sr_objs = self._sr_obj(c, slot_objs)
        rows = []
        for k in range(n):
            mine = [a for a, s in zip(actions, slot_of, strict=True) if s == k]
            nav = [a for a in mine if a.action.kind == "navigate"]
            man = [a for a in mine if a.action.kind in MANIPULATION_KINDS]
            cc = float(sum(int(a.collisions) for a in nav))
            d = float(sum(float(a.distance) for a in nav))
            t_nav = float(sum(float(a.time) for a in nav))
            t_man = float(sum(float(a.time) for a in man))
            sr_man = (sum(float(a.success_rate) for a in man) / len(man)) if man else 0.0
            sr_obj = sr_objs[k]
            m = m_overall(cc, t_nav + t_man, d, sr_man, sr_obj, self.g)
            self._cum += m
            rows.append({
                "planner": self.planner, "scene": self.scene_id, "mission": self.mission_id,
                "command_index": ci + 1, "command": c.command_id, "slot": k + 1,
                "object_index": len(self.objects) + len(rows) + 1, "object": "+".join(slot_objs[k]),
                "category": "+".join(str(self.scene.get("category", {}).get(o)) for o in slot_objs[k]),
                "filled": int(bool(slot_objs[k])), "n_actions": len(mine), "cc": cc, "d": d,
                "t_nav": t_nav, "t_man": t_man, "t_exe": t_nav + t_man, "sr_man": sr_man,
                "sr_obj": sr_obj, "m_overall": m, "m_overall_cum": self._cum})
        self.objects.extend(rows)
        _moved(self.where, c)
        s = c.summary
        row = {"planner": self.planner, "scene": self.scene_id, "mission": self.mission_id,
               "command_index": ci + 1, "command": c.command_id, "n_objects": n,
               "n_filled": sum(r["filled"] for r in rows), "n_fulfilled": int(sum(r["sr_obj"] for r in rows)),
               **_sums(rows), "llm_calls": int(s.llm_calls), "llm_tokens_in": int(s.llm_tokens_in),
               "llm_tokens_out": int(s.llm_tokens_out), "regenerations": int(s.regenerations),
               "replans": int(s.replans), "dropped_candidates": int(s.dropped_candidates)}
        self.commands.append(row)
        return rows, row

    def _sr_obj(self, c: CommandRecord, slot_objs: list[list[str]]) -> list[float]:
        """sr_obj of each slot (module doc, "Counting delivered objects"): a slot's own object, slot n
        if any object folded into it is fulfilled, and the further fulfilled objects of slot n fill
        the earliest unfulfilled slots; Σ = min(n, distinct fulfilled objects)."""
        ok = [[fulfilled(o, c, self.scene, self.where.get(o)) for o in objs] for objs in slot_objs]
        out = [1.0 if any(f) else 0.0 for f in ok]
        spare = max(0, sum(ok[-1]) - 1)  # fulfilled objects of slot n beyond the one it counts
        for k in range(len(out) - 1):
            if spare and out[k] == 0.0:
                out[k], spare = 1.0, spare - 1
        return out

    def mission_row(self, sim_time: float) -> dict:
        return {"planner": self.planner, "scene": self.scene_id, "mission": self.mission_id,
                "n_commands": len(self.commands), "n_objects": len(self.objects),
                "n_fulfilled": int(sum(r["sr_obj"] for r in self.objects)), **_sums(self.objects),
                "llm_calls": sum(r["llm_calls"] for r in self.commands),
                "llm_tokens_in": sum(r["llm_tokens_in"] for r in self.commands),
                "llm_tokens_out": sum(r["llm_tokens_out"] for r in self.commands),
                "sim_time": float(sim_time)}


def mission_rows(rec: MissionRecord, scene: Mapping, g: Gammas) -> tuple[list[dict], list[dict], dict]:
    """(per_object rows, per_command rows, per_mission row) of one MissionRecord."""
    rows = MissionRows(rec.planner, rec.scene_id, rec.mission_id, scene, g)
    for c in rec.commands:
        rows.add(c)
    return rows.objects, rows.commands, rows.mission_row(rec.sim_time)


def run_log_object_rows(run: Any) -> list[tuple[float, dict]]:
    """(end time of its command [s], per-object row) of a run log (``interllm.record.reader.RunLog``),
    computed from its executed results (/results/command and /actions) as the aggregate stage
    computes them, with the γ of the config the run recorded. A replay plots them."""
    cfg = run.run.get("config") if isinstance(run.run.get("config"), Mapping) else {}
    g = Gammas.from_mapping(cfg)
    objects = run.scene.objects.values() if run.scene is not None else ()
    scene = {"category": {o.id: o.category for o in objects}, "furniture": {o.id: o.furniture for o in objects}}
    rows = MissionRows(str(run.run.get("planner", "")), str(run.run.get("scene", "")),
                       str(run.run.get("mission", "")), scene, g)
    out: list[tuple[float, dict]] = []
    for t, command in run.command_records():
        out += [(t, row) for row in rows.add(command)[0]]
    return out


def _sums(rows: list[dict]) -> dict:
    n = max(1, len(rows))
    return {"cc": sum(r["cc"] for r in rows), "d": sum(r["d"] for r in rows),
            "t_exe": sum(r["t_exe"] for r in rows), "sr_man": sum(r["sr_man"] for r in rows) / n,
            "sr_obj": sum(r["sr_obj"] for r in rows) / n, "m_overall": sum(r["m_overall"] for r in rows)}


def compute_tables(records: Iterable[Mapping], scenes: Mapping[str, Mapping], g: Gammas
                   ) -> dict[str, list[dict]]:
    """{"per_object", "per_command", "per_mission"} rows of all records, sorted by
    (planner, scene, mission, ...)."""
    po, pc, pm = [], [], []
    for rec in records:
        sid = rec.scene_id
        if sid not in scenes:
            raise MetricsInputError(f"run {rec.planner}/{sid}/{rec.mission_id}: scene '{sid}' has no "
                                    f"scene.json among {sorted(scenes)}")
        a, b, c = mission_rows(rec, scenes[sid], g)
        po += a
        pc += b
        pm.append(c)
    po.sort(key=lambda r: (r["planner"], r["scene"], r["mission"], r["object_index"]))
    pc.sort(key=lambda r: (r["planner"], r["scene"], r["mission"], r["command_index"]))
    pm.sort(key=lambda r: (r["planner"], r["scene"], r["mission"]))
    return {"per_object": po, "per_command": pc, "per_mission": pm}


# ---- CSV -------------------------------------------------------------------------------------
def fmt(v: Any, ndigits: int = 6) -> Any:
    """Stable text for floats (rounded, no '-0'); other values unchanged."""
    if isinstance(v, float):
        r = round(v, ndigits)
        if r == 0:
            r = 0.0
        return repr(r)
    return v


def csv_text(rows: list[Mapping], fields: Optional[Iterable[str]] = None) -> str:
    """CSV text (csv module, '\\n' line ends, floats via ``fmt``) of a list of dicts."""
    rows = list(rows)
    fields = list(fields) if fields is not None else (list(rows[0]) if rows else [])
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: fmt(r.get(k, "")) for k in fields})
    return buf.getvalue()


def write_csv(path: str | os.PathLike, rows: list[Mapping], fields: Optional[Iterable[str]] = None) -> None:
    """Atomically write ``rows`` as CSV (header = ``fields`` or the first row's keys)."""
    atomic_write_text(path, csv_text(rows, fields))


def read_csv(path: str | os.PathLike) -> list[dict]:
    """Rows of a CSV written by ``write_csv``; numeric-looking cells become int/float."""
    with open(path, encoding="utf-8", newline="") as f:
        return [{k: _num(v) for k, v in r.items()} for r in csv.DictReader(f)]


def _num(s: str) -> Any:
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s
