"""Small houses in ProcTHOR's format (schema 1.0.0, as allenai/procthor writes it), built in the tests.

Rooms are axis-aligned rectangles in the x-z plane; every room lists its own walls (a wall shared
by two rooms appears once per room) and each outer wall has a ``wall|exterior|...`` copy, as
ProcTHOR writes them.
"""

from __future__ import annotations


def rect(x0: float, z0: float, x1: float, z1: float) -> list[dict]:
    return [{"x": x0, "y": 0, "z": z0}, {"x": x1, "y": 0, "z": z0}, {"x": x1, "y": 0, "z": z1},
            {"x": x0, "y": 0, "z": z1}]


def wall_id(room: int | str, a, b) -> str:
    return f"wall|{room}|{min(a[0], b[0]):.2f}|{min(a[1], b[1]):.2f}|{max(a[0], b[0]):.2f}|{max(a[1], b[1]):.2f}"


def wall(room: int | str, a, b, empty: bool = False) -> dict:
    w = {"id": wall_id(room, a, b), "roomId": f"room|{room}" if room != "exterior" else "exterior",
         "polygon": [{"x": a[0], "y": 0, "z": a[1]}, {"x": b[0], "y": 0, "z": b[1]},
                     {"x": a[0], "y": 2.5, "z": a[1]}, {"x": b[0], "y": 2.5, "z": b[1]}],
         "material": {"name": "PureWhite"}}
    if empty:
        w["empty"] = True
    return w


def room_walls(room: int, x0, z0, x1, z1, outer: set[str], empty: set[str] = frozenset()) -> list[dict]:
    """The four walls of a rectangular room (sides "S", "E", "N", "W"), plus an exterior copy of
    each side in ``outer``; sides in ``empty`` are ProcTHOR's open connections."""
    sides = {"S": ((x0, z0), (x1, z0)), "E": ((x1, z0), (x1, z1)), "N": ((x1, z1), (x0, z1)),
             "W": ((x0, z1), (x0, z0))}
    out = [wall(room, a, b, empty=s in empty) for s, (a, b) in sides.items()]
    out += [wall("exterior", b, a) for s, (a, b) in sides.items() if s in outer]
    return out


def door(r0: int, r1: int, wall0: str, wall1: str, lo: float, hi: float, openness: float | None = 1.0) -> dict:
    d = {"id": f"door|{min(r0, r1)}|{max(r0, r1)}", "assetId": "Doorway_1", "room0": f"room|{r0}",
         "room1": f"room|{r1}", "wall0": wall0, "wall1": wall1,
         "holePolygon": [{"x": lo, "y": 0, "z": 0}, {"x": hi, "y": 2.1, "z": 0}],
         "assetPosition": {"x": (lo + hi) / 2, "y": 1.05, "z": 0}}
    if openness is not None:
        d.update(openable=True, openness=openness)
    return d


def obj(type_name: str, room: int, n: int, x: float, z: float, y: float = 0.4, rot: float = 0.0,
        children: list | None = None, asset: str | None = None) -> dict:
    o = {"id": f"{type_name}|{room}|{n}", "assetId": asset or f"{type_name}_1", "position": {"x": x, "y": y, "z": z},
         "rotation": {"x": 0, "y": rot, "z": 0}, "kinematic": True, "layer": "Procedural0"}
    if children:
        o["children"] = children
    return o


def child(type_name: str, room: int, n: int, x: float, z: float, y: float = 0.8) -> dict:
    return {"id": f"{type_name}|surface|{room}|{n}", "assetId": f"{type_name}_1",
            "position": {"x": x, "y": y, "z": z}, "rotation": {"x": 0, "y": 0, "z": 0}, "kinematic": False,
            "layer": "Procedural0"}


def paper_house() -> dict:
    """A 4-room house that hosts the paper's mission: kitchen [0,5]x[0,4] and living room [5,10]x[0,4]
    joined by an empty wall (open plan); bedroom [0,5]x[4,8] and bathroom [5,10]x[4,8]; doors
    kitchen-bedroom and living-bathroom; an exterior door in the kitchen; a window; a painting."""
    k, lv, bd, ba = 2, 3, 4, 5
    walls = (room_walls(k, 0, 0, 5, 4, {"S", "W"}, {"E"}) + room_walls(lv, 5, 0, 10, 4, {"S", "E"}, {"W"})
             + room_walls(bd, 0, 4, 5, 8, {"N", "W"}) + room_walls(ba, 5, 4, 10, 8, {"N", "E"}))
    kb = wall_id(k, (5, 4), (0, 4))  # kitchen N = bedroom S
    lb = wall_id(lv, (10, 4), (5, 4))
    doors = [door(k, bd, kb, wall_id(bd, (0, 4), (5, 4)), 1.0, 2.0),
             door(lv, ba, lb, wall_id(ba, (5, 4), (10, 4)), 2.5, 3.5),
             door(k, k, wall_id(k, (0, 0), (5, 0)), "wall|exterior|0.00|0.00|5.00|0.00", 3.0, 4.0, None)]
    doors[2]["id"] = "door|1|2"
    objects = [
        obj("CounterTop", k, 0, 2.5, 0.4, children=[child("Apple", k, 1, 1.9, 0.3), child("Bread", k, 2, 2.5, 0.35),
                                                   child("Egg", k, 3, 3.1, 0.4), child("Pen", k, 4, 3.4, 0.3)]),
        obj("Fridge", k, 1, 4.5, 0.45),
        obj("DiningTable", lv, 0, 7.0, 2.0, children=[child("Newspaper", lv, 1, 6.8, 2.1),
                                                     child("CellPhone", lv, 2, 7.4, 1.9)]),
        obj("Sofa", lv, 1, 7.0, 0.5),
        obj("CoffeeTable", lv, 2, 9.3, 2.8, rot=90, children=[child("Book", lv, 3, 9.3, 2.6),
                                                             child("Laptop", lv, 4, 9.3, 3.1)]),
        obj("Painting", lv, 5, 9.9, 1.5, y=1.6, rot=270, asset="Wall_Decor_Painting_6"),
        obj("Bed", bd, 0, 1.2, 6.8, rot=90),
        obj("Desk", bd, 1, 4.3, 7.55, children=[child("RemoteControl", bd, 1, 4.3, 7.6)]),
        obj("ShelvingUnit", bd, 2, 4.7, 5.0, rot=270, children=[child("Book", bd, 4, 4.75, 4.8, 1.2),
                                                               child("Magazine", bd, 5, 4.75, 5.2, 1.2)]),
        obj("Toilet", ba, 0, 9.6, 7.5),
        obj("Sink", ba, 1, 7.0, 7.7, children=[child("SoapBottle", ba, 1, 7.0, 7.7, 0.9)]),
        obj("SideTable", ba, 2, 9.7, 4.6, children=[child("Glasses", ba, 4, 9.65, 4.55, 0.6)]),
    ]
    return {"id": "paper_house", "metadata": {"schema": "1.0.0"},
            "rooms": [{"id": f"room|{r}", "roomType": t, "floorPolygon": rect(*b), "children": [], "ceilings": []}
                      for r, t, b in ((k, "Kitchen", (0, 0, 5, 4)), (lv, "LivingRoom", (5, 0, 10, 4)),
                                      (bd, "Bedroom", (0, 4, 5, 8)), (ba, "Bathroom", (5, 4, 10, 8)))],
            "walls": walls, "doors": doors,
            "windows": [{"id": "window|3|0", "assetId": "Window_Hung_36x32", "room0": "room|3", "room1": "room|3",
                         "wall0": wall_id(lv, (10, 0), (10, 4)), "wall1": "wall|exterior|10.00|0.00|10.00|4.00",
                         "holePolygon": [{"x": 1.0, "y": 0.9, "z": 0}, {"x": 2.0, "y": 1.8, "z": 0}]}],
            "objects": objects}
