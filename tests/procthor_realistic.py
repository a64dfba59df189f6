"""Seeded ProcTHOR-format test houses laid out the way published ProcTHOR houses are furnished.

``realistic_house(seed)``: four rooms (kitchen open to the living room, a bedroom, a bathroom), with
what makes real houses hard for a mobile manipulator:

- an L of kitchen counters along two walls (two ``CounterTop`` objects meeting in the corner), 0.65 m
  deep, their objects spread over the whole top (front to back);
- a fridge in a corner with objects *inside* it (below its top; the robot does not open doors);
- a dining table in the middle of the living room ringed by six chairs tucked 0.1 m under its edges
  (two on each long side, one at each end), its objects spread over the whole top;
- a bed with its head against the bedroom wall and a dresser and a desk (with its chair) against walls;
- a TV stand against a wall, a sofa and a coffee table; a sink, a toilet and a side table.

Every furniture has its ``axisAlignedBoundingBox`` as ProcTHOR writes it; every object a real ``assetId`` of
ProcTHOR's asset database (``_asset``), which sizes it on import. The seed jitters the room
sizes and the objects' spots. ``OPEN_SURFACE`` names the objects on open surfaces (all but the
fridge's).
"""

from __future__ import annotations

import numpy as np
from procthor_houses import door, rect, room_walls, wall_id

from interllm.scene.procthor_db import load_database

K, LV, BD, BA = 2, 3, 4, 5  # ProcTHOR room ids (room|2, ...)
INSIDE = ("Egg", "Lettuce")  # types put inside the fridge


def _furniture(type_name: str, room: int, n: int, centre: tuple[float, float], size: tuple[float, float, float],
               kids: list | None = None, rot: float = 0.0) -> dict:
    """A furniture at ``centre`` (x, z) [m] with its box ``size`` (x, y, z) [m] in the world frame."""
    x, z = (round(v, 3) for v in centre)
    o = {"id": f"{type_name}|{room}|{n}", "assetId": f"{type_name}_1", "position": {"x": x, "y": size[1] / 2, "z": z},
         "rotation": {"x": 0, "y": rot, "z": 0}, "kinematic": True, "layer": "Procedural0",
         "axisAlignedBoundingBox": {"center": {"x": x, "y": size[1] / 2, "z": z},
                                    "size": {"x": size[0], "y": size[1], "z": size[2]}}}
    if kids:
        o["children"] = kids
    return o


def _asset(type_name: str) -> str:
    """A real asset id of ``type_name`` in ProcTHOR's asset database (its first CanPickup one, by id), so
    the importer sizes the object by it; ``<type>_1`` for a type the database lacks (Magazine)."""
    assets = [a for a in load_database().assets.values() if a.object_type == type_name]
    pick = sorted(a.id for a in assets if a.pickupable) or sorted(a.id for a in assets)
    return pick[0] if pick else f"{type_name}_1"


def _spread(rng: np.random.Generator, types: tuple[str, ...], room: int, first: int, box, y: float) -> list[dict]:
    """Children of ``types`` at seeded spots over the whole top ``box`` (x0, z0, x1, z1) [m], 0.06 m
    inside its edges, resting at height ``y`` [m]."""
    x0, z0, x1, z1 = box
    out = []
    for k, t in enumerate(types):
        x, z = rng.uniform(x0 + 0.06, x1 - 0.06), rng.uniform(z0 + 0.06, z1 - 0.06)
        out.append({"id": f"{t}|surface|{room}|{first + k}", "assetId": _asset(t),
                    "position": {"x": round(float(x), 3), "y": y, "z": round(float(z), 3)},
                    "rotation": {"x": 0, "y": 0, "z": 0}, "kinematic": False, "layer": "Procedural0"})
    return out


def _kitchen(w1: float, d1: float, rng: np.random.Generator) -> list[dict]:
    south = (0.3, 0.0, 2.9, 0.65)  # counter along the south wall, from the corner's west counter
    west = (0.0, 0.65, 0.65, min(2.55, d1 - 0.9))  # counter along the west wall
    fridge = _furniture("Fridge", K, 2, (w1 - 0.5, 0.38), (0.8, 1.8, 0.75))
    fridge["children"] = [{"id": f"{t}|surface|{K}|{20 + k}", "assetId": _asset(t),
                           "position": {"x": round(w1 - 0.5, 3), "y": 0.5 + 0.5 * k, "z": 0.35},
                           "rotation": {"x": 0, "y": 0, "z": 0}, "kinematic": False, "layer": "Procedural0"}
                          for k, t in enumerate(INSIDE)]
    return [_furniture("CounterTop", K, 0, ((south[0] + south[2]) / 2, 0.325), (2.6, 0.9, 0.65),
                       _spread(rng, ("Apple", "Bread", "Mug", "Kettle", "Tomato"), K, 1, south, 0.95)),
            _furniture("CounterTop", K, 1, (0.325, (west[1] + west[3]) / 2), (0.65, 0.9, west[3] - west[1]),
                       _spread(rng, ("Bowl", "Plate", "Pot"), K, 6, west, 0.95)),
            fridge]


def _dining(w1: float, w2: float, d1: float, rng: np.random.Generator) -> list[dict]:
    tx, tz = w1 + w2 / 2, d1 / 2 + 0.3
    top = (tx - 0.9, tz - 0.5, tx + 0.9, tz + 0.5)
    out = [_furniture("DiningTable", LV, 0, (tx, tz), (1.8, 0.75, 1.0),
                      _spread(rng, ("Newspaper", "CellPhone", "Plate", "Cup", "Apple"), LV, 1, top, 0.8))]
    spots = [(tx + dx, tz + s * 0.6) for dx in (-0.45, 0.45) for s in (-1, 1)] + [(tx - 1.05, tz), (tx + 1.05, tz)]
    out += [_furniture("Chair", LV, 10 + k, spot, (0.45, 0.9, 0.45)) for k, spot in enumerate(spots)]
    return out


def _living(w1: float, w2: float, d1: float, rng: np.random.Generator) -> list[dict]:
    e = w1 + w2
    stand = (e - 0.5, 0.6, e, 2.0)
    return [_furniture("TVStand", LV, 20, (e - 0.25, 1.3), (0.5, 0.6, 1.4),
                       _spread(rng, ("Vase", "RemoteControl"), LV, 20, stand, 0.65)),
            _furniture("Sofa", LV, 21, (w1 + 1.2, d1 - 0.45), (2.0, 0.8, 0.9)),
            _furniture("CoffeeTable", LV, 22, (w1 + 1.2, d1 - 1.5), (1.0, 0.45, 0.5),
                       _spread(rng, ("Book", "Laptop"), LV, 22, (w1 + 0.7, d1 - 1.75, w1 + 1.7, d1 - 1.25), 0.5))]


def _bedroom(w1: float, d1: float, d2: float, rng: np.random.Generator) -> list[dict]:
    top = d1 + d2
    dresser = (w1 - 1.6, top - 0.5, w1 - 0.4, top)
    return [_furniture("Bed", BD, 0, (1.2, top - 1.0), (1.6, 0.6, 2.0),
                       _spread(rng, ("Pillow", "Book"), BD, 1, (0.4, top - 2.0, 2.0, top - 0.3), 0.65)),
            _furniture("Dresser", BD, 1, ((dresser[0] + dresser[2]) / 2, top - 0.25), (1.2, 0.9, 0.5),
                       _spread(rng, ("Watch", "Statue", "Magazine"), BD, 3, dresser, 0.95)),
            _furniture("Desk", BD, 2, (w1 - 0.35, d1 + 1.0), (0.7, 0.75, 1.2),
                       _spread(rng, ("Laptop", "Pen"), BD, 6, (w1 - 0.7, d1 + 0.4, w1, d1 + 1.6), 0.8)),
            _furniture("Chair", BD, 3, (w1 - 0.9, d1 + 1.0), (0.45, 0.9, 0.45))]


def _bathroom(w1: float, w2: float, d1: float, d2: float, rng: np.random.Generator) -> list[dict]:
    top, e = d1 + d2, w1 + w2
    return [_furniture("Sink", BA, 0, (w1 + 1.5, top - 0.25), (0.8, 0.9, 0.5),
                       _spread(rng, ("SoapBottle",), BA, 1, (w1 + 1.1, top - 0.5, w1 + 1.9, top), 0.95)),
            _furniture("Toilet", BA, 1, (e - 0.4, top - 0.35), (0.45, 0.8, 0.7)),
            _furniture("SideTable", BA, 2, (e - 0.25, d1 + 0.6), (0.5, 0.6, 0.5),
                       _spread(rng, ("Towel",), BA, 2, (e - 0.5, d1 + 0.35, e, d1 + 0.85), 0.65))]


def realistic_house(seed: int) -> dict:
    """ProcTHOR-format house ``seed`` (schema 1.0.0): see the module docstring."""
    rng = np.random.default_rng([seed, 7])
    w1, w2, d1, d2 = (float(np.round(rng.uniform(lo, hi) * 20) / 20)
                      for lo, hi in ((4.5, 5.5), (5.5, 6.5), (4.6, 5.2), (3.8, 4.4)))
    e, top = w1 + w2, d1 + d2
    walls = (room_walls(K, 0, 0, w1, d1, {"S", "W"}, {"E"}) + room_walls(LV, w1, 0, e, d1, {"S", "E"}, {"W"})
             + room_walls(BD, 0, d1, w1, top, {"N", "W"}) + room_walls(BA, w1, d1, e, top, {"N", "E"}))
    doors = [door(K, BD, wall_id(K, (w1, d1), (0, d1)), wall_id(BD, (0, d1), (w1, d1)), 2.0, 3.0),
             door(LV, BA, wall_id(LV, (e, d1), (w1, d1)), wall_id(BA, (w1, d1), (e, d1)), w2 - 4.0, w2 - 3.0)]
    objects = (_kitchen(w1, d1, rng) + _dining(w1, w2, d1, rng) + _living(w1, w2, d1, rng)
               + _bedroom(w1, d1, d2, rng) + _bathroom(w1, w2, d1, d2, rng))
    rooms = ((K, "Kitchen", (0, 0, w1, d1)), (LV, "LivingRoom", (w1, 0, e, d1)), (BD, "Bedroom", (0, d1, w1, top)),
             (BA, "Bathroom", (w1, d1, e, top)))
    return {"id": f"realistic_house_{seed:02d}", "metadata": {"schema": "1.0.0"},
            "rooms": [{"id": f"room|{r}", "roomType": t, "floorPolygon": rect(*b), "children": [], "ceilings": []}
                      for r, t, b in rooms],
            "walls": walls, "doors": doors, "objects": objects}
