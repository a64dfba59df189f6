"""Repairs of untidy ProcTHOR houses, used by ``import_procthor`` unless ``strict``.

Published ProcTHOR houses are rarely tidy: chairs are pushed under tables (the robot cannot reach
them), a child object lies a little off its parent's footprint, a table's rotation disagrees with its
box. Instead of rejecting the whole house for one such item, the importer

- checks a parent's footprint against its ``rotation.y`` and its ``axisAlignedBoundingBox`` when a child
  lies off it (``choose_footprint``), and uses the one its children lie over;
- puts a child still far off its parent on the nearest supporting surface within
  ``CHILD_SURFACE_BOUND``, else on a patch of floor under it, else drops it (``place_stray_child``);
- keeps furniture the robot cannot reach (and the objects on it), marked unreachable with the reason
  (``mark_unreachable``), so that missions leave them out;
- then warns, without refusing the house, when no command of the catalog can be hosted, naming the
  commands generated from what the house holds instead (``warn_unhostable``).

Every repair is a line of the ``ImportReport`` naming the JSON paths it touched.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Optional, Protocol

from interllm.scene.catalog import Catalog
from interllm.scene.geometry import point_in_polygon, r4
from interllm.scene.graph import Furniture, Room, SceneGraph
from interllm.scene.grid import rasterize
from interllm.scene.reachability import REACH_MARGIN, unreachable

CHILD_SLACK = 0.5  # [m] a child farther than this outside its parent's footprint is a stray, not a nudge
CHILD_SURFACE_BOUND = 1.0  # [m] a stray child goes to a supporting surface at most this far from it
OVER_TOLERANCE = 0.02  # [m] a child this close to a footprint counts as over it
FLOOR_CATEGORY = "floor"  # the furniture a child put on the floor rests on: a thin patch under it
FLOOR_PATCH_HEIGHT = 0.02  # [m]
FLOOR_PATCH_MARGIN = 0.05  # [m] around the child's box
TUCKED_MIN_OVERLAP = 0.01  # [m²] a footprint sharing this much with another furniture is tucked under it


class Report(Protocol):
    """What the repairs need of ``importer.ImportReport``."""

    def add(self, reason: str, item: str) -> None: ...

    def warn(self, text: str) -> None: ...


def footprint_distance(fp: tuple[float, float, float, float], x: float, y: float) -> float:
    """Distance [m] from point (x, y) to the rectangle ``fp`` (x0, y0, x1, y1); 0 inside it."""
    x0, y0, x1, y1 = fp
    return math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1))


def _rect(center: tuple[float, float], size: tuple[float, float]) -> tuple[float, float, float, float]:
    return center[0] - size[0] / 2, center[1] - size[1] / 2, center[0] + size[0] / 2, center[1] + size[1] / 2


def footprint_candidates(o: dict, default: tuple[float, float], catalog_size) -> list[tuple[str, tuple]]:
    """The footprints (label, (x extent, z extent) [m]) a ProcTHOR object may have, the file's own
    (``default``, what the importer derived) first: its ``axisAlignedBoundingBox``, the catalog size
    turned by ``rotation.y``, and turned by ``rotation.y`` + 90° (a rotation the file got wrong)."""
    out = [("the file's footprint", default)]
    aabb = o.get("axisAlignedBoundingBox")
    if isinstance(aabb, dict) and isinstance(aabb.get("size"), dict):
        out.append(("axisAlignedBoundingBox", (float(aabb["size"]["x"]), float(aabb["size"]["z"]))))
    if catalog_size is not None:
        yaw = float((o.get("rotation") or {}).get("y", 0.0))
        for label, turn in (("catalog size turned by rotation.y", 0.0),
                            ("catalog size turned by rotation.y + 90°", 90.0)):
            c, s = abs(math.cos(math.radians(yaw + turn))), abs(math.sin(math.radians(yaw + turn)))
            out.append((label, (catalog_size[0] * c + catalog_size[1] * s, catalog_size[0] * s + catalog_size[1] * c)))
    return out


def choose_footprint(center: tuple[float, float], candidates: list[tuple[str, tuple]],
                     points: list[tuple[float, float]]) -> tuple[str, tuple]:
    """The candidate footprint the most ``points`` (children) lie over; the first on a tie."""
    def over(size) -> int:
        fp = _rect(center, size)
        return sum(footprint_distance(fp, x, y) <= OVER_TOLERANCE for x, y in points)

    return max(candidates, key=lambda c: (over(c[1]), -candidates.index(c)))


def check_parent_footprint(o: dict, path: str, center: tuple[float, float], size: tuple[float, float],
                           catalog_size, points: list[tuple[float, float]], rep: Report) -> tuple[float, float]:
    """The footprint size (x, z extents [m]) of the ProcTHOR object ``o`` at ``path``: its own,
    unless a child lies off it and more of its children lie over its bounding box or its catalog size
    turned by its rotation (or by its rotation + 90°); one report line says which was used."""
    fp = _rect(center, size)
    if all(footprint_distance(fp, x, y) <= OVER_TOLERANCE for x, y in points):
        return size
    label, best = choose_footprint(center, footprint_candidates(o, size, catalog_size), points)
    rep.add(f"parent with a child off its footprint: checked against rotation.y and axisAlignedBoundingBox, "
            f"{label} used", path)
    return best


def child_points(children: list) -> list[tuple[float, float]]:
    """The (x, z) of the ProcTHOR children that have a usable (finite) position."""
    out = []
    for c in children:
        q = c.get("position") if isinstance(c, dict) else None
        try:
            x, z = float(q["x"]), float(q["z"])  # type: ignore[index]
        except (TypeError, KeyError, ValueError):
            continue
        if math.isfinite(x) and math.isfinite(z):
            out.append((x, z))
    return out


def place_stray_child(craw: str, cp: str, at: tuple[float, float], size: tuple[float, float], *,
                      world: tuple[dict, dict], cat: Catalog, new_id: Callable[[str], str],
                      rep: Report) -> Optional[Furniture]:
    """Where a child more than ``CHILD_SLACK`` off its parent goes (``craw``: its file id, ``cp``: its
    JSON path, ``at``: its (x, z), ``size``: its box's x, z extents [m]; ``world``: the house's (furniture,
    rooms)): the nearest supporting surface within ``CHILD_SURFACE_BOUND``, else a new floor patch under it
    (added to the furniture, its id from ``new_id``), else nowhere (None: dropped). One report line per
    outcome, items by JSON path."""
    furniture, rooms = world
    far = f"child more than {CHILD_SLACK} m off its parent"
    s = supporting_surface(furniture, cat, *at)
    if s is not None:
        rep.add(f"{far}: put on the nearest surface within {CHILD_SURFACE_BOUND} m", f"{cp} ({craw} -> {s.id})")
        return s
    patch = floor_patch(FLOOR_CATEGORY, rooms, furniture, at[0], at[1], size)
    if patch is not None:
        patch = dataclasses.replace(patch, id=new_id(FLOOR_CATEGORY))
        furniture[patch.id] = patch
        rep.add(f"{far} and more than {CHILD_SURFACE_BOUND} m from any surface: put on the floor "
                f"(a {FLOOR_CATEGORY!r} patch under it)", f"{cp} ({craw} -> {patch.id})")
        return patch
    rep.add(f"{far}, more than {CHILD_SURFACE_BOUND} m from any surface and over no free floor: dropped",
            f"{cp} ({craw})")
    return None


def supporting_surface(furniture: dict[str, Furniture], cat: Catalog, x: float, y: float,
                       bound: float = CHILD_SURFACE_BOUND) -> Optional[Furniture]:
    """The furniture with a top surface (its catalog category holds objects) nearest to (x, y), at
    most ``bound`` [m] from its footprint, or None; ties: lowest id."""
    near = [(footprint_distance(f.footprint, x, y), f.id) for f in furniture.values()
            if f.category in cat.furniture and cat.furniture[f.category].holds]
    near = [(d, fid) for d, fid in near if d <= bound]
    return furniture[min(near)[1]] if near else None


def floor_patch(fid: str, rooms: dict[str, Room], furniture: dict[str, Furniture], x: float, y: float,
                size: tuple[float, float]) -> Optional[Furniture]:
    """A thin ``floor`` furniture under a child at (x, y) with box ``size`` (x, y extents [m]), or None
    when the patch would leave its room or overlap another furniture."""
    sx, sy = size[0] + 2 * FLOOR_PATCH_MARGIN, size[1] + 2 * FLOOR_PATCH_MARGIN
    x0, y0, x1, y1 = _rect((x, y), (sx, sy))
    corners = ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
    room = next((rid for rid, r in sorted(rooms.items())
                 if all(point_in_polygon(r.polygon, *c) for c in corners)), None)
    if room is None or any(_overlap((x0, y0, x1, y1), f.footprint) > 0 for f in furniture.values()):
        return None
    return Furniture(fid, FLOOR_CATEGORY, room, (r4(x), r4(y)), (r4(sx), r4(sy), FLOOR_PATCH_HEIGHT),
                     "a patch of floor where an object lies")


def _overlap(a, b) -> float:
    """Shared area [m²] of two rectangles (x0, y0, x1, y1)."""
    return max(min(a[2], b[2]) - max(a[0], b[0]), 0.0) * max(min(a[3], b[3]) - max(a[1], b[1]), 0.0)


def mark_unreachable(scene: SceneGraph, robot_radius: float, resolution: float, rep: Report,
                     paths: dict[str, str]) -> list[str]:
    """Mark the furniture the robot cannot reach on the presumed grid (as ``validate_scene`` checks it)
    and the objects on it, in place, with the reason; one report line per reason, items by JSON path
    (``paths``: our id -> the file's JSON path). Unreachable rooms are left to validation. Returns the
    ids of the furniture marked."""
    grid = rasterize(scene, resolution, robot_radius, doors="presumed")
    reach = robot_radius + REACH_MARGIN
    marked = [x for x in unreachable(scene, grid, robot_radius) if x in scene.furniture]
    for fid in marked:
        f = scene.furniture[fid]
        under = sorted(g.id for g in scene.furniture.values()
                       if g.id != fid and _overlap(f.footprint, g.footprint) >= TUCKED_MIN_OVERLAP)
        why = (f"tucked under {under[0]!r}" if under else "boxed in") + \
            f": no free floor within {reach:g} m of it that joins the house (robot radius {robot_radius:g} m)"
        scene.furniture[fid] = dataclasses.replace(f, unreachable=why)
        kind = "tucked under other furniture" if under else "boxed in by walls or furniture"
        rep.add(f"unreachable furniture ({kind}): kept, marked unreachable, left out of missions",
                f"{paths.get(fid, fid)} ({fid})")
        for o in sorted(scene.objects_on(fid), key=lambda o: o.id):
            scene.objects[o.id] = dataclasses.replace(o, unreachable=f"on unreachable {fid!r}")
            rep.add("object on unreachable furniture: kept, marked unreachable, left out of missions",
                    f"{paths.get(o.id, o.id)} ({o.id})")
    return marked


def hosting_problems(scene: SceneGraph, cat: Catalog, n_objects: int) -> list[str]:
    """Why each command of the catalog cannot be hosted (empty when one can): its target furniture
    missing or unreachable, or fewer than ``n_objects`` reachable objects of its categories."""
    out = []
    for c in cat.commands:
        if c.resolve_targets(scene) and len(c.valid_objects(scene)) >= n_objects:
            return []
        room = f" in a {c.target_room_type}" if c.target_room_type else ""
        targets = [f for f in scene.furniture.values() if f.category in c.target_furniture
                   and (c.target_room_type is None or scene.rooms[f.room].type == c.target_room_type)]
        if not targets:
            out.append(f"{c.id}: no {'/'.join(c.target_furniture)}{room} (missing)")
            continue
        if not c.resolve_targets(scene):
            out.append(f"{c.id}: every {'/'.join(c.target_furniture)}{room} is unreachable "
                       f"({', '.join(sorted(f.id for f in targets))})")
            continue
        have = [o for o in scene.objects.values() if o.category in c.categories]
        far = sum(bool(o.unreachable) for o in have)
        out.append(f"{c.id}: {len(c.valid_objects(scene))} reachable object(s) of {'/'.join(c.categories)}, "
                   f"needs {n_objects} ({far} unreachable)")
    return out


def warn_unhostable(scene: SceneGraph, cat: Catalog, n_objects: int, generated: Sequence[str], rep: Report) -> None:
    """Report a house none of whose catalog commands can be hosted with ``n_objects`` reachable objects:
    one report line per command saying what it lacks, and the commands generated from what the house
    holds (``open_commands``) that its missions draw instead. Only a house with neither gets a warning
    (it is imported all the same; the scenes stage will find no command for it)."""
    problems = hosting_problems(scene, cat, n_objects)
    if not problems:
        return
    for p in problems:
        rep.add(f"catalog command without {n_objects} reachable objects or a target: missions draw the "
                f"commands generated from what the house holds", p)
    for text in generated:
        rep.add("command generated from what the house holds (mission.commands=auto or open)", text)
    if not generated:
        rep.warn(f"no command can be hosted: none of the catalog's with {n_objects} reachable objects "
                 f"({'; '.join(problems)}), nor any generated from what the house holds (no reachable furniture "
                 f"that holds a reachable object of another): no mission can be drawn in this house, and the "
                 f"scenes stage will say so; add objects on reachable furniture, or free the floor around the "
                 f"unreachable ones")
