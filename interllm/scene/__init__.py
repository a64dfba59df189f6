"""Scene subpackage: scene graph, catalog, procedural generator, missions, grid, import/export."""

from interllm.scene.catalog import Catalog, CatalogError, CommandSpec, load_catalog, scene_config
from interllm.scene.generator import SceneGenerationError, generate_scene
from interllm.scene.geometry import free_edges
from interllm.scene.graph import Command, Door, Furniture, Goal, Mission, Room, SceneGraph, SceneObject, Wall
from interllm.scene.grid import OccupancyGrid, approach_cells, free_components, largest_component, rasterize
from interllm.scene.importer import ImportOptions, import_procthor
from interllm.scene.missions import (
                                     MissionError,
                                     generate_missions,
                                     load_missions,
                                     save_missions,
                                     start_pose,
                                     supported_commands,
)
from interllm.scene.reachability import unreachable
from interllm.scene.render import render_topdown
from interllm.scene.schema import scene_json_schema
from interllm.scene.validate import SceneValidationError, load_scene_file, validate_dict, validate_scene

__all__ = [
    "Catalog", "CatalogError", "CommandSpec", "load_catalog", "scene_config",
    "SceneGenerationError", "free_edges", "generate_scene", "unreachable",
    "Command", "Door", "Furniture", "Goal", "Mission", "Room", "SceneGraph", "SceneObject", "Wall",
    "OccupancyGrid", "approach_cells", "free_components", "largest_component", "rasterize",
    "ImportOptions", "import_procthor",
    "MissionError", "generate_missions", "load_missions", "save_missions", "start_pose", "supported_commands",
    "render_topdown", "scene_json_schema",
    "SceneValidationError", "load_scene_file", "validate_dict", "validate_scene",
]
