"""Seeded ProcTHOR-format test houses laid out the way published ProcTHOR houses are furnished, with
ProcTHOR's own assets (its asset database, ``interllm.scene.procthor_db``).

``realistic_house(seed)``: four rooms (kitchen open to the living room, a bedroom, a bathroom), with
what makes real houses hard for a mobile manipulator:

- an L of kitchen counters along two walls (two ``Countertop_I_*`` assets meeting in the corner),
  their objects spread over the whole top (front to back);
- a fridge against a wall with objects *inside* it (below its top; the robot does not open doors);
- a dining table in the middle of the living room ringed by the chairs of ProcTHOR's asset group
  ``chair-diningtable-6`` (``asset_source.chair_spots``), its objects spread over the whole top;
- a bed with its head against the bedroom wall, a dresser against a wall, and a desk against a wall
  with its chair where the group ``desk-with-chair`` puts it;
- a TV stand against a wall, a sofa and a coffee table; a sink, a toilet and a side table.

Every furniture is an asset of its type drawn by the seed among those that fit its spot (``_piece``):
its ``assetId``, and its ``axisAlignedBoundingBox`` the asset's box turned by its ``rotation``, as
ProcTHOR writes them. Every object is a real ``assetId`` too (``_asset``), which sizes it on import.
The seed also jitters the room sizes and the objects' spots. ``INSIDE`` names the objects in the
fridge; all the others stand on open surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from procthor_houses import door, rect, room_walls, wall_id

from interllm.scene.asset_source import DESK_GROUP, chair_spots
from interllm.scene.procthor_db import load_database

K, LV, BD, BA = 2, 3, 4, 5  # ProcTHOR room ids (room|2, ...)
INSIDE = ("Egg", "Lettuce")  # types put inside the fridge
FACING = {"S": 0, "W": 90, "N": 180, "E": 270}  # rotation.y [deg] of a piece with its back to that wall
DINING_GROUP = "chair-diningtable-6"  # ProcTHOR's asset_groups/ file of the dining table and its chairs


@dataclass(frozen=True)
class Piece:
    """A furniture as the house file holds it, its top (x0, z0, x1, z1) [m] and its height [m]."""

    record: dict
    top: tuple[float, float, float, float]
    height: float


def _turned(size: tuple[float, float], rot: float) -> tuple[float, float]:
    """A footprint (x, depth) [m] in the world at rotation ``rot`` [deg] (a multiple of 90)."""
    return (size[1], size[0]) if round(rot) % 180 == 90 else (size[0], size[1])


def _rotate(offset: tuple[float, float], rot: float) -> tuple[float, float]:
    """An offset (x, z) [m] in a piece's frame, in the world at rotation ``rot`` [deg] (Unity's y-up,
    clockwise from above: the piece's front, +z, points to +x at 90)."""
    c, s = np.cos(np.radians(rot)), np.sin(np.radians(rot))
    return float(offset[0] * c + offset[1] * s), float(-offset[0] * s + offset[1] * c)


def _record(asset_id: str, oid: str, centre: tuple[float, float], size: tuple[float, float, float],
            rot: float) -> dict:
    """A kinematic furniture at ``centre`` (x, z) [m] with its world box ``size`` (x, y, z) [m]."""
    x, z = (round(float(v), 3) for v in centre)
    box = {"center": {"x": x, "y": size[1] / 2, "z": z}, "size": {"x": size[0], "y": size[1], "z": size[2]}}
    return {"id": oid, "assetId": asset_id, "position": {"x": x, "y": size[1] / 2, "z": z},
            "rotation": {"x": 0, "y": rot, "z": 0}, "kinematic": True, "layer": "Procedural0",
            "axisAlignedBoundingBox": box}


def _fitting(type_name: str, slot, rot: float, heights: tuple[float, float]) -> list:
    """The assets of ``type_name`` with a height within ``heights`` (lo, hi) [m] whose footprint at ``rot`` fits
    ``slot`` (x0, z0, x1, z1) [m]: the larger half by area (a spot is furnished, not dotted), or the
    smallest asset when none fits."""
    assets = [a for a in load_database().assets_of(type_name) if heights[0] <= a.size[2] <= heights[1]]
    w, d = slot[2] - slot[0], slot[3] - slot[1]
    fits = [a for a in assets if all(u <= v for u, v in zip(_turned(a.size[:2], rot), (w, d), strict=True))]
    fit = sorted(fits, key=lambda a: (a.size[0] * a.size[1], a.id))
    return fit[len(fit) // 2:] if fit else [min(assets, key=lambda a: (a.size[0] * a.size[1], a.id))]


def _piece(type_name: str, oid: str, slot, hug: str, rng: np.random.Generator,
           heights: tuple[float, float] = (0.3, 2.5)) -> Piece:
    """An asset of ``type_name`` drawn by ``rng`` among those that fit ``slot`` (x0, z0, x1, z1) [m]
    with a height within ``heights`` [m] (a floor sink, not a basin; a desk, not one with a hutch),
    pushed against the slot's sides named in ``hug`` ("S", "N", "W", "E"; none: centred) with its
    back to the first of them."""
    rot = float(FACING[hug[0]]) if hug else 0.0
    choices = _fitting(type_name, slot, rot, heights)
    asset = choices[int(rng.integers(len(choices)))]
    sx, sz = _turned(asset.size[:2], rot)
    x = slot[0] + sx / 2 if "W" in hug else slot[2] - sx / 2 if "E" in hug else (slot[0] + slot[2]) / 2
    z = slot[1] + sz / 2 if "S" in hug else slot[3] - sz / 2 if "N" in hug else (slot[1] + slot[3]) / 2
    sx, sz, h = round(sx, 4), round(sz, 4), round(asset.size[2], 4)
    record = _record(asset.id, oid, (x, z), (sx, h, sz), rot)
    x, z = record["position"]["x"], record["position"]["z"]
    return Piece(record, (x - sx / 2, z - sz / 2, x + sx / 2, z + sz / 2), h)


def _with(piece: Piece, rng: np.random.Generator, types: tuple[str, ...], room: int, first: int) -> dict:
    """The piece's record with children of ``types`` spread over its whole top."""
    return {**piece.record, "children": _spread(rng, types, room, first, piece.top, piece.height + 0.05)}


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
                    "position": {"x": round(float(x), 3), "y": round(y, 3), "z": round(float(z), 3)},
                    "rotation": {"x": 0, "y": 0, "z": 0}, "kinematic": False, "layer": "Procedural0"})
    return out


def _kitchen(w1: float, d1: float, rng: np.random.Generator) -> list[dict]:
    south = _piece("CounterTop", f"CounterTop|{K}|0", (0.0, 0.0, w1 - 1.2, 0.65), "SW", rng)
    west = _piece("CounterTop", f"CounterTop|{K}|1", (0.0, south.top[3], 0.65, d1 - 0.9), "WS", rng)
    fridge = _piece("Fridge", f"Fridge|{K}|2", (w1 - 1.15, 0.0, w1 - 0.05, 0.8), "S", rng, heights=(1.5, 2.5))
    fx, fz = fridge.record["position"]["x"], fridge.record["position"]["z"]
    inside = [{"id": f"{t}|surface|{K}|{20 + k}", "assetId": _asset(t),
               "position": {"x": fx, "y": 0.5 + 0.5 * k, "z": fz},
               "rotation": {"x": 0, "y": 0, "z": 0}, "kinematic": False, "layer": "Procedural0"}
              for k, t in enumerate(INSIDE)]
    return [_with(south, rng, ("Apple", "Bread", "Mug", "Kettle", "Tomato"), K, 1),
            _with(west, rng, ("Bowl", "Plate", "Pot"), K, 6), {**fridge.record, "children": inside}]


def _chairs(table: Piece, group: str, room: int, first: int, rng: np.random.Generator) -> list[dict]:
    """The chairs of asset group ``group`` around ``table`` (turned with it), as ``chair_spots`` lays
    them out, each facing the table as the group's member does."""
    rot = float(table.record["rotation"]["y"])
    sx, sz = table.top[2] - table.top[0], table.top[3] - table.top[1]
    db = load_database()
    members = db.groups[group][1:]
    tx, tz = table.record["position"]["x"], table.record["position"]["z"]
    out = []
    for k, (spot, member) in enumerate(zip(chair_spots(db, group, _turned((sx, sz), rot), rng), members, strict=True)):
        dx, dz = _rotate(spot.offset, rot)
        size = _turned(spot.size, rot)
        h = round(db.assets[spot.asset].size[2], 4)
        out.append(_record(spot.asset, f"Chair|{room}|{first + k}", (tx + dx, tz + dz),
                           (round(size[0], 4), h, round(size[1], 4)), (rot + member.yaw) % 360))
    return out


def _dining(w1: float, w2: float, d1: float, rng: np.random.Generator) -> list[dict]:
    tx, tz = w1 + w2 / 2, d1 / 2 + 0.3
    table = _piece("DiningTable", f"DiningTable|{LV}|0", (tx - 0.95, tz - 0.55, tx + 0.95, tz + 0.55), "", rng)
    return [_with(table, rng, ("Newspaper", "CellPhone", "Plate", "Cup", "Apple"), LV, 1),
            *_chairs(table, DINING_GROUP, LV, 10, rng)]


def _living(w1: float, w2: float, d1: float, rng: np.random.Generator) -> list[dict]:
    e = w1 + w2
    stand = _piece("TVStand", f"TVStand|{LV}|20", (e - 0.7, 0.4, e, 2.4), "E", rng)
    sofa = _piece("Sofa", f"Sofa|{LV}|21", (w1 + 0.1, d1 - 1.0, w1 + 2.4, d1), "N", rng)
    table = _piece("CoffeeTable", f"CoffeeTable|{LV}|22", (w1 + 0.6, d1 - 2.1, w1 + 1.9, d1 - 1.3), "", rng)
    return [_with(stand, rng, ("Vase", "RemoteControl"), LV, 20), sofa.record,
            _with(table, rng, ("Book", "Laptop"), LV, 22)]


def _bedroom(w1: float, d1: float, d2: float, rng: np.random.Generator) -> list[dict]:
    top = d1 + d2
    bed = _piece("Bed", f"Bed|{BD}|0", (0.2, top - 2.5, 2.4, top), "N", rng)
    dresser = _piece("Dresser", f"Dresser|{BD}|1", (w1 - 2.2, top - 0.8, w1 - 0.2, top), "N", rng, heights=(0.6, 1.2))
    desk = _piece("Desk", f"Desk|{BD}|2", (w1 - 0.8, d1 + 0.3, w1, d1 + 2.1), "E", rng, heights=(0.6, 0.9))
    return [_with(bed, rng, ("Pillow", "Book"), BD, 1), _with(dresser, rng, ("Watch", "Statue", "Magazine"), BD, 3),
            _with(desk, rng, ("Laptop", "Pen"), BD, 6), *_chairs(desk, DESK_GROUP, BD, 3, rng)]


def _bathroom(w1: float, w2: float, d1: float, d2: float, rng: np.random.Generator) -> list[dict]:
    top, e = d1 + d2, w1 + w2
    sink = _piece("Sink", f"Sink|{BA}|0", (w1 + 1.0, top - 0.8, w1 + 2.0, top), "N", rng, heights=(0.7, 1.2))
    toilet = _piece("Toilet", f"Toilet|{BA}|1", (e - 0.8, top - 1.1, e, top), "N", rng)
    side = _piece("SideTable", f"SideTable|{BA}|2", (e - 0.6, d1 + 0.3, e, d1 + 0.9), "E", rng, heights=(0.45, 0.9))
    return [_with(sink, rng, ("SoapBottle",), BA, 1), toilet.record, _with(side, rng, ("Towel",), BA, 2)]


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
