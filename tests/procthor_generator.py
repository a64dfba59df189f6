"""Seeded ProcTHOR-format test houses, untidy the way published ProcTHOR houses are.

``untidy_house(seed)`` lays out four rooms (kitchen and living room open to each other, a bedroom, a
bathroom) with the furniture the paper's mission needs, jittered by the seed, and ProcTHOR's habits:

- a dining table turned by 90° with chairs tucked under it, one wedged between the table and a wall
  (``unreachable_chair``: the robot cannot reach it);
- children near the table and counter edges, a little off them (nudged back on);
- wall-mounted items (a painting, a television) that are no floor obstacles;
- and, by the seed, a coffee table whose rotation disagrees with its children (``rotated_parent``), a
  child 0.6 to 0.9 m off its table (``stray_child``), a child lying on the floor far from any surface
  (``floor_child``) and one over a toilet, far from any surface (``dropped_child``).

``features(seed)`` says which of the optional ones a house has, so a test can count the repairs.
"""

from __future__ import annotations

import numpy as np
from procthor_houses import child, door, obj, rect, room_walls, wall_id

K, LV, BD, BA = 2, 3, 4, 5  # ProcTHOR room ids (room|2, ...)


def features(seed: int) -> dict[str, bool]:
    """Which untidy features house ``seed`` has (the tucked chairs and edge children are always there)."""
    rng = np.random.default_rng([seed, 1])
    draw = rng.random(5)
    return {"unreachable_chair": bool(draw[0] < 0.8), "rotated_parent": bool(draw[1] < 0.5),
            "stray_child": bool(draw[2] < 0.6), "floor_child": bool(draw[3] < 0.5),
            "dropped_child": bool(draw[4] < 0.4)}


def _dims(rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(kitchen width, living room width, south depth, north depth) [m], to 0.05 m."""
    return tuple(float(np.round(rng.uniform(lo, hi) * 20) / 20)  # type: ignore[return-value]
                 for lo, hi in ((4.5, 5.5), (5.5, 6.5), (4.2, 5.0), (3.6, 4.4)))


def _dining(w1: float, w2: float, d1: float, f: dict, rng: np.random.Generator) -> list[dict]:
    """The dining table (turned by 90°: 1.0 m along x, 1.8 m along z), 0.45 m from the living room's east
    wall, its chairs tucked 0.15 m under it, and its children near its edges."""
    tx, tz = round(w1 + w2 - 0.05 - 0.45 - 0.5, 2), round(d1 / 2 + 0.2, 2)
    kids = [child("Newspaper", LV, 1, round(tx - 0.45 + rng.uniform(-0.03, 0.03), 3), tz + 0.6),
            child("CellPhone", LV, 2, tx + 0.1, round(tz - 0.85 - rng.uniform(0.0, 0.05), 3)),
            child("Bowl", LV, 3, tx + 0.4, tz + 0.2)]
    if f["stray_child"]:  # ProcTHOR's untidy file: a plate 0.6 to 0.9 m west of the table's edge
        kids.append(child("Plate", LV, 4, round(tx - 0.5 - rng.uniform(0.6, 0.9), 3), tz))
    out = [obj("DiningTable", LV, 0, tx, tz, rot=90, children=kids)]
    out += [obj("Chair", LV, 10 + k, tx - 0.6, tz + dz, rot=90) for k, dz in enumerate((-0.45, 0.45))]
    if f["unreachable_chair"]:  # between the table and the wall: 0.1 m of floor behind it
        out.append(obj("Chair", LV, 12, tx + 0.6, tz, rot=270))
    return out


def _living(w1: float, w2: float, d1: float, f: dict, rng: np.random.Generator) -> list[dict]:
    """Sofa, coffee table (by the seed, a rotation its children disagree with), a painting and a
    television on the walls; by the seed a pillow on the kitchen floor, far from any surface."""
    cx, cz = round(w1 + 1.6 + rng.uniform(0, 0.4), 2), round(d1 - 1.3, 2)
    if f["rotated_parent"]:  # the file says 0°, but the table is turned: its children lie along z
        table = obj("CoffeeTable", LV, 2, cx, cz, rot=0, children=[child("Book", LV, 5, cx, cz - 0.45),
                                                                   child("Laptop", LV, 6, cx, cz + 0.45)])
    else:
        table = obj("CoffeeTable", LV, 2, cx, cz, rot=90, children=[child("Book", LV, 5, cx, cz - 0.2),
                                                                    child("Laptop", LV, 6, cx, cz + 0.3)])
    sofa = obj("Sofa", LV, 1, round(w1 + 2.2, 2), 0.5)
    sofa["axisAlignedBoundingBox"] = {"center": {"x": sofa["position"]["x"], "y": 0.4, "z": 0.5},
                                      "size": {"x": 2.0, "y": 0.45, "z": 0.9}}
    if f["floor_child"]:  # a pillow carried off the sofa, lying in the middle of the kitchen
        sofa["children"] = [child("Pillow", LV, 7, round(w1 / 2 + 0.3, 2), round(d1 / 2 + 0.2, 2), y=0.1)]
    return [sofa, table,
            obj("Painting", LV, 5, round(w1 + 1.0, 2), round(d1 - 0.05, 2), y=1.6, rot=180,
                asset="Wall_Decor_Painting_6"),
            obj("Television", LV, 6, round(w1 + 2.2, 2), 0.05, y=1.5, rot=0)]


def _kitchen(w1: float, rng: np.random.Generator) -> list[dict]:
    """A counter on the south wall with breakfast things near its front edge, and a fridge (with its
    bounding box, as ProcTHOR writes it) in the south-east corner."""
    x = round(w1 / 2 - 0.5, 2)
    edge = 0.4 + 0.325  # the counter's front edge (z)
    kids = [child(t, K, k, round(x - 0.8 + 0.4 * k, 3), round(edge - 0.05 + rng.uniform(-0.02, 0.04), 3), y=0.95)
            for k, t in enumerate(("Apple", "Bread", "Egg", "Mug", "Pen"))]
    fridge = obj("Fridge", K, 1, round(w1 - 0.5, 2), 0.45)
    fridge["axisAlignedBoundingBox"] = {"center": {"x": fridge["position"]["x"], "y": 0.9, "z": 0.45},
                                        "size": {"x": 0.8, "y": 1.8, "z": 0.75}}
    return [obj("CounterTop", K, 0, x, 0.4, children=kids), fridge]


def _bedroom(w1: float, d1: float, d2: float) -> list[dict]:
    """Bed, a desk on the north wall and a shelf on the east wall, with their children."""
    top = d1 + d2
    return [obj("Bed", BD, 0, 1.2, round(top - 1.2, 2), rot=90),
            obj("Desk", BD, 1, round(w1 - 1.0, 2), round(top - 0.45, 2),
                children=[child("RemoteControl", BD, 1, round(w1 - 1.0, 2), round(top - 0.4, 2))]),
            obj("ShelvingUnit", BD, 2, round(w1 - 0.3, 2), round(d1 + 1.6, 2), rot=270,
                children=[child("Book", BD, 4, round(w1 - 0.25, 2), round(d1 + 1.4, 2), 1.2),
                          child("Magazine", BD, 5, round(w1 - 0.25, 2), round(d1 + 1.8, 2), 1.2)])]


def _bathroom(w1: float, w2: float, d1: float, d2: float, f: dict) -> list[dict]:
    """Toilet, sink and side table; by the seed a toilet-paper roll lying over the toilet, far from any
    surface (it cannot go on the floor there)."""
    top, east = d1 + d2, w1 + w2
    sink_kids = [child("SoapBottle", BA, 1, round(w1 + 2.0, 2), round(top - 0.3, 2), 0.9)]
    toilet = (round(east - 0.4, 2), round(top - 0.5, 2))
    if f["dropped_child"]:
        sink_kids.append(child("ToiletPaper", BA, 2, *toilet, y=0.5))
    return [obj("Toilet", BA, 0, *toilet),
            obj("Sink", BA, 1, round(w1 + 2.0, 2), round(top - 0.3, 2), children=sink_kids),
            obj("SideTable", BA, 2, round(east - 0.3, 2), round(d1 + 0.6, 2),
                children=[child("Glasses", BA, 4, round(east - 0.35, 2), round(d1 + 0.55, 2), 0.6)])]


def untidy_house(seed: int) -> dict:
    """ProcTHOR-format house ``seed`` (schema 1.0.0): see the module docstring."""
    rng = np.random.default_rng([seed, 0])
    f = features(seed)
    w1, w2, d1, d2 = _dims(rng)
    e, top = w1 + w2, d1 + d2
    walls = (room_walls(K, 0, 0, w1, d1, {"S", "W"}, {"E"}) + room_walls(LV, w1, 0, e, d1, {"S", "E"}, {"W"})
             + room_walls(BD, 0, d1, w1, top, {"N", "W"}) + room_walls(BA, w1, d1, e, top, {"N", "E"}))
    kb = wall_id(K, (w1, d1), (0, d1))  # its polygon runs west from (w1, d1): the hole is 2.5 to 3.5 m along
    lb = wall_id(LV, (e, d1), (w1, d1))
    doors = [door(K, BD, kb, wall_id(BD, (0, d1), (w1, d1)), 2.5, 3.5),
             door(LV, BA, lb, wall_id(BA, (w1, d1), (e, d1)), w2 - 3.5, w2 - 2.5)]
    objects = (_kitchen(w1, rng) + _dining(w1, w2, d1, f, rng) + _living(w1, w2, d1, f, rng)
               + _bedroom(w1, d1, d2) + _bathroom(w1, w2, d1, d2, f))
    rooms = ((K, "Kitchen", (0, 0, w1, d1)), (LV, "LivingRoom", (w1, 0, e, d1)), (BD, "Bedroom", (0, d1, w1, top)),
             (BA, "Bathroom", (w1, d1, e, top)))
    return {"id": f"untidy_house_{seed:02d}", "metadata": {"schema": "1.0.0"},
            "rooms": [{"id": f"room|{r}", "roomType": t, "floorPolygon": rect(*b), "children": [], "ceilings": []}
                      for r, t, b in rooms],
            "walls": walls, "doors": doors, "objects": objects}
