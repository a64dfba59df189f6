"""Scene subpackage: scene graph, catalog, procedural generator, missions, grid, import/export. Names are imported from
their modules on first use (``interllm.lazy``)."""

from interllm.lazy import exports_of, lazy_exports

_EXPORTS = exports_of({
    "interllm.scene.catalog": ("Catalog", "CatalogError", "CommandSpec", "load_catalog", "scene_config"),
    "interllm.scene.generator": ("SceneGenerationError", "generate_scene"),
    "interllm.scene.geometry": ("free_edges",),
    "interllm.scene.graph": ("Command", "Door", "Furniture", "Goal", "Mission", "Room", "SceneGraph", "SceneObject",
                             "Wall"),
    "interllm.scene.grid": ("OccupancyGrid", "approach_cells", "free_components", "largest_component", "rasterize"),
    "interllm.scene.importer": ("ImportOptions", "import_procthor"),
    "interllm.scene.missions": ("MissionError", "generate_missions", "load_missions", "save_missions", "start_pose",
                                "supported_commands"),
    "interllm.scene.reachability": ("unreachable",),
    "interllm.scene.render": ("render_topdown",),
    "interllm.scene.schema": ("scene_json_schema",),
    "interllm.scene.validate": ("SceneValidationError", "load_scene_file", "validate_dict", "validate_scene"),
})
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
