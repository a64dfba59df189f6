"""Simulator benchmark on a generated paper-size scene (9 rooms, 26 furniture, 30 objects).

Prints:
1. IK solves per second on the small per-furniture model (what sim/arm_ik.py builds) vs the
   same solve on the whole-house model (all free joints frozen with mink.DofFreezingTask);
2. navigation execution speed as a multiple of simulated time (goal >= 100x), and the cost of
   one contact check (mj_kinematics + mj_collision) vs a full mj_forward;
3. one paper-size mission (3 commands x 3 objects, ground-truth plan: navigate, pickup,
   navigate, place per object) executed end to end: wall time vs simulated time.

Run: .venv/bin/python benchmarks/bench_sim.py [--scene-index 0]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mink  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from interllm.config import MissionConfig, SceneConfig, SimConfig  # noqa: E402
from interllm.core.actions import Action  # noqa: E402
from interllm.core.frames import yaw_quat_wxyz  # noqa: E402
from interllm.scene.generator import generate_scene  # noqa: E402
from interllm.scene.missions import generate_missions  # noqa: E402
from interllm.sim import arm_ik  # noqa: E402
from interllm.sim.base_poses import PRE_GRASP_HEIGHT, window_poses  # noqa: E402
from interllm.sim.robot import ARM_GEOMS, ARM_JOINTS, GRIP_SITE, TUCK  # noqa: E402
from interllm.sim.world import World  # noqa: E402


def ik_benchmark(world: World, n_targets: int = 40) -> None:
    cfg = world.cfg
    scene = world.scene
    fronts = sorted(o.id for o in scene.objects.values() if o.placement == "front")
    jobs = []
    for oid in fronts:
        o = scene.objects[oid]
        act = Action("pickup", o.furniture, obj=oid)
        for bp in window_poses(world.belief.presumed, world.scene.furniture[o.furniture], o.position[:2], act, 3, cfg):
            jobs.append((o, bp.pose))
    jobs = jobs[:n_targets]
    # small model
    t = time.perf_counter()
    n_ok = 0
    for o, (bx, by, byaw) in jobs:
        ik = world.manipulator.local_ik(world.scene, o.furniture)
        ik.model.body_pos[ik.base_body] = (bx, by, 0.0)
        ik.model.body_quat[ik.base_body] = yaw_quat_wxyz(byaw)
        rot = arm_ik.topdown_rotation((bx, by), o.position[:2])
        avoid = ik.furniture_geoms + [g for k, g in ik.object_geoms.items() if k != o.id]
        s = arm_ik.solve_ik(ik, TUCK, np.array(o.position) + [0, 0, PRE_GRASP_HEIGHT], rot, cfg, avoid)
        n_ok += s.converged
    t_local = time.perf_counter() - t
    # whole-house model: same tasks and limits, every non-arm dof frozen
    m = world.physics.model
    conf = mink.Configuration(m)
    arm_dofs = {int(m.jnt_dofadr[m.joint(j).id]) for j in ARM_JOINTS}
    freeze = mink.DofFreezingTask(m, [d for d in range(m.nv) if d not in arm_dofs])
    arm_geoms = [m.geom(g).id for g in ARM_GEOMS]
    base_qadr = [int(m.jnt_qposadr[m.joint(j).id]) for j in ("robot/x", "robot/y", "robot/yaw")]
    arm_qadr = [int(m.jnt_qposadr[m.joint(j).id]) for j in ARM_JOINTS]
    n_big = min(len(jobs), 8)
    t = time.perf_counter()
    n_ok_big = 0
    for o, (bx, by, byaw) in jobs[:n_big]:
        q = world.physics.data.qpos.copy()
        q[base_qadr] = (bx, by, byaw)
        q[arm_qadr] = TUCK
        conf.update(q)
        fid = m.geom(f"furniture/{o.furniture}").id
        limits = [mink.ConfigurationLimit(m),
                  mink.CollisionAvoidanceLimit(m, [(arm_geoms, [fid])], minimum_distance_from_collisions=0.005,
                                               collision_detection_distance=0.08)]
        task = mink.FrameTask(GRIP_SITE, "site", position_cost=1.0, orientation_cost=0.3, lm_damping=1e-3)
        rot = arm_ik.topdown_rotation((bx, by), o.position[:2])
        target = np.array(o.position) + [0, 0, PRE_GRASP_HEIGHT]
        task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), target))
        for _ in range(cfg.ik_max_iters):
            p = conf.data.site_xpos[m.site(GRIP_SITE).id]
            if np.linalg.norm(p - target) <= cfg.ik_tol:
                n_ok_big += 1
                break
            v = mink.solve_ik(conf, [task], cfg.ik_dt, "daqp", damping=1e-3, limits=limits, constraints=[freeze])
            conf.integrate_inplace(v, cfg.ik_dt)
    t_big = time.perf_counter() - t
    r_local = len(jobs) / t_local
    r_big = n_big / t_big
    print(f"IK (pre-grasp, top-down, joint + collision limits): small per-furniture model "
          f"{r_local:.1f} solves/s ({n_ok}/{len(jobs)} converged); whole-house model (nv={m.nv}) "
          f"{r_big:.2f} solves/s ({n_ok_big}/{n_big} converged) -> small model {r_local / r_big:.0f}x faster")


def nav_benchmark(world: World, mission) -> None:
    world.reset(mission)
    fids = sorted(world.scene.furniture)
    t = time.perf_counter()
    sim = 0.0
    dist = 0.0
    cols = 0
    steps = 0
    for k in range(12):
        f = world.scene.furniture[fids[(k * 7) % len(fids)]]
        r = world.execute(Action("navigate", f.id, room=f.room))
        sim += r.time
        dist += r.distance
        cols += r.collisions
        steps += len(r.driven_path)
    wall = time.perf_counter() - t
    print(f"navigation: 12 navigate actions, {dist:.1f} m, {cols} collisions, {sim:.1f} s simulated in "
          f"{wall:.2f} s wall -> {sim / wall:.0f}x faster than simulated time ({steps} contact checks)")
    m, d = world.physics.model, world.physics.data
    n = 2000
    t = time.perf_counter()
    for _ in range(n):
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
    t_kc = (time.perf_counter() - t) / n
    t = time.perf_counter()
    for _ in range(n):
        mujoco.mj_forward(m, d)
    t_fw = (time.perf_counter() - t) / n
    print(f"contact check: mj_kinematics+mj_collision {t_kc * 1e6:.1f} us vs mj_forward {t_fw * 1e6:.1f} us "
          f"-> {t_fw / t_kc:.1f}x cheaper")


def mission_benchmark(world: World, mission) -> None:
    scene = world.initial_scene
    world.reset(mission)
    used: set[str] = set()
    plan = []
    for cmd in mission.commands:
        target = cmd.goal.target_furniture[0]
        cands = sorted(o.id for o in scene.objects.values()
                       if o.category in cmd.goal.categories and o.id not in used)[:cmd.goal.n_objects]
        for oid in cands:
            used.add(oid)
            src = scene.objects[oid].furniture
            plan += [Action("navigate", src, room=scene.furniture[src].room), Action("pickup", src, obj=oid),
                     Action("navigate", target, room=scene.furniture[target].room),
                     Action("place", target, obj=oid)]
    t = time.perf_counter()
    results = []
    for a in plan:
        if a.kind == "place" and world.state.holding != a.obj:
            continue  # the pickup failed
        results.append(world.execute(a))
    wall = time.perf_counter() - t
    ok = sum(r.success for r in results)
    nav = [r for r in results if r.action.kind == "navigate"]
    manip = [r for r in results if r.action.kind != "navigate"]
    print(f"mission {mission.id} ({len(mission.commands)} commands, {len(used)} objects): {len(results)} actions "
          f"({ok} succeeded), simulated {world.clock:.1f} s, wall {wall:.2f} s -> {world.clock / wall:.0f}x; "
          f"nav {sum(r.distance for r in nav):.1f} m, {sum(r.collisions for r in nav)} collisions; "
          f"manipulation mean sr {np.mean([r.success_rate for r in manip]):.2f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene-index", type=int, default=0)
    args = ap.parse_args()
    t = time.perf_counter()
    scene = generate_scene(SceneConfig(), args.scene_index)
    missions = generate_missions(scene, MissionConfig())
    t_gen = time.perf_counter() - t
    t = time.perf_counter()
    world = World(scene, SimConfig())
    t_world = time.perf_counter() - t
    print(f"scene {scene.id}: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, {len(scene.objects)} "
          f"objects, {len(scene.doors)} doors; generate {t_gen:.2f} s, World() {t_world:.2f} s "
          f"(nq={world.physics.model.nq}, ngeom={world.physics.model.ngeom})")
    world.reset(missions[0])
    ik_benchmark(world)
    nav_benchmark(world, missions[0])
    mission_benchmark(world, missions[0])


if __name__ == "__main__":
    main()
