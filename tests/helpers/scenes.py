"""Small hand-built houses shared by the simulator, planner and recording tests.

``house``: rooms A [0,4]x[0,4] and B [4,8]x[0,4] [m]; the wall x = 4 has door_a (y in [0.5, 1.5])
and door_b (y in [2.5, 3.5]); a counter in A, a sofa and a wide table (1.4 x 1.0, top at 0.75 m) in
B. ``kitchen``: one 4 x 3 m room with a deep counter (0.8 m, top at 0.9 m) against the north wall.
"""

from __future__ import annotations

from interllm.core.actions import Action
from interllm.scene.graph import Door, Furniture, Mission, Room, SceneGraph, SceneObject, Wall

# Room A [0,4]x[0,4] and room B [4,8]x[0,4]; the wall x = 4 has door_a (y in [0.5, 1.5]) and
# door_b (y in [2.5, 3.5]). Grid cell centres are at -0.475 + 0.05 k.
START = (1.525, 0.875, 0.0)

# The v1 robot (sim/robot=generic) that the simulator's mechanics tests were written for: their
# distances, collision counts and reach figures are worked out for its 0.25 / 0.30 m base and its
# fixed 0.8 m shoulder. The robots themselves are tested in tests/test_robots.py.
GENERIC = {"robot": "generic", "robot_radius": 0.25, "footprint_radius": 0.3}


def house(open_a: float = 1.0, open_b: float = 1.0) -> SceneGraph:
    sg = SceneGraph(id="two_rooms", seed=0)
    sg.rooms["room_a"] = Room("room_a", "kitchen", ((0, 0), (4, 0), (4, 4), (0, 4)))
    sg.rooms["room_b"] = Room("room_b", "living_room", ((4, 0), (8, 0), (8, 4), (4, 4)))
    walls = [((0, 0), (8, 0)), ((0, 4), (8, 4)), ((0, 0), (0, 4)), ((8, 0), (8, 4)),
             ((4, 0), (4, 0.5)), ((4, 1.5), (4, 2.5)), ((4, 3.5), (4, 4))]
    for i, (a, b) in enumerate(walls):
        sg.walls[f"wall_{i}"] = Wall(f"wall_{i}", a, b, 0.1, 2.5)
    sg.doors["door_a"] = Door("door_a", ("room_a", "room_b"), (4, 1.0), "y", 1.0, open_fraction=open_a)
    sg.doors["door_b"] = Door("door_b", ("room_a", "room_b"), (4, 3.0), "y", 1.0, open_fraction=open_b)
    sg.furniture["counter_1"] = Furniture("counter_1", "counter", "room_a", (0.5, 1.0), (0.6, 1.2, 0.9))
    sg.furniture["sofa_1"] = Furniture("sofa_1", "sofa", "room_b", (6.0, 0.35), (1.2, 0.5, 0.45))
    # a wide table: 1.4 x 1.0, top at 0.75 m
    sg.furniture["table_1"] = Furniture("table_1", "dining_table", "room_b", (6.3, 2.3), (1.4, 1.0, 0.75))
    # front: 0.1 m from the south edge; deep: the middle, 0.5 m from every edge
    sg.objects["cup_1"] = SceneObject("cup_1", "cup", "table_1", (6.3, 1.9, 0.8), (0.08, 0.08, 0.1))
    sg.objects["apple_1"] = SceneObject("apple_1", "apple", "table_1", (6.3, 2.3, 0.79), (0.08, 0.08, 0.08),
                                        placement="deep")
    return sg


def mission() -> Mission:
    return Mission("m0", "two_rooms", START, "counter_1", ())


def nav(fid: str, room: str) -> Action:
    return Action("navigate", fid, room=room)


FRONT = (2.0, 2.25)  # a mug 0.1 m behind the counter's front edge (y = 2.15)


BACK = (2.0, 2.85)  # a mug 0.7 m behind it, against the wall


def kitchen() -> SceneGraph:
    """One 4 x 3 m room; a deep counter (0.8 m, top at 0.9 m) against the north wall."""
    sg = SceneGraph(id="kitchen", seed=0)
    sg.rooms["k"] = Room("k", "kitchen", ((0, 0), (4, 0), (4, 3), (0, 3)))
    for i, (a, b) in enumerate([((0, 0), (4, 0)), ((4, 0), (4, 3)), ((4, 3), (0, 3)), ((0, 3), (0, 0))]):
        sg.walls[f"wall_{i}"] = Wall(f"wall_{i}", a, b, 0.1, 2.5)
    sg.furniture["counter_1"] = Furniture("counter_1", "counter", "k", (2.0, 2.55), (1.2, 0.8, 0.9))
    sg.objects["mug_front"] = SceneObject("mug_front", "mug", "counter_1", (*FRONT, 0.95), (0.08, 0.08, 0.1))
    sg.objects["mug_back"] = SceneObject("mug_back", "mug", "counter_1", (*BACK, 0.95), (0.08, 0.08, 0.1))
    return sg
