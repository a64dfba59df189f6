"""The robots of ``sim/robot=<name>``: each builds, matches its published dimensions, and picks up
and places an object in MuJoCo (in the manner of mujoco_menagerie's model tests).

Figures checked (interllm/sim/robots.py cites them): Stretch 3 (Hello Robot's hardware guide):
footprint 34 x 33 cm, lift travel 1.1 m, arm travel 0.52 m. ManipulaTHOR (AI2-THOR's source): body
radius 0.2 m, arm root 0.329 m right of the body axis and 0.451 to 1.801 m above the floor, shoulder
0.3165 m in front of the root, upper arm 0.3165 m and forearm 0.3170 m (the prefab's joints; about
AI2-THOR's 0.6325 m extendedArmLength from the shoulder).
"""

from __future__ import annotations

import math
import sys

import mujoco
import numpy as np
import pytest
from helpers.scenes import house, mission, nav

from interllm.config import ROBOTS, SimConfig
from interllm.core.actions import Action
from interllm.overrides import compose_config
from interllm.sim.kinematics import RobotKinematics
from interllm.sim.robot import add_robot, add_robot_assets, grip_in_base, robot_parts
from interllm.sim.robots import describe, stretch_urdf_path
from interllm.sim.urdf_chain import link_boxes, read_chain, rpy_quat
from interllm.sim.world import World

REAL = [r for r in ROBOTS if r != "generic"]


def _cfg(name: str) -> SimConfig:
    """The sim config the Hydra group ``sim/robot=<name>`` composes."""
    return SimConfig(**compose_config([f"sim/robot={name}"])["sim"])


def test_the_robot_choices_are_the_descriptions_and_the_hydra_group():
    from interllm.overrides import CONF_DIR

    assert sorted(p.stem for p in (CONF_DIR / "sim" / "robot").glob("*.yaml")) == sorted(ROBOTS)
    assert compose_config([])["sim"]["robot"] == "manipulathor" == SimConfig().robot
    for name in ROBOTS:
        assert _cfg(name).robot == name


@pytest.mark.parametrize("name", ROBOTS)
def test_each_robot_builds_and_its_kinematics_match_mujoco(name):
    cfg = _cfg(name)
    spec = mujoco.MjSpec()
    add_robot_assets(spec)
    add_robot(spec.worldbody, cfg, mobile=False)
    model = spec.compile()
    data = mujoco.MjData(model)
    parts = robot_parts(name)
    assert model.nq == len(parts.joints) == len(parts.tuck)
    kin = RobotKinematics(cfg)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = np.array([rng.uniform(*model.jnt_range[i]) if model.jnt_limited[i] else rng.uniform(-3, 3)
                      for i in range(model.njnt)])
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        trans, quat = kin.link_poses(q)
        pos = {"base_link": np.array(model.body("robot/base").pos)}
        rot = {"base_link": np.eye(3)}
        for (parent, child), t, qt in zip(kin.chain, trans, quat, strict=True):
            r = np.zeros(9)
            mujoco.mju_quat2Mat(r, np.array([qt[3], *qt[:3]]))
            pos[child] = pos[parent] + rot[parent] @ t
            rot[child] = rot[parent] @ r.reshape(3, 3)
        assert np.allclose(pos["grip"], data.site_xpos[model.site("robot/grip").id], atol=1e-9)


def test_stretch_matches_its_published_dimensions():
    desc = describe("stretch")
    joints = {j.name: j for j in desc.joints}
    assert joints["joint_lift"].kind == "slide" and joints["joint_lift"].range == (0.0, 1.1)  # lift travel 1.1 m
    arm = [joints[f"joint_arm_l{i}"] for i in range(4)]
    assert sum(j.range[1] - j.range[0] for j in arm) == pytest.approx(0.52)  # arm travel 52 cm
    # footprint 34 x 33 cm: the URDF's base collision mesh spans 0.344 x 0.362 m (its wheels and
    # bumper included); the contact radius is that box's half diagonal
    base = link_boxes(stretch_urdf_path(), {"base_link"})["base_link"]
    assert sorted(2 * h for h in base.half[:2]) == pytest.approx([0.33, 0.34], abs=0.035)
    assert desc.footprint_radius == pytest.approx(math.hypot(*base.half[:2]))
    assert _cfg("stretch").footprint_radius == pytest.approx(desc.footprint_radius, abs=0.005)
    # by forward kinematics: the grasp centre travels 1.1 m up and 0.52 m out, sideways (base -y)
    low, high = grip_in_base(desc, desc.reach_low), grip_in_base(desc, desc.reach_high)
    assert high[2] - low[2] == pytest.approx(1.1, abs=1e-4)  # the URDF writes pi/2 as 1.5708
    assert low[1] - high[1] == pytest.approx(0.52, abs=1e-4)
    assert abs(high[0] - low[0]) < 1e-4
    reach = robot_parts("stretch").reach
    assert reach.radius == pytest.approx(math.hypot(high[0], high[1]))
    assert 0.6 < reach.radius < 0.7 and reach.z_high < 1.0  # a top-down grasp reaches 0.65 m out, below 1 m


def test_manipulathor_matches_ai2thors_figures():
    desc = describe("manipulathor")
    assert desc.footprint_radius == 0.2 and _cfg("manipulathor").footprint_radius == 0.2
    lift = desc.joints[0]
    assert lift.kind == "slide" and lift.range == pytest.approx((0.450998873, 1.8009994))
    shoulder = (0.31654257, -0.329)  # [m] forward, left of the body axis
    arm = 0.31653777 + 0.3169529  # [m] shoulder to wrist, straight
    assert arm == pytest.approx(0.6325, abs=0.0015)  # AI2-THOR's extendedArmLength
    for height in lift.range:
        straight = grip_in_base(desc, (height, 0.0, 0.0, 0.0, 0.0, 0.0))  # arm and wrist straight out
        assert straight == pytest.approx((shoulder[0] + arm + 0.07, shoulder[1], height))
        down = grip_in_base(desc, (height, 0.0, 0.0, 0.0, math.pi / 2, 0.0))  # the hand turned down
        assert down == pytest.approx((shoulder[0] + arm, shoulder[1], height - 0.07))
    reach = robot_parts("manipulathor").reach
    assert reach.radius == pytest.approx(math.hypot(shoulder[0] + arm, shoulder[1]))
    # nearest: the grasp centre under the shoulder (AI2-THOR refuses targets behind the shoulder)
    assert (reach.lateral, reach.radius_min, reach.tilts) == (pytest.approx(-0.329), pytest.approx(math.hypot(*shoulder)), True)
    assert SimConfig().pose_reach > reach.radius + SimConfig().pose_margin  # the cap leaves the reach whole


def test_the_urdf_frames_are_read_as_urdf_defines_them():
    from scipy.spatial.transform import Rotation

    for rpy in ((0.3, -1.2, 2.0), (math.pi / 2, 0.0, math.pi), (0.0, 0.0, 0.0)):
        x, y, z, w = Rotation.from_euler("xyz", rpy).as_quat()  # fixed axes: Rz·Ry·Rx
        assert np.allclose(rpy_quat(*rpy), (w, x, y, z))
    chain = read_chain(stretch_urdf_path(), "base_link", "link_grasp_center")
    assert [j.name for j in chain if j.kind != "fixed"] == [
        "joint_lift", "joint_arm_l3", "joint_arm_l2", "joint_arm_l1", "joint_arm_l0", "joint_wrist_yaw",
        "joint_wrist_pitch", "joint_wrist_roll"]
    with pytest.raises(ValueError, match="does not descend"):
        read_chain(stretch_urdf_path(), "link_lift", "link_head")


@pytest.mark.parametrize("name", REAL)
def test_each_robot_picks_up_and_places_in_mujoco(name):
    cfg = _cfg(name)
    w = World(house(), cfg)
    w.reset(mission())
    assert w.execute(nav("table_1", "room_b")).success
    pick = w.execute(Action("pickup", "table_1", obj="cup_1"))
    assert pick.success, pick.reason
    assert len(pick.trajectory.joint_names) == len(robot_parts(name).joints)
    assert w.physics.held == "cup_1"
    assert w.execute(nav("sofa_1", "room_b")).success
    place = w.execute(Action("place", "sofa_1", obj="cup_1"))
    assert place.success, place.reason
    o = w.scene.objects["cup_1"]
    assert o.furniture == "sofa_1"
    assert o.position[2] == pytest.approx(w.scene.furniture["sofa_1"].surface_height + o.size[2] / 2)


def test_a_missing_robot_package_is_named_with_the_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "stretch_urdf", None)  # as if it were not installed
    with pytest.raises(ModuleNotFoundError, match="make install.*hello-robot-stretch-urdf"):
        stretch_urdf_path()


def test_the_reach_report_counts_per_category_and_names_each_cause(tmp_path):
    from interllm.scene.graph import SceneObject
    from interllm.sim.reach_report import object_cause, reach_report, report_json

    scene = house()
    scene.objects["mug_1"] = SceneObject("mug_1", "mug", "counter_1", (0.72, 1.0, 0.95), (0.08, 0.08, 0.1))
    generic = reach_report(scene, _cfg("generic"))  # the apple stands deep on the table (test_sim_world)
    assert {c: (r.pickable, r.objects) for c, r in generic.items()} == {"counter": (1, 1), "dining_table": (1, 2)}
    assert generic["dining_table"].causes == {"no_free_pose": 1}
    tall = reach_report(scene, _cfg("stretch"))
    assert tall["counter"].pickable == 0 and tall["counter"].causes == {"height": 1}  # top-down: below 1 m only
    assert tall["dining_table"].pickable == 1
    assert report_json(tall, "stretch")["by_furniture_category"]["counter"]["causes"] == {"height": 1}
    assert object_cause(World(scene, _cfg("generic")), scene, "cup_1") == ""


def test_scene_reach_command_takes_hydra_overrides(tmp_path):
    import json
    import subprocess

    from interllm.io import atomic_write_text

    scene_file = tmp_path / "scene.json"
    atomic_write_text(scene_file, house().to_json())
    out = tmp_path / "reach.json"
    r = subprocess.run([sys.executable, "-m", "interllm.cli", "scene", "reach", str(scene_file), "sim/robot=stretch",
                        "--json", str(out)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("robot stretch: 1 of 2 objects pickable (50%); not: no_free_pose 1")
    assert json.loads(out.read_text())["pickable"] == 1
    bad = subprocess.run([sys.executable, "-m", "interllm.cli", "scene", "reach", str(scene_file), "sim/robot=nao"],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "sim/robot" in bad.stderr and "stretch" in bad.stderr


@pytest.mark.parametrize("name", REAL)
def test_the_ik_keeps_every_arm_link_off_the_furniture_even_the_first(name):
    """In the local IK model the base is welded to the world, so mink would take the arm's first
    moving link (ManipulaTHOR's arm root, Stretch's lift carriage) for the world's child and drop
    its pairs with the furniture; ``ArmCollisionLimit`` keeps every (arm geom, obstacle) pair."""
    from interllm.sim.arm_ik import build_local_ik

    ik = build_local_ik(house(), "table_1", _cfg(name))
    avoid = ik.obstacles()
    pairs = {tuple(sorted(p)) for p in ik.limits(avoid)[1].geom_id_pairs}
    table = ik.model.geom("furniture/table_1").id
    assert {tuple(sorted((g, table))) for g in ik.arm_geoms} <= pairs
    assert len(pairs) == len(ik.arm_geoms) * len(set(avoid))
