"""Procedural house generator: ``generate_scene(cfg, index)``, deterministic in ``(cfg, index)``.

Scene ``index`` uses seed ``cfg.seed + index``; each attempt draws from a numpy ``Generator``
seeded by ``core.seeding.scene_seed(seed, attempt)``, and every float is rounded to 1e-4 m so
``scene.to_json()`` is byte-identical across runs and machines. An attempt builds the house in
stages on one ``build_state.BuildState``:

1. the floor plan: rooms, doors and walls (``floor_plans``; ``scene.layout`` grid or hallway);
2. the furniture (``furnishing``), each piece's size from ``scene.assets`` (``asset_source``: the
   catalog's, or a ProcTHOR asset with chairs around tables and desks);
3. the objects (``scene.object_design``): ``graded_objects`` (difficulty by design) or
   ``surface_objects`` (legacy).

An attempt is redrawn when a stage fails or some furniture is unreachable on the presumed or the
true grid. The paper's three commands must always be satisfiable; with the catalog's sizes, an
attempt that leaves another command of the catalog unsupported is kept as a fallback while up to
``FULL_SUPPORT_ATTEMPTS`` attempts look for one supporting every command (a house of ProcTHOR assets
is taken as the first valid attempt: the search would prefer dining tables without their chairs).
``scene.meta["commands"]`` lists the commands each scene supports (graded: with k easy instances).
"""

from __future__ import annotations

import numpy as np

from interllm.config import SceneConfig
from interllm.core.seeding import scene_seed
from interllm.scene.asset_source import PROCTHOR_META, asset_source
from interllm.scene.build_state import BuildState, Retry, SceneGenerationError
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.floor_plans import grid_plan, hallway_plan
from interllm.scene.furnishing import place_all_furniture
from interllm.scene.graded_objects import place_graded_objects
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import rasterize
from interllm.scene.reachability import unreachable
from interllm.scene.surface_objects import place_legacy_objects

MAX_ATTEMPTS = 25
FULL_SUPPORT_ATTEMPTS = 8  # attempts spent looking for a scene supporting every command

def capacity(cfg: SceneConfig, cat: Catalog) -> tuple[int, int]:
    """Upper bounds (furniture, objects) a house of ``cfg`` can hold, from the catalog's sizes:
    every room at ``scene.room_size_max``, furniture packed at its smallest footprint plus the free
    ring, objects packed on the largest surface at their smallest side plus the object gap. Sizes
    above these can never be generated; sizes below may still fail (rooms are smaller in fact)."""
    pl = cat.placement
    floor_area = cfg.n_rooms * cfg.room_size_max ** 2
    smallest = min((f.size[0] + pl.free_ring) * (f.size[1] + pl.free_ring) for f in cat.furniture.values())
    max_furniture = int(floor_area // smallest)
    per_piece = 0
    for f in cat.furniture.values():
        if not f.holds:
            continue
        area = max(0.0, f.size[0] - 2 * pl.surface_margin + pl.object_gap) * \
            max(0.0, f.size[1] - 2 * pl.surface_margin + pl.object_gap)
        need = min((cat.objects[c].size[0] + pl.object_gap) * (cat.objects[c].size[1] + pl.object_gap)
                   for c in f.holds)
        per_piece = max(per_piece, int(area // need))
    return max_furniture, per_piece * min(cfg.n_furniture, max_furniture)


def check_capacity(cfg: SceneConfig, cat: Catalog) -> None:
    """Refuse sizes that cannot fit, up front, naming the numbers that would."""
    max_f, max_o = capacity(cfg, cat)
    if cfg.n_furniture > max_f:
        raise SceneGenerationError(
            f"scene.n_furniture={cfg.n_furniture} cannot fit in {cfg.n_rooms} rooms of at most "
            f"{cfg.room_size_max:g} m (scene.room_size_max): at most {max_f} pieces would; lower "
            f"scene.n_furniture to <= {max_f}, or raise scene.n_rooms or scene.room_size_max")
    if cfg.n_objects > max_o:
        per = max(1, max_o // max(1, cfg.n_furniture))
        raise SceneGenerationError(
            f"scene.n_objects={cfg.n_objects} cannot fit on scene.n_furniture={cfg.n_furniture} pieces: at "
            f"most {max_o} objects would (about {per} per piece at best); lower scene.n_objects to "
            f"<= {max_o}, or raise scene.n_furniture to >= {-(-cfg.n_objects // per)}")


def generate_scene(cfg: SceneConfig, index: int = 0, robot_radius: float = 0.25,
                   catalog: Catalog | None = None, objects_per_command: int | None = None,
                   footprint_radius: float | None = None) -> SceneGraph:
    """Generate scene ``index`` of an experiment, deterministic in (cfg, index).

    cfg: scene config (counts, room sizes [m], door widths [m], probabilities, seed).
    robot_radius: base radius [m] used to size partly closed doors (gap < 2 * radius) and to check
        that every furniture is reachable on the presumed and the true grid.
    objects_per_command: graded design: the easy instances each command gets
        (``mission.objects_per_command``; None: the catalog's ``min_objects_per_command``).
    footprint_radius: [m] graded design: the base's true contact radius (``sim.footprint_radius``);
        easy spots need floor clear of obstacles by it (None: robot_radius + 0.05 m).
    """
    cfg.validate()
    cat = catalog or load_catalog()
    check_capacity(cfg, cat)
    k = cat.min_objects_per_command if objects_per_command is None else int(objects_per_command)
    extra = 0.05 if footprint_radius is None else max(0.0, float(footprint_radius) - robot_radius)
    graded = cfg.object_design == "graded"
    seed = int(cfg.seed) + int(index)
    if seed < 0:
        raise ValueError(f"scene.seed + index must be >= 0, got {seed}; use a non-negative scene.seed")
    reasons = []
    house_types = set(cat.room_types_for_house(cfg.n_rooms))
    # a house of real assets is taken as drawn (its missions come from what it holds, measured): looking
    # for one that hosts all of our catalog's commands would prefer tables without their chairs
    want_all = cfg.assets == "catalog" and all(c.target_room_type in house_types or c.target_room_type is None
                                               for c in cat.commands)
    fallback = None
    assets = asset_source(cfg.assets, cat)
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng(scene_seed(seed, attempt))
        b = BuildState(cat, cfg, rng, robot_radius, k=k, footprint_extra=extra, assets=assets)
        try:
            (hallway_plan if cfg.layout == "hallway" else grid_plan)(b)
            place_all_furniture(b)
            supported = (place_graded_objects if graded else place_legacy_objects)(b)
        except Retry as e:
            reasons.append(str(e))
            continue
        scene = SceneGraph(
            id=f"{cfg.name}_s{seed:04d}", seed=seed, rooms=b.rooms, walls=b.walls, doors=b.doors,
            furniture=b.furniture, objects=b.objects,
            meta={"generator": "interllm.scene.generator", "preset": cfg.name, "attempt": attempt,
                  "commands": supported, "robot_radius": robot_radius,
                  "grid_resolution": cfg.grid_resolution,
                  **({"object_design": "graded", "objects_per_command": k} if graded else {}),
                  **({"assets": PROCTHOR_META} if cfg.assets == "procthor" else {})})
        bad = []
        for doors in ("presumed", "true"):
            grid = rasterize(scene, cfg.grid_resolution, robot_radius, doors=doors)
            bad += [f"{x} ({doors})" for x in unreachable(scene, grid, robot_radius)]
        if bad:
            reasons.append(f"unreachable: {bad[:5]}")
            continue
        if not want_all or all(supported.values()):
            return scene
        # Some command lacks targets or objects: keep this scene, try a few more attempts for one
        # that supports every command of the catalog.
        fallback = fallback or scene
        if attempt >= FULL_SUPPORT_ATTEMPTS:
            return fallback
    if fallback is not None:
        return fallback
    raise SceneGenerationError(f"no valid scene for seed {seed} after {MAX_ATTEMPTS} attempts; "
                               f"last reasons: {reasons[-3:]}")
