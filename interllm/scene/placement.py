"""Where on its furniture an object sits, measured from the scene's geometry: the part of the
paper's semantic attributes A^s = {location, category, usage} that says *location* — the furniture
instance and the position on it — in numbers a cost-inference prompt can carry.

``placement_of(scene, object_id)`` gives, in metres:
- ``height``: of the surface the object stands on (the bottom of its box) above the floor;
- ``depth``: from the object's centre to the nearest *open* side of the footprint — a side that
  faces free floor (not the room's wall, ``geometry.free_edges``) with no other furniture within
  ``SIDE_CLEARANCE`` of it; the side a robot could stand at. With no open side, the nearest side;
- ``clearance``: the gap to the nearest other object on the same furniture (None when alone);
- ``size``: the object's largest extent.

``placement_text`` renders them as words and numbers ("0.45 m in from the open side, at 0.75 m,
0.05 m from the next object, 8 cm across").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Optional

from interllm.scene.geometry import edge_distances, free_edges, rect_gap
from interllm.scene.graph import SceneGraph

SIDE_CLEARANCE = 0.6  # [m] another furniture closer than this to a side closes it (about a robot's width)
DEEP = 0.35  # [m] depth beyond which the text says "at the back"
HIGH = 1.2  # [m] surface height above which the text says "high up"
LOW = 0.35  # [m] surface height below which the text says "low"
CROWDED = 0.06  # [m] clearance below which the text says "between other objects"


@dataclass(frozen=True)
class Placement:
    """An object's place on its furniture (module doc); lengths in metres, rounded to 1 cm."""

    furniture: str
    height: float
    depth: Optional[float]  # None: a surface, no object on it yet (an unknown place action)
    open_sides: tuple[str, ...]  # of "S", "N", "W", "E"
    clearance: Optional[float]
    size: Optional[float]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["open_sides"] = list(self.open_sides)
        return d


def open_sides(scene: SceneGraph, furniture_id: str) -> tuple[str, ...]:
    """Sides of a footprint facing free floor: not against the wall, no furniture within SIDE_CLEARANCE."""
    f = scene.furniture[furniture_id]
    x0, y0, x1, y1 = f.footprint
    c = SIDE_CLEARANCE
    strips = {"S": (x0, y0 - c, x1, y0), "N": (x0, y1, x1, y1 + c), "W": (x0 - c, y0, x0, y1),
              "E": (x1, y0, x1 + c, y1)}
    others = [g.footprint for g in scene.furniture.values() if g.id != furniture_id]
    return tuple(s for s in free_edges(scene, f)
                 if all(rect_gap(strips[s], fp) > 1e-9 for fp in others))


def _box(o) -> tuple[float, float, float, float]:
    x, y = o.position[0], o.position[1]
    return (x - o.size[0] / 2, y - o.size[1] / 2, x + o.size[0] / 2, y + o.size[1] / 2)


def placement_of(scene: SceneGraph, object_id: str) -> Placement:
    """The placement attributes of an object where it is now (module doc)."""
    o = scene.objects[object_id]
    f = scene.furniture[o.furniture]
    sides = open_sides(scene, f.id)
    dist = edge_distances(f, o.position[0], o.position[1])
    depth = min(dist[s] for s in sides) if sides else min(dist.values())
    gaps = [rect_gap(_box(o), _box(p)) for p in scene.objects_on(f.id) if p.id != object_id]
    return Placement(f.id, round(o.position[2] - o.size[2] / 2, 2), round(max(depth, 0.0), 2), sides,
                     round(min(gaps), 2) if gaps else None, round(max(o.size), 2))


def surface_placement(scene: SceneGraph, furniture_id: str) -> Placement:
    """A furniture's top surface as a place to put something: its height and open sides."""
    f = scene.furniture[furniture_id]
    return Placement(f.id, round(f.surface_height, 2), None, open_sides(scene, f.id), None, None)


def placement_text(p: Placement) -> str:
    """The attributes as the prompts show them: words where a threshold says so, then numbers."""
    if p.depth is None:
        sides = "no open side" if not p.open_sides else f"{len(p.open_sides)} open side" + \
            ("s" if len(p.open_sides) > 1 else "")
        return f"surface at {p.height:.2f} m height, {sides}"
    words = []
    if p.depth > DEEP:
        words.append("at the back")
    if p.height > HIGH:
        words.append("high up")
    elif p.height < LOW:
        words.append("low")
    if p.clearance is not None and p.clearance < CROWDED:
        words.append("between other objects")
    side = "the open side" if p.open_sides else "the nearest side (no open side)"
    nums = [f"{p.depth:.2f} m in from {side}", f"at {p.height:.2f} m height"]
    if p.clearance is not None:
        nums.append(f"{p.clearance:.2f} m from the next object")
    if p.size is not None:
        nums.append(f"{round(p.size * 100):d} cm across")
    return ", ".join(words + nums)
