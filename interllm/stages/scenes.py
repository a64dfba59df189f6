"""Stage scenes: scene graphs (generated or imported), occupancy grids, MuJoCo worlds, missions and
top-down pictures."""

from __future__ import annotations

from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.io import atomic_write_bytes, atomic_write_text
from interllm.progress import progress
from interllm.scene.generator import generate_scene
from interllm.scene.grid import OccupancyGrid, rasterize
from interllm.scene.missions import generate_missions, save_missions
from interllm.scene.render import render_topdown
from interllm.scene.validate import load_scene_file
from interllm.sim.build import build_world_spec


def run_scenes(cfg: ExperimentConfig, out_dir: Path) -> list[str]:
    """Write every scene of the experiment into ``out_dir/<scene_id>/``; returns the scene ids."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ids = []
    n = 1 if cfg.scene.import_path else cfg.scene.n_scenes
    for i in progress(range(n), "scenes", total=n):
        scene = load_scene_file(cfg.scene.import_path) if cfg.scene.import_path else generate_scene(
            cfg.scene, i, robot_radius=cfg.sim.robot_radius)
        d = out_dir / scene.id
        d.mkdir(parents=True, exist_ok=True)
        atomic_write_text(d / "scene.json", scene.to_json())
        presumed = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="presumed")
        true = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="true")
        atomic_write_bytes(d / "grid.npz", OccupancyGrid.pair_npz_bytes(presumed, true, cfg.sim.robot_radius))
        atomic_write_text(d / "scene.xml", build_world_spec(scene, robot=False, sim_cfg=cfg.sim).to_xml())
        save_missions(d / "missions.json",
                      generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution,
                                        footprint_radius=cfg.sim.footprint_radius))
        render_topdown(scene, d / "topdown.png", grid=presumed)
        ids.append(scene.id)
    return ids
