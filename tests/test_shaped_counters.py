"""Counters that are no box (interllm.scene.shaped_furniture): ProcTHOR's ``Countertop_L_8x6`` in a
kitchen corner is two arms, and the floor of its inner corner is floor: free on the grid, free in
MuJoCo, a base pose for the arm, and the reason an object near the corner is pickable at all.

The house: a kitchen [0, 5] x [0, 4] m (ProcTHOR x, z) with the L counter in its south-west corner,
read with its size from ProcTHOR's asset database (2.44 x 1.83 m, arms 0.61 m deep), an apple on the
back arm 1.3 m from the west wall and 0.3 m from the south wall. Seen as its bounding box, the nearest
free floor to the apple is 1.5 m away (beyond the arm's reach); seen as an L, 0.33 m."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from procthor_houses import child, obj, rect, room_walls

from interllm.config import SimConfig
from interllm.scene import import_procthor, rasterize
from interllm.scene.shaped_furniture import shaped_parts
from interllm.sim.build import build_world_spec
from interllm.sim.reach_report import reach_report

K = 2
APPLE = (1.3, 0.3)  # ProcTHOR (x, z) [m]: on the back arm, near the inner corner
CORNER = (1.6, 1.3)  # [m] inner-corner floor: 0.67 m from the back arm, 0.97 m from the side arm


def l_kitchen() -> dict:
    counter = obj("CounterTop", K, 0, 0.02 + 2.4392 / 2, 0.02 + 1.8288 / 2, y=0.47, asset="Countertop_L_8x6",
                  children=[child("Apple", K, 1, *APPLE, y=0.99)])
    return {"id": "l_kitchen", "metadata": {"schema": "1.0.0"},
            "rooms": [{"id": f"room|{K}", "roomType": "Kitchen", "floorPolygon": rect(0, 0, 5, 4)}],
            "walls": room_walls(K, 0, 0, 5, 4, {"S", "E", "N", "W"}), "doors": [],
            "objects": [counter, obj("Fridge", K, 1, 4.4, 3.5, asset="Fridge_1")]}


@pytest.fixture(scope="module")
def scene():
    return import_procthor(l_kitchen())


def _counter(scene):
    (f,) = [f for f in scene.furniture.values() if f.category == "kitchen_counter"]
    return f


def _as_a_box(scene):
    f = _counter(scene)
    return dataclasses.replace(scene, furniture={**scene.furniture, f.id: dataclasses.replace(f, parts=())})


def test_the_l_counter_is_two_arms_with_the_asset_databases_size(scene):
    f = _counter(scene)
    assert f.size[:2] == pytest.approx((2.4392, 1.8288), abs=1e-3)  # asset-database.json, not the catalog's
    back, arm = f.parts
    assert back == pytest.approx((0.02, 0.02, 2.4592, 0.6296), abs=1e-3)  # along the south wall
    assert arm == pytest.approx((0.02, 0.6296, 0.6296, 1.8488), abs=1e-3)  # along the west wall
    assert any("L-shaped counter: 2 boxes" in line for line in scene.meta["import_report"])


def test_the_inner_corner_is_free_on_the_grid(scene):
    sim = SimConfig()
    grid = rasterize(scene, 0.05, sim.robot_radius)
    assert grid.is_free(grid.world_to_cell(np.array(CORNER)))
    boxed = rasterize(_as_a_box(scene), 0.05, sim.robot_radius)
    assert not boxed.is_free(boxed.world_to_cell(np.array(CORNER)))  # the test sees the difference


def test_the_inner_corner_is_free_in_mujoco(scene):
    model = build_world_spec(scene, robot=False, sim_cfg=SimConfig()).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    f = _counter(scene)
    geoms = [g for g in range(model.ngeom) if model.geom(g).name.startswith(f"furniture/{f.id}")]
    assert len(geoms) == 2
    probe = np.array([*CORNER, 0.5])
    for g in geoms:  # the corner point lies outside every box of the counter
        half, centre = model.geom_size[g], data.geom_xpos[g]
        assert np.any(np.abs(probe - centre) > half + 0.05), model.geom(g).name
    lo = np.min([data.geom_xpos[g] - model.geom_size[g] for g in geoms], axis=0)
    hi = np.max([data.geom_xpos[g] + model.geom_size[g] for g in geoms], axis=0)
    assert np.all(lo[:2] <= probe[:2]) and np.all(probe[:2] <= hi[:2])  # yet inside the bounding box


def test_shaped_parts_leave_the_corner_and_cover_the_arms():
    box = (0.0, 0.0, 2.44, 1.83)
    back, arm = shaped_parts("L", box, back="S", arm="W")
    assert back == (0.0, 0.0, 2.44, 0.6096) and arm == (0.0, 0.6096, 0.6096, 1.83)
    c = shaped_parts("C", box, back="S")
    assert len(c) == 3 and c[2] == (1.8304, 0.6096, 2.44, 1.83)
    assert shaped_parts("C", (0.0, 0.0, 1.2, 1.83), back="S") == ()  # arms that fill the rest: a box
    assert shaped_parts("I", box, back="S") == ()
    with pytest.raises(ValueError, match="perpendicular"):
        shaped_parts("L", box, back="S", arm="N")


def test_the_reach_report_counts_the_apple_by_the_inner_corner(scene):
    sim = SimConfig()
    shaped = reach_report(scene, sim, 0.05)
    assert shaped["kitchen_counter"].objects == 1 and shaped["kitchen_counter"].pickable == 1, shaped
    boxed = reach_report(_as_a_box(scene), sim, 0.05)
    assert boxed["kitchen_counter"].pickable == 0, boxed  # as a box, no pose reaches it
