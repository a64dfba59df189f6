import math

import mujoco
import numpy as np
import pytest
from helpers.scenes import GENERIC

from interllm.config import SimConfig
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.sim.build import build_local_spec, build_world_spec
from interllm.sim.robot import ARM_JOINTS, GRIP_SITE, REACH, SHOULDER_FORWARD, SHOULDER_HEIGHT


def _scene() -> SceneGraph:
    sg = SceneGraph(id="build_test", seed=0)
    sg.rooms["r1"] = Room("r1", "kitchen", ((0, 0), (3, 0), (3, 3), (0, 3)))
    sg.rooms["r2"] = Room("r2", "bedroom", ((3, 0), (6, 0), (6, 3), (3, 3)))
    for i, (a, b) in enumerate([((0, 0), (6, 0)), ((0, 3), (6, 3)), ((0, 0), (0, 3)), ((6, 0), (6, 3)),
                                ((3, 0), (3, 1.0)), ((3, 2.0), (3, 3))]):
        sg.walls[f"w{i}"] = Wall(f"w{i}", a, b, 0.1, 2.5)
    sg.doors["d1"] = Door("d1", ("r1", "r2"), (3, 1.5), "y", 1.0, open_fraction=0.4, hinge="high")
    sg.furniture["table_1"] = Furniture("table_1", "table", "r1", (1.5, 1.5), (1.0, 0.8, 0.75))
    sg.furniture["shelf_1"] = Furniture("shelf_1", "shelf", "r2", (5.5, 2.5), (0.6, 0.4, 1.5))
    sg.objects["cup_1"] = SceneObject("cup_1", "cup", "table_1", (1.3, 1.4, 0.8), (0.08, 0.08, 0.1))
    sg.objects["book_1"] = SceneObject("book_1", "book", "table_1", (1.7, 1.6, 0.77), (0.2, 0.15, 0.04))
    sg.objects["vase_1"] = SceneObject("vase_1", "vase", "shelf_1", (5.5, 2.5, 1.6), (0.1, 0.1, 0.2))
    return sg


def _names(m, kind):
    n = {"geom": (m.ngeom, mujoco.mjtObj.mjOBJ_GEOM), "body": (m.nbody, mujoco.mjtObj.mjOBJ_BODY)}[kind]
    return {mujoco.mj_id2name(m, n[1], i) for i in range(n[0])}


def test_names_and_counts():
    sg = _scene()
    m = build_world_spec(sg, robot=True).compile()
    geoms = _names(m, "geom")
    for w in sg.walls:
        assert f"wall/{w}" in geoms
    assert "door/d1" in geoms
    for f in sg.furniture:
        assert f"furniture/{f}" in geoms and f"furniture/{f}" in _names(m, "body")
    for o in sg.objects:
        assert f"object/{o}" in geoms
        assert m.jnt_type[m.joint(f"object/{o}").id] == mujoco.mjtJoint.mjJNT_FREE
    assert "robot/base" in geoms and m.site(GRIP_SITE).id >= 0
    # 3 base joints + 6 arm joints + 7 per free object
    assert m.nq == 3 + 6 + 7 * len(sg.objects)
    # door leaf: 40 % open of 1 m, hinge high -> leaf covers y in [1.5 + 0.5 - 0.6, 2.0] = [1.4, 2.0]
    g = m.geom("door/d1").id
    half = m.geom_size[g]
    assert max(half[0], half[1]) == pytest.approx(0.6 / 2 + 0.04 / 2)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    assert d.geom_xpos[g][1] == pytest.approx(1.7)


def test_fully_open_door_has_no_leaf():
    sg = _scene()
    sg.doors["d1"] = Door("d1", ("r1", "r2"), (3, 1.5), "y", 1.0, open_fraction=1.0)
    m = build_world_spec(sg, robot=False).compile()
    assert "door/d1" not in _names(m, "geom")


def test_scene_xml_round_trip_loads():
    sg = _scene()
    xml = build_world_spec(sg, robot=False).to_xml()
    m = mujoco.MjModel.from_xml_string(xml)
    assert m.nq == 7 * len(sg.objects)
    assert "robot/base" not in _names(m, "geom")


def test_objects_settle_on_furniture_without_penetration():
    sg = _scene()
    m = build_world_spec(sg, robot=True, sim_cfg=SimConfig(**GENERIC)).compile()
    d = mujoco.MjData(m)
    d.qpos[:3] = (0.6, 2.4, 0.0)  # robot base in a free spot of room r1
    mujoco.mj_forward(m, d)
    start = {o: d.xpos[m.body(f"object/{o}").id].copy() for o in sg.objects}
    arm0 = np.array([d.qpos[m.jnt_qposadr[m.joint(j).id]] for j in ARM_JOINTS])
    n = int(round(0.5 / m.opt.timestep))
    for _ in range(n):
        mujoco.mj_step(m, d)
    for oid, o in sg.objects.items():
        p = d.xpos[m.body(f"object/{oid}").id]
        f = sg.furniture[o.furniture]
        x0, y0, x1, y1 = f.footprint
        assert x0 <= p[0] <= x1 and y0 <= p[1] <= y1, oid
        assert abs(p[2] - start[oid][2]) < 0.005, (oid, p[2], start[oid][2])
        # bottom of the box on the surface (within 5 mm)
        assert p[2] - o.size[2] / 2 == pytest.approx(f.surface_height, abs=0.005)
    assert d.ncon > 0
    assert min(d.contact.dist[: d.ncon]) > -0.005  # no deep penetration
    # the robot (gravity-compensated, damped) stays where it is
    arm1 = np.array([d.qpos[m.jnt_qposadr[m.joint(j).id]] for j in ARM_JOINTS])
    assert np.abs(arm1 - arm0).max() < 0.05


def test_robot_reach_and_radius():
    cfg = SimConfig(**{**GENERIC, "robot_radius": 0.3})
    sg = _scene()
    m = build_world_spec(sg, robot=True, sim_cfg=cfg).compile()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)  # all joints zero: arm straight forward, horizontal
    grip = d.site_xpos[m.site(GRIP_SITE).id]
    assert grip[0] == pytest.approx(SHOULDER_FORWARD + REACH)
    assert grip[2] == pytest.approx(SHOULDER_HEIGHT)
    assert 0.7 <= REACH <= 0.9 and 0.6 <= SHOULDER_HEIGHT <= 0.9
    assert m.geom_size[m.geom("robot/base").id][0] == pytest.approx(0.3)
    for j in ARM_JOINTS:
        assert m.jnt_limited[m.joint(j).id]


def test_base_wall_contact_is_detected():
    sg = _scene()
    m = build_world_spec(sg, robot=True).compile()
    d = mujoco.MjData(m)
    base = m.geom("robot/base").id

    def touching(x, y):
        d.qpos[:3] = (x, y, 0.0)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        names = set()
        for i in range(d.ncon):
            g1, g2 = d.contact.geom1[i], d.contact.geom2[i]
            if base in (g1, g2):
                other = g2 if g1 == base else g1
                names.add(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, other))
        return names

    assert touching(0.5, 2.5) == set()
    assert "wall/w2" in touching(0.2, 2.5)  # 0.25 m radius vs wall at x = 0.05
    assert "door/d1" in touching(2.85, 1.7)  # the leaf at x = 3 +- 0.02
    assert "furniture/table_1" in touching(1.5, 0.9)  # table edge y = 1.1


def test_local_spec_has_only_arm_joints():
    sg = _scene()
    m = build_local_spec(sg, "table_1", exclude_objects=("book_1",)).compile()
    assert m.nq == 6
    geoms = _names(m, "geom")
    assert "object/cup_1" in geoms and "object/book_1" not in geoms and "object/vase_1" not in geoms
    with pytest.raises(KeyError, match="unknown furniture"):
        build_local_spec(sg, "nope")
    assert math.isfinite(REACH)
