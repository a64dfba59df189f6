"""Hallway floor plans (scene.layout=hallway): walls, shared edges, and the houses they make."""

from dataclasses import replace

import numpy as np
import pytest

from interllm.scene.catalog import load_catalog
from interllm.scene.floor_plans import HALLWAY, hallway_rects, plan_walls, shared_edges
from interllm.scene.generator import generate_scene
from interllm.scene.grid import free_components, largest_component, rasterize
from interllm.scene.reachability import unreachable


def test_walls_of_two_rooms_and_a_door_worked_by_hand():
    # room A [0,4]x[0,3], room B [4,6]x[0,2]: they share x = 4 for y in [0, 2]; a 0.8 m door at y = 1
    rects = [(0.0, 0.0, 4.0, 3.0), (4.0, 0.0, 6.0, 2.0)]
    (edge,) = shared_edges(rects, min_length=1.0)
    assert (edge.a, edge.b, edge.axis, edge.fixed, edge.lo, edge.hi) == (0, 1, "y", 4.0, 0.0, 2.0)
    walls = sorted(plan_walls(rects, [("y", 4.0, 1.0, 0.8)]))
    assert walls == sorted([
        ((0.0, 0.0), (6.0, 0.0)),  # y = 0: the two bottoms merged into one line
        ((0.0, 3.0), (4.0, 3.0)), ((4.0, 2.0), (6.0, 2.0)),  # the tops
        ((0.0, 0.0), (0.0, 3.0)), ((6.0, 0.0), (6.0, 2.0)),  # the outer sides
        ((4.0, 0.0), (4.0, 0.6)), ((4.0, 1.4), (4.0, 3.0)),  # x = 4 cut by the door [0.6, 1.4]
    ])
    assert shared_edges(rects, min_length=2.5) == []  # too short for a 2.5 m door


def test_hallway_rects_tile_a_rectangle_with_rooms_of_different_sizes():
    rng = np.random.default_rng(0)
    plan = hallway_rects(9, rng, 3.0, 5.0)
    halls = [r for h, r in plan if h]
    rooms = [r for h, r in plan if not h]
    assert len(halls) == 1 and len(rooms) == 9
    area = sum((r[2] - r[0]) * (r[3] - r[1]) for _, r in plan)
    x1, y1 = max(r[2] for _, r in plan), max(r[3] for _, r in plan)
    assert area == pytest.approx(x1 * y1, rel=1e-3)  # no gaps, no overlaps
    widths = {round(r[2] - r[0], 2) for r in rooms}
    aspects = {round((r[2] - r[0]) / (r[3] - r[1]), 2) for r in rooms}
    assert len(widths) >= 5 and len(aspects) >= 5  # not a grid of equal cells
    h = halls[0]
    assert 1.1 <= h[3] - h[1] <= 1.6 and h[2] - h[0] == pytest.approx(x1)  # spans the house


@pytest.fixture(scope="module")
def hallway_house():
    cat = load_catalog()
    cfg = replace(cat.scene_config("paper"), layout="hallway", door_width_min=0.8, door_width=1.0)
    return cfg, generate_scene(cfg, 0)


def test_a_hallway_house_is_connected_with_doors_of_several_widths(hallway_house):
    cfg, scene = hallway_house
    halls = [r for r in scene.rooms.values() if r.type == HALLWAY]
    assert len(halls) == 1 and len(scene.rooms) == cfg.n_rooms + 1
    assert not [f for f in scene.furniture.values() if f.room == halls[0].id]  # hallways stay clear
    onto_hall = [d for d in scene.doors.values() if halls[0].id in d.rooms]
    assert len(onto_hall) >= cfg.n_rooms // 2  # most rooms open onto the hallway
    normal = [d.width for d in scene.doors.values() if d.open_fraction == 1.0 and d.width > cfg.narrow_door_width]
    assert all(cfg.door_width_min <= w <= cfg.door_width for w in normal) and len(set(normal)) >= 5
    for doors in ("presumed", "true"):
        grid = rasterize(scene, cfg.grid_resolution, 0.25, doors=doors)
        labels, _ = free_components(grid, 8)
        main = largest_component(labels)
        for r in scene.rooms.values():  # every room has floor in the one region the robot drives in
            x0, y0, x1, y1 = r.bounds
            (r0, c0), (r1, c1) = grid.world_to_cell((x0, y0)), grid.world_to_cell((x1, y1))
            assert (labels[r0:r1, c0:c1] == main).any(), (doors, r.id)
        assert unreachable(scene, grid, 0.25) == []


def test_hallway_layout_is_deterministic(hallway_house):
    cfg, scene = hallway_house
    assert generate_scene(cfg, 0).to_json() == scene.to_json()
    assert generate_scene(cfg, 1).to_json() != scene.to_json()
