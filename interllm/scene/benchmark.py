"""A versioned benchmark: the houses and missions of an experiment frozen on purpose, under a name.

Without one (``benchmark: ""``) the scenes stage generates the houses and draws the missions from
the simulator's own measurement of them, so a change to the simulator (IK, base-pose sampling, the
robot) silently changes which commands are asked, and results before and after are not comparable.
With one (``benchmark: paper-v2``) the scenes stage takes the houses (``scene.json``) and missions
(``missions.json``) from ``<benchmark_dir>/<name>/`` instead, still measures them with the current
simulator, and reports every slot whose measured feasibility changed since the benchmark was
frozen (``recheck``), instead of drawing other commands.

A benchmark folder holds ``manifest.json`` (``Manifest``: the name, the commit and robot it was
frozen with, the scene and mission config it was drawn with, and the SHA-256 of every frozen file)
and per scene ``<scene_id>/{scene.json, missions.json, feasibility.json}`` (the measurement at
freezing). A version is never rewritten: ``python -m pipeline.freeze_benchmark <name>`` refuses an
existing name, and the scenes stage refuses a frozen file whose hash no longer matches.

This module is the scene layer's part (plain data: no simulator); ``interllm.stages.scenes`` runs the
measurement and calls ``recheck``.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from interllm.config import BENCHMARK_NAME
from interllm.errors import UserError
from interllm.io import check_name, read_bytes, read_json
from interllm.scene.graph import Mission
from interllm.scene.missions import CommandFill, Fulfillable, load_missions, match_slots

BENCHMARK_SCHEMA_VERSION = 1
MANIFEST = "manifest.json"
FROZEN_FILES = ("scene.json", "missions.json", "feasibility.json")  # per scene, in this order
# config keys that do not change which houses and missions are drawn, so a benchmark leaves them free
FREE_KEYS = frozenset({"scene.reach_report", "mission.limit_missions"})
# keys added after benchmarks were frozen, with the value that draws their houses and missions as they
# were drawn: a manifest without the key was frozen with that value
ADDED_KEYS = {"mission": {"commands": "auto"}, "scene": {"assets": "catalog"}}
# counts a run may lower: house i and mission j do not depend on how many are drawn (house i is
# generated with scene.seed + i, mission j with its own seed), so the first ones are a subset
SUBSET_KEYS = ("scene.n_scenes", "mission.n_missions")
IMPORTED = "(imported houses)"  # drawn_with's scene.import_path when the houses were imported


class BenchmarkError(UserError, ValueError):
    """A benchmark cannot be used as configured (missing, altered, or drawn with another config)."""


def check_benchmark_name(name: str, key: str = "benchmark") -> str:
    """``name`` unchanged if it can name a benchmark folder, else :class:`BenchmarkError` naming ``key``."""
    if not BENCHMARK_NAME.fullmatch(name or ""):
        raise BenchmarkError(f"{key}={name!r} is not a benchmark name: use 1-64 characters of a-z, 0-9, '.', '_' "
                             f"and '-', starting with a letter or digit (e.g. paper-v2); '' draws the missions "
                             f"from this run's own measurement instead")
    return name


def drawn_with(seed: int, scene: object, mission: object) -> dict:
    """The config a benchmark is drawn with: the experiment's replicate ``seed`` and the scene and
    mission groups (dataclasses), without ``FREE_KEYS`` and ``SUBSET_KEYS``; ``scene.import_path``
    only says whether the houses were imported (``IMPORTED``): the frozen houses are what counts,
    and their path differs from machine to machine."""
    out: dict = {"seed": int(seed)}
    for group, obj in (("scene", scene), ("mission", mission)):
        out[group] = {k: v for k, v in dataclasses.asdict(obj).items()  # type: ignore[call-overload]
                      if f"{group}.{k}" not in FREE_KEYS and f"{group}.{k}" not in SUBSET_KEYS}
    out["scene"]["import_path"] = IMPORTED if out["scene"].get("import_path") else None
    return out


def config_differences(frozen: Mapping, given: Mapping, prefix: str = "") -> list[str]:
    """``key: frozen X, given Y`` for every key whose value differs (nested mappings flattened)."""
    out = []
    for k in sorted(set(frozen) | set(given)):
        a, b = frozen.get(k, "<absent>"), given.get(k, "<absent>")
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            out += config_differences(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}: frozen {a!r}, given {b!r}")
    return out


def sha256_of(path: Path) -> str:
    return hashlib.sha256(read_bytes(path)).hexdigest()


@dataclass(frozen=True)
class Manifest:
    """``manifest.json`` of a benchmark: name, the git commit and robot (``sim.robot``) it was frozen
    with, the config it was drawn with (``drawn_with``), and per scene (in generation order) the
    SHA-256 of each of ``FROZEN_FILES``."""

    name: str
    commit: str
    robot: str
    config: dict
    n_missions: int  # missions per scene
    scenes: dict[str, dict[str, str]]  # scene id -> {file name: sha256}

    def to_dict(self) -> dict:
        return {"schema_version": BENCHMARK_SCHEMA_VERSION, "name": self.name, "frozen_commit": self.commit,
                "frozen_robot": self.robot, "config": self.config, "n_missions": self.n_missions,
                "scenes": [{"id": sid, "sha256": files} for sid, files in self.scenes.items()]}

    @classmethod
    def from_dict(cls, d: object, source: str) -> Manifest:
        try:
            assert isinstance(d, dict) and d["schema_version"] == BENCHMARK_SCHEMA_VERSION
            scenes = {str(s["id"]): {f: str(s["sha256"][f]) for f in FROZEN_FILES} for s in d["scenes"]}
            return cls(str(d["name"]), str(d["frozen_commit"]), str(d["frozen_robot"]), dict(d["config"]),
                       int(d["n_missions"]), scenes)
        except (AssertionError, KeyError, TypeError, ValueError):
            raise BenchmarkError(f"{source}: not a benchmark manifest of schema version {BENCHMARK_SCHEMA_VERSION} "
                                 f"(keys schema_version, name, frozen_commit, frozen_robot, config, n_missions, "
                                 f"scenes[].id, scenes[].sha256); restore it with `git checkout -- {source}`") from None


@dataclass(frozen=True)
class Benchmark:
    """An opened benchmark folder (``open_benchmark``)."""

    root: Path
    manifest: Manifest

    @property
    def name(self) -> str:
        return self.manifest.name

    @property
    def scenes_frozen(self) -> list[str]:
        """The frozen scene ids in generation order (a run takes the first scene.n_scenes)."""
        return list(self.manifest.scenes)

    def path(self, scene_id: str, file: str) -> Path:
        """A frozen file, after checking its SHA-256 against the manifest."""
        if scene_id not in self.manifest.scenes:
            raise BenchmarkError(f"scene {scene_id!r} is not in benchmark {self.name!r} ({self.root / MANIFEST} "
                                 f"lists {self.scenes_frozen})")
        p = self.root / check_name(scene_id, f"the scene id in {self.root / MANIFEST}") / file
        if not p.is_file() or sha256_of(p) != self.manifest.scenes[scene_id][file]:
            raise BenchmarkError(f"{p} is {'missing' if not p.is_file() else 'not the file frozen'} in benchmark "
                                 f"{self.name!r} (its SHA-256 is in {self.root / MANIFEST}): a benchmark version is "
                                 f"never changed; restore it (`git checkout -- {self.root}`) or freeze a new "
                                 f"version under another name (python -m pipeline.freeze_benchmark NAME)")
        return p

    def missions(self, scene_id: str) -> list[Mission]:
        return load_missions(self.path(scene_id, "missions.json"))

    def feasibility(self, scene_id: str) -> dict:
        """The scene's ``feasibility.json`` as measured when the benchmark was frozen."""
        return read_json(self.path(scene_id, "feasibility.json"))

    def check_config(self, given: dict, n_scenes: int, n_missions: int) -> None:
        """:class:`BenchmarkError` listing every key (``drawn_with``) that differs from the frozen config,
        and the counts (``SUBSET_KEYS``) beyond the frozen ones."""
        frozen = {**self.manifest.config}
        for group, added in ADDED_KEYS.items():
            if isinstance(frozen.get(group), Mapping):
                frozen[group] = {**added, **frozen[group]}
        diff = config_differences(frozen, given)
        for key, n, have in (("scene.n_scenes", n_scenes, len(self.scenes_frozen)),
                             ("mission.n_missions", n_missions, self.manifest.n_missions)):
            if n > have:
                diff.append(f"{key}: {have} frozen, {n} asked (at most {have}: the first ones are used)")
        if diff:
            raise BenchmarkError(f"benchmark {self.name!r} ({self.root / MANIFEST}) was drawn with another config: "
                                 f"{'; '.join(diff)}. Fix: set those keys as frozen, or set benchmark='' to draw the "
                                 f"houses and missions from this run's own measurement, or freeze a new version "
                                 f"(python -m pipeline.freeze_benchmark NAME <overrides>)")


def available(benchmark_dir: Path) -> list[str]:
    """The benchmark names under ``benchmark_dir`` (folders holding a manifest)."""
    d = Path(benchmark_dir)
    return sorted(p.name for p in d.iterdir() if (p / MANIFEST).is_file()) if d.is_dir() else []


def open_benchmark(benchmark_dir: str | Path, name: str) -> Benchmark:
    """The benchmark ``name`` under ``benchmark_dir``; :class:`BenchmarkError` names the ones there."""
    root = Path(benchmark_dir) / check_benchmark_name(name)  # read only: a name, so never outside benchmark_dir
    mpath = root / MANIFEST
    if not mpath.is_file():
        have = available(Path(benchmark_dir))
        raise BenchmarkError(f"benchmark={name!r}: no {mpath}; benchmarks under {benchmark_dir} (benchmark_dir): "
                             f"{have or 'none'}. Set benchmark to one of them, freeze this one with "
                             f"`python -m pipeline.freeze_benchmark {name}`, or set benchmark='' to draw the "
                             f"missions from this run's own measurement")
    manifest = Manifest.from_dict(read_json(mpath), str(mpath))
    if manifest.name != name:
        raise BenchmarkError(f"{mpath}: names benchmark {manifest.name!r}, not {name!r} (its folder); restore it "
                             f"with `git checkout -- {root}`")
    return Benchmark(root, manifest)


@dataclass(frozen=True)
class SlotChange:
    """One command of a frozen mission whose measured feasibility changed: the slots the mission's
    matching filled when frozen and now, and the instances that stopped (lost) or started (gained)
    being fulfillable for it (among those examined; ``stages.feasibility``)."""

    mission: str
    command: str
    slots_then: int
    slots_now: int
    lost: tuple[str, ...]
    gained: tuple[str, ...]

    def to_dict(self) -> dict:
        return {"mission": self.mission, "command": self.command, "slots_then": self.slots_then,
                "slots_now": self.slots_now, "lost": list(self.lost), "gained": list(self.gained)}


def recheck(missions: Sequence[Mission], frozen_record: Mapping, fulfillable: Fulfillable, k: int,
            source: str = "the frozen feasibility.json"
            ) -> tuple[list[tuple[Mission, tuple[CommandFill, ...]]], list[SlotChange]]:
    """The frozen ``missions`` filled by the current measurement ``fulfillable``, and what changed.

    frozen_record: the scene's ``feasibility.json`` when frozen (its ``missions`` give each command's
    slots and fulfillable instances then); k: objects a command asks for. Each mission's commands
    keep the objects they ask for (``n_objects``); the matching (``match_slots``, distinct instances
    across the mission) is recomputed on the current measurement: status ``ok`` when it fills them
    all, ``short`` when not (the planners still run the command as frozen). Dropped commands (no
    objects when frozen) are carried over as they were. Returns the (mission, fills) pairs in
    ``feasibility_record``'s form and the commands whose slots or fulfillable instances changed.
    """
    then = {m["id"]: m["commands"] for m in frozen_record.get("missions", [])}
    drawn, changes = [], []
    for mission in missions:
        frozen = then.get(mission.id)
        if frozen is None:
            raise BenchmarkError(f"mission {mission.id} of scene {mission.scene_id} is not in {source}: the "
                                 f"benchmark is inconsistent; freeze a new version")
        asked = [c for c in frozen if int(c["n_objects"]) > 0]
        demands = [(tuple(fulfillable.objects.get(c["id"], ())),
                    min(int(c["n_objects"]), int(fulfillable.capacity.get(c["id"], 0)))) for c in asked]
        got = iter(match_slots(demands))
        fills = []
        for c in frozen:
            n = int(c["n_objects"])
            if n == 0:
                fills.append(CommandFill(c["id"], int(c["asked"]), 0, 0, c["status"], (), tuple(c["fulfillable"])))
                continue
            now, cands = next(got), tuple(fulfillable.objects.get(c["id"], ()))
            fills.append(CommandFill(c["id"], int(k), n, len(now), "ok" if len(now) >= n else "short", tuple(now),
                                     cands))
            lost = tuple(sorted(set(c["fulfillable"]) - set(cands)))
            gained = tuple(sorted(set(cands) - set(c["fulfillable"])))
            if len(now) != int(c["matched"]) or lost or gained:
                changes.append(SlotChange(mission.id, c["id"], int(c["matched"]), len(now), lost, gained))
        drawn.append((mission, tuple(fills)))
    return drawn, changes


def pickups_changed(frozen_record: Mapping, objects_now: Mapping[str, Mapping]) -> list[str]:
    """Objects measured both times whose pickup went from possible (success rate > 0) to not, or back."""
    then = frozen_record.get("objects", {})
    return sorted(o for o in set(then) & set(objects_now)
                  if (float(then[o]["pickup_sr"]) > 0) != (float(objects_now[o]["pickup_sr"]) > 0))


def benchmark_section(bench: Benchmark, changes: Sequence[SlotChange], pickups: Sequence[str],
                      starts_moved: Sequence[str], slots: int) -> dict:
    """``feasibility.json``'s ``benchmark``: which version the scene comes from and what the
    current simulator measures differently (``slots_changed``: Σ |slots then − slots now|)."""
    return {"name": bench.name, "frozen_commit": bench.manifest.commit, "frozen_robot": bench.manifest.robot,
            "slots": int(slots), "slots_changed": sum(abs(c.slots_then - c.slots_now) for c in changes),
            "changes": [c.to_dict() for c in changes], "pickups_changed": list(pickups),
            "starts_moved": list(starts_moved)}
