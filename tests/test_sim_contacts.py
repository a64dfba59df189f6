"""Navigation contacts of the true footprint (sim.footprint_radius) on tiny houses worked by hand.

Room A [0,3]x[0,3] and room B [6,9]x[0,3] are joined by a hallway [3,6] long whose walls (0.1 m
thick) leave a clear width w between their faces. The robot's map is inflated by
sim.robot_radius = 0.25 m, so the map calls the hallway passable whenever w > 0.5 m; the true
footprint (radius 0.30 m) needs w > 0.60 m.
"""


from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.scene.graph import Furniture, Mission, Room, SceneGraph, Wall
from interllm.sim.world import World

HALL_Y = 1.5  # [m] hallway centre line
START = (1.0, 1.5, 0.0)


def hallway_house(clear_width: float) -> SceneGraph:
    """Two rooms joined by a straight hallway whose wall faces are ``clear_width`` [m] apart."""
    t = 0.1
    lo, hi = HALL_Y - clear_width / 2 - t / 2, HALL_Y + clear_width / 2 + t / 2  # wall centre lines
    sg = SceneGraph(id="hallway", seed=0)
    sg.rooms["room_a"] = Room("room_a", "kitchen", ((0, 0), (3, 0), (3, 3), (0, 3)))
    sg.rooms["hall_1"] = Room("hall_1", "hallway", ((3, lo), (6, lo), (6, hi), (3, hi)))
    sg.rooms["room_b"] = Room("room_b", "living_room", ((6, 0), (9, 0), (9, 3), (6, 3)))
    walls = [((0, 0), (3, 0)), ((0, 3), (3, 3)), ((0, 0), (0, 3)), ((3, 0), (3, lo)), ((3, hi), (3, 3)),
             ((3, lo), (6, lo)), ((3, hi), (6, hi)),
             ((6, 0), (9, 0)), ((6, 3), (9, 3)), ((9, 0), (9, 3)), ((6, 0), (6, lo)), ((6, hi), (6, 3))]
    for i, (a, b) in enumerate(walls):
        sg.walls[f"wall_{i}"] = Wall(f"wall_{i}", a, b, t, 2.5)
    sg.furniture["counter_1"] = Furniture("counter_1", "counter", "room_a", (0.35, 1.5), (0.6, 1.2, 0.9))
    sg.furniture["sofa_1"] = Furniture("sofa_1", "sofa", "room_b", (8.65, 1.5), (0.6, 1.2, 0.45))
    return sg


def drive(clear_width: float, **sim) -> object:
    w = World(hallway_house(clear_width), SimConfig(max_nav_replans=3, **sim))
    w.reset(Mission("m0", "hallway", START, "counter_1", ()))
    return w.execute(Action("navigate", "sofa_1", room="room_b")), w


def test_a_hallway_narrower_than_the_footprint_collides():
    """0.60 m between the wall faces: the map (0.25 m) plans through it, the base touches a wall
    (the path runs on cell centres, 0.025 m off the centre line, so 0.30 + 0.025 > 0.30)."""
    r, _ = drive(0.60, footprint_radius=0.30)
    assert len(r.presumed_path) > 0 and r.presumed_path[:, 0].max() > 6.0  # planned through the hallway
    assert not r.success and r.collisions == 4  # max_nav_replans = 3: the fourth contact fails it
    assert "wall" in r.reason
    legacy, _ = drive(0.60, footprint_radius=None)  # the map's radius less half a cell diagonal
    assert legacy.success and legacy.collisions == 0


def test_a_hallway_wider_than_the_footprint_passes_in_its_middle():
    r, _ = drive(0.75, footprint_radius=0.30, clearance_cost=2.0)  # 0.075 m to spare each side
    assert r.success and r.collisions == 0
    hall = r.driven_path[(r.driven_path[:, 0] > 3.3) & (r.driven_path[:, 0] < 5.7)]
    assert len(hall) and abs(hall[:, 1] - HALL_Y).max() < 0.075  # within 0.075 m of the centre line


def test_a_base_put_against_a_wall_drives_away_without_a_collision():
    """Started touching room A's south wall (face at y = 0.05, centre 0.33 m from it with a 0.30 m
    footprint): what it stands against is no collision until it has come free of it."""
    w = World(hallway_house(0.75), SimConfig(footprint_radius=0.30, clearance_cost=2.0))
    w.reset(Mission("m0", "hallway", (1.0, 0.33, 0.0), "counter_1", ()))
    assert {(k, s) for _, _, k, s in w.physics.base_contacts()} == {("wall", "wall_0")}
    r = w.execute(Action("navigate", "sofa_1", room="room_b"))
    assert r.success and r.collisions == 0
