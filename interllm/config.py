"""Typed experiment configuration.

These dataclasses are the single schema of the experiment and hold every default: the option
files in ``conf/`` set only what differs from them (``llm=ollama``: the backend, the model and the
proposal modes). The Hydra plugin ``hydra_plugins/interllm_schema`` registers ``ExperimentConfig``
in Hydra's ConfigStore, so every composition of ``conf/`` (DVC's included) starts from these
defaults and a typo or a wrong type fails at composition; ``validate()`` (called from
``__post_init__``) checks ranges and choices, so a bad value fails with the config key and the
valid choices. Names of registered implementations (planners, LLM backends, proposal modes) are
checked against their registries by ``interllm.stages.validate.check_registered`` at composition
and before a stage uses them. The library itself never imports hydra: it receives instances of
these classes.

Units are in the field comments: metres [m], seconds [s], radians [rad].
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from typing import Optional

from interllm.config_planners import (  # noqa: F401  (re-exported: one import for the schema)
    COST_ENCODINGS,
    LEGACY_PLANNER_KEYS,
    NAV_ESTIMATES,
    InterLLMConfig,
    MoMaLLMConfig,
    SayPlanConfig,
    build_section,
)
from interllm.config_sim import POSE_PROTOCOLS, ROBOTS, SimConfig  # noqa: F401  (re-exported: one import for the schema)
from interllm.config_types import ConfigError
from interllm.config_types import check as _check
from interllm.config_types import choice as _choice

# llm.cache_mode (interllm/llm/cache.py); retry_failures: readwrite, but failed answers are asked again
CACHE_MODES = ("readwrite", "replay", "off", "retry_failures")
SCENE_SIZES = ("paper", "medium", "large", "huge", "tiny", "custom")
SCENE_LAYOUTS = ("grid", "hallway")  # scene.layout (interllm/scene/floor_plans.py)
OBJECT_DESIGNS = ("graded", "legacy")  # scene.object_design (interllm/scene/graded_objects.py, surface_objects.py)
ASSET_SOURCES = ("catalog", "procthor")  # scene.assets (interllm/scene/asset_source.py)
MISSION_FEASIBILITY = ("measured", "off")  # mission.feasibility (interllm/stages/feasibility.py)
MISSION_COMMANDS = ("auto", "catalog", "open")  # mission.commands (interllm/scene/open_commands.py)
ORACLE_COSTS = ("classes", "numeric")  # llm.oracle_costs (interllm/planning/oracle.py)
CANDIDATE_DIVERSITY = ("objects", "plans")  # llm.candidate_diversity (interllm/planning/scoring.py)
# sweep: the report section an experiment's multirun jobs feed (interllm/stages/report.py finds
# them by it); "" for none
SWEEPS = ("", "temperature", "m", "estimate", "oracle", "encoding")


# The largest scene (generated or imported) and experiment the stages accept, checked before any
# work starts: about 3 times the huge preset (110 rooms, 360 furniture, 2,000 objects, whose scenes
# stage takes about 3 minutes on 2 cores), so a mistyped size is a message, not an hour of silence
SCENE_LIMITS = {"rooms": 400, "furniture": 1500, "objects": 6000}
MAX_SCENES, MAX_MISSIONS, MAX_COMMANDS = 100, 1000, 100  # scene.n_scenes, mission.n_missions, commands_per_mission


def _at_most(value: int, limit: int, key: str, what: str) -> None:
    _check(value <= limit, key, f"{value} {what} is more than the {limit} the stages accept (about 3 times the "
                                f"largest measured run, so that a mistyped size stops here, not after hours); "
                                f"lower it")


@dataclass
class SceneConfig:
    name: str = "paper"  # size preset, one of SCENE_SIZES
    n_scenes: int = 3  # scenes generated for the experiment
    seed: int = 0  # scene i uses seed + i
    n_rooms: int = 9
    n_furniture: int = 26
    n_objects: int = 30
    layout: str = "hallway"  # floor plan: one of SCENE_LAYOUTS (grid: rooms on a grid; hallway: rooms along hallways)
    room_size_min: float = 3.0  # [m]
    room_size_max: float = 5.0  # [m]
    door_width: float = 1.0  # [m] opening width of a normal door (hallway layout: the widest)
    door_width_min: float = 0.8  # [m] hallway layout: normal doors are drawn in [door_width_min, door_width]
    narrow_door_width: float = 0.72  # [m]; the map lets the robot through, its true footprint collides
    narrow_door_prob: float = 0.15
    partly_closed_door_prob: float = 0.25  # door leaf blocks part of the opening (true map only)
    hard_placement_prob: float = 0.3  # object deep on a wide surface, high shelf, clutter
    # graded: every requested category gets easy, medium and hard instances in different places, and
    # each command at least objects_per_command easy ones on reachable furniture; legacy: hard
    # placements drawn with hard_placement_prob only
    object_design: str = "graded"
    # sizes of generated pieces: catalog (one per category) or procthor (a ProcTHOR asset per piece, chairs
    # from its asset groups, objects weighted by its receptacle statistics; interllm/scene/asset_source.py)
    assets: str = "catalog"
    wall_thickness: float = 0.1  # [m]
    wall_height: float = 2.5  # [m]
    grid_resolution: float = 0.05  # [m] per occupancy cell
    # the scenes stage measures every object's pickup (feasibility.json's reach report, topdown.png's
    # marks cover the whole house); false: only the instances the mission draw examines (the huge
    # preset: 2,000 pickups would be most of its scenes stage; `interllm scene reach` gives the report)
    reach_report: bool = True
    # a user scene in our JSON (a ProcTHOR house: `interllm scene import-procthor` first), or a
    # folder of them (<folder>/<house>/scene.json, sorted): several imported houses form one experiment
    import_path: Optional[str] = None

    def validate(self) -> None:
        _choice(self.name, "scene.name", SCENE_SIZES)
        _check(self.n_scenes >= 1, "scene.n_scenes", f"must be >= 1, got {self.n_scenes}")
        _check(self.n_rooms >= 2, "scene.n_rooms", f"must be >= 2, got {self.n_rooms}")
        _check(self.n_furniture >= self.n_rooms, "scene.n_furniture", "must be >= scene.n_rooms")
        _check(self.n_objects >= 1, "scene.n_objects", f"must be >= 1, got {self.n_objects}")
        _at_most(self.n_scenes, MAX_SCENES, "scene.n_scenes", "scenes")
        for key in SCENE_LIMITS:
            _at_most(getattr(self, f"n_{key}"), SCENE_LIMITS[key], f"scene.n_{key}", key)
        _choice(self.layout, "scene.layout", SCENE_LAYOUTS)
        _choice(self.object_design, "scene.object_design", OBJECT_DESIGNS)
        _choice(self.assets, "scene.assets", ASSET_SOURCES)
        _check(0.3 <= self.door_width_min <= self.door_width, "scene.door_width_min",
               f"must be in [0.3 m, scene.door_width], got {self.door_width_min}")
        _check(0 < self.room_size_min <= self.room_size_max, "scene.room_size_min",
               "must satisfy 0 < room_size_min <= room_size_max")
        for k in ("narrow_door_prob", "partly_closed_door_prob", "hard_placement_prob"):
            v = getattr(self, k)
            _check(0.0 <= v <= 1.0, f"scene.{k}", f"must be in [0, 1], got {v}")
        _check(0.01 <= self.grid_resolution <= 0.5, "scene.grid_resolution",
               f"must be in [0.01, 0.5] m, got {self.grid_resolution}")


@dataclass
class MissionConfig:
    n_missions: int = 10  # missions per scene
    commands_per_mission: int = 3
    objects_per_command: int = 3  # objects each command asks for (the paper: 3)
    include_paper_mission: bool = True  # mission 0 is the paper's three commands
    seed: int = 0
    limit_missions: Optional[int] = None  # run only the first N missions (smoke runs)
    # measured: commands are drawn among those the simulator's measurement says a planner can fulfil
    # (enough reachable and placeable instances, distinct across the mission); a command that
    # cannot be filled is reduced or dropped with a log line. off: commands drawn unchecked
    feasibility: str = "measured"
    # where commands come from (interllm/scene/open_commands.py): catalog (its 12 commands), open (the
    # catalog's and commands generated from what the house holds, with ProcTHOR's statistics of what
    # stands where), auto (the catalog's; the generated ones for a house that hosts none of them)
    commands: str = "auto"

    def validate(self) -> None:
        _check(self.n_missions >= 1, "mission.n_missions", f"must be >= 1, got {self.n_missions}")
        _check(self.commands_per_mission >= 1, "mission.commands_per_mission", "must be >= 1")
        _at_most(self.n_missions, MAX_MISSIONS, "mission.n_missions", "missions per scene")
        _at_most(self.commands_per_mission, MAX_COMMANDS, "mission.commands_per_mission", "commands per mission")
        _check(1 <= self.objects_per_command <= 6, "mission.objects_per_command",
               f"must be in [1, 6], got {self.objects_per_command}")
        _check(self.limit_missions is None or self.limit_missions >= 1, "mission.limit_missions",
               "must be null or >= 1")
        _choice(self.feasibility, "mission.feasibility", MISSION_FEASIBILITY)
        _choice(self.commands, "mission.commands", MISSION_COMMANDS)


@dataclass
class LLMConfig:
    backend: str = "embedded"  # a registered LLM backend (interllm.llm.backend.BACKENDS)
    model: str = ""  # GGUF path (embedded; "" = the packaged gemma3-270m) or Ollama model name
    host: str = "http://127.0.0.1:11434"  # Ollama server (llm.backend=ollama)
    base_url: str = "http://127.0.0.1:8080/v1"  # OpenAI-compatible server (llm.backend=openai)
    api_key_env: str = "OPENAI_API_KEY"  # name of the environment variable holding the key (never the key)
    temperature: float = 0.8  # the paper's σ: cost-label inference (and plan sampling unless plan_temperature is set)
    # plan sampling (candidates, re-proposals, replans); null: llm.temperature, as the paper couples them.
    # The σ ablation fixes it, so that σ varies the cost inference only
    plan_temperature: Optional[float] = None
    top_p: float = 0.95
    max_tokens: int = 384
    seed: int = 0
    n_threads: int = 2
    n_ctx: int = 8192
    timeout_s: float = 120.0  # [s] whole-call deadline of one request
    max_retries: int = 3  # retries of a request after HTTP 429 / 5xx / connection errors (exponential backoff)
    cache_mode: str = "readwrite"  # one of CACHE_MODES
    cache_dir: str = "data/llm_cache"
    proposal_mode: str = "score"  # how candidates are proposed (interllm.planning.proposers.PLAN_PROPOSERS)
    cost_inference_mode: str = "score"  # manipulation-cost inference (...proposers.COST_INFERRERS)
    # cost-inference prompts say where on its furniture each object is (scene/placement.py): the
    # furniture instance, depth from the open side, surface height, clearance, size (false:
    # furniture category and room only)
    placement_attributes: bool = True
    constrain_names: bool = True  # enumerate valid scene-graph names in schemas
    repair_retries: int = 2  # re-asks after malformed output
    calibrate: bool = True  # score calibration against a content-free prompt
    # the scene graph is expanded hierarchically. Score mode (planning/scoring.py): the room_beam
    # rooms, then the furniture_beam furniture in them, are the only ones whose objects are scored
    # one by one (0: no limit; both 0: every object, whatever the house's size). Generate mode
    # (planning/expansion.py): the LLM chooses up to room_beam rooms, and the plan requests show
    # only those (0: the whole scene graph); a selection with fewer usable objects than the command
    # asks for is widened by another request, at most room_widenings times per command
    room_beam: int = 3
    furniture_beam: int = 6
    room_widenings: int = 2
    max_failure_share: float = 0.05  # a stage stops when a larger share of its LLM calls fail or give unparseable answers
    # llm=oracle: the share of the oracle's answers (relevance, target, cost class) replaced by
    # seeded random ones (interllm/planning/oracle.py); read only when llm.backend is oracle
    oracle_error: float = 0.0
    # llm=oracle: manipulation costs as the paper's three classes (classes), or as the measured
    # number itself (numeric), to tell the encoding's limit from the model's
    oracle_costs: str = "classes"
    # score and oracle modes: objects: the M candidates differ in the objects they take where the
    # house allows it; plans: they differ in (objects, target) only
    candidate_diversity: str = "objects"

    @property
    def source_label(self) -> str:
        """What answered the planners' questions, as tables, logs and figures name it: the model, or
        "oracle (error e)" for the ground-truth source."""
        if self.backend == "oracle":
            return f"oracle (error {self.oracle_error:g})"
        return f"{self.backend} {self.model or 'gemma3-270m'}"

    @property
    def plan_sampling_temperature(self) -> float:
        """The temperature plans are sampled at: ``plan_temperature``, or ``temperature`` when null."""
        return self.temperature if self.plan_temperature is None else float(self.plan_temperature)

    def validate(self) -> None:
        _check(0.0 <= self.temperature <= 2.0, "llm.temperature",
               f"must be in [0, 2], got {self.temperature}")
        _check(self.plan_temperature is None or 0.0 <= self.plan_temperature <= 2.0, "llm.plan_temperature",
               f"must be null or in [0, 2], got {self.plan_temperature}")
        _check(0.0 < self.top_p <= 1.0, "llm.top_p", f"must be in (0, 1], got {self.top_p}")
        _check(self.max_tokens >= 1, "llm.max_tokens", "must be >= 1")
        _check(self.n_threads >= 1, "llm.n_threads", "must be >= 1")
        _check(self.n_ctx >= 512, "llm.n_ctx", "must be >= 512")
        _check(self.timeout_s > 0, "llm.timeout_s", "must be > 0")
        _check(0 <= self.max_retries <= 10, "llm.max_retries", f"must be in [0, 10], got {self.max_retries}")
        check_api_key_env(self.api_key_env)
        _choice(self.cache_mode, "llm.cache_mode", CACHE_MODES)
        _check(0 <= self.repair_retries <= 10, "llm.repair_retries", "must be in [0, 10]")
        _check(0.0 <= self.max_failure_share <= 1.0, "llm.max_failure_share",
               f"must be in [0, 1] (share of failed or unparseable LLM calls), got {self.max_failure_share}")
        _check(0 <= self.room_beam <= 1000, "llm.room_beam", f"must be in [0, 1000] (0: every room), got {self.room_beam}")
        _check(0 <= self.furniture_beam <= 10000, "llm.furniture_beam",
               f"must be in [0, 10000] (0: all furniture of the expanded rooms), got {self.furniture_beam}")
        _check(0 <= self.room_widenings <= 10, "llm.room_widenings",
               f"must be in [0, 10] (selection requests added when the chosen rooms run short), got {self.room_widenings}")
        _check(0.0 <= self.oracle_error <= 1.0, "llm.oracle_error", f"must be in [0, 1], got {self.oracle_error}")
        _choice(self.oracle_costs, "llm.oracle_costs", ORACLE_COSTS)
        _choice(self.candidate_diversity, "llm.candidate_diversity", CANDIDATE_DIVERSITY)
        oracle = [self.backend == "oracle", self.proposal_mode == "oracle", self.cost_inference_mode == "oracle"]
        _check(all(oracle) or not any(oracle), "llm.backend",
               "the oracle answers from ground truth and is never mixed with a model: use llm=oracle (backend, "
               f"proposal_mode and cost_inference_mode all 'oracle'), got backend={self.backend!r}, "
               f"proposal_mode={self.proposal_mode!r}, cost_inference_mode={self.cost_inference_mode!r}")
        _check(self.backend == "oracle" or self.oracle_error == 0.0, "llm.oracle_error",
               f"{self.oracle_error:g} is the error rate of the oracle (llm=oracle), but llm.backend="
               f"{self.backend!r} asks a model, whose answers it would not change: drop llm.oracle_error, "
               f"or use llm=oracle llm.oracle_error={self.oracle_error:g}")


# llm.api_key_env: a POSIX-portable environment variable name (upper case), never a key
ENV_VAR_NAME = re.compile(r"[A-Z_][A-Z0-9_]{0,63}")


def check_api_key_env(value: object) -> None:
    """Raise :class:`ConfigError` unless ``value`` (llm.api_key_env) looks like an environment variable
    NAME. The message never shows the value: what was pasted there is often the key itself."""
    _check(isinstance(value, str) and ENV_VAR_NAME.fullmatch(value) is not None, "llm.api_key_env",
           "must name the environment variable that holds the API key (upper-case letters, digits and _, not "
           "starting with a digit, at most 64 characters, e.g. OPENAI_API_KEY), but the value given is not such "
           "a name: it looks like a key itself. The value is not shown here and was not written anywhere. Fix: "
           "put the key in an environment variable (export MY_API_KEY=<the key>) and set "
           "llm.api_key_env=MY_API_KEY")


@dataclass
class PlannerConfig:
    """``planner``: which planners run, what they share (candidates, repair, fairness), and each
    planner's own settings under ``planner.<name>`` (interllm/config_planners.py)."""

    # registered planners to run; nothing and optimal are the anchors every table places the others
    # between (doing nothing; the cheapest assignment on ground-truth costs), never judged
    names: list[str] = field(default_factory=lambda: ["inter_llm", "sayplan", "moma_llm", "nothing", "optimal"])
    M: int = 3  # plan candidates per command
    max_regenerations: int = 3  # feasibility-repair rounds per candidate (bounded loop)
    # true: like Inter-LLM, SayPlan and MoMa-LLM propose commands 2.. from the current scene and
    # state, excluding delivered objects (only Inter-LLM's prompts carry known costs); false: they
    # take every command's plans from the mission-start candidates
    fair_baselines: bool = True
    # Python modules imported (in every process, the missions stage's workers too) before planners
    # are looked up: a planner defined outside this package registers itself there with
    # @PLANNERS.register (docs/extending.md)
    modules: list[str] = field(default_factory=list)
    # each built-in planner's own settings; a variant registered with ablates=<name> reads <name>'s
    inter_llm: InterLLMConfig = field(default_factory=InterLLMConfig)
    sayplan: SayPlanConfig = field(default_factory=SayPlanConfig)
    moma_llm: MoMaLLMConfig = field(default_factory=MoMaLLMConfig)
    # the nodes planner.<name> of planners defined outside the package, as composed ({name: {key:
    # value}}): from_dict puts them here, interllm.stages.validate checks each against the dataclass
    # its planner registers once planner.modules are imported. Not a config key of its own: the Hydra
    # schema leaves it out and to_dict writes each node back under planner.<name>
    external: dict = field(default_factory=dict, metadata={"internal": True})

    def validate(self) -> None:
        _check(len(self.names) >= 1, "planner.names", "must list at least one planner")
        bad = [m for m in self.modules if not re.fullmatch(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*", m)]
        _check(not bad, "planner.modules", f"must list importable module names (a.b.c), got {bad}")
        _check(len(set(self.names)) == len(self.names), "planner.names", "has duplicates")
        _check(1 <= self.M <= 20, "planner.M", f"must be in [1, 20], got {self.M}")
        _check(0 <= self.max_regenerations <= 20, "planner.max_regenerations", "must be in [0, 20]")
        self.inter_llm.validate()
        self.sayplan.validate()
        self.moma_llm.validate()


PLANNER_NODES = {"inter_llm": InterLLMConfig, "sayplan": SayPlanConfig, "moma_llm": MoMaLLMConfig}


INTERVAL_METHODS = ("cluster_bootstrap", "cr2")  # metrics.interval (interllm.metrics.stats)

@dataclass
class MetricsConfig:
    gamma_obj: float = 100.0  # unfulfilled-object normalising factor γ_obj
    # the γ_obj values of the report's sensitivity table (m_overall recomputed per slot)
    gamma_obj_sensitivity: list[float] = field(default_factory=lambda: [100.0, 200.0, 500.0, 1000.0])
    bootstrap_samples: int = 2000
    ci: float = 0.95
    seed: int = 0
    # how intervals are made (interllm.metrics.stats): "cluster_bootstrap" resamples houses, then
    # missions (bootstrap_samples, seed); "cr2" is the CR2 t interval with Bell–McCaffrey degrees
    # of freedom (interllm.metrics.cluster_t), whose coverage tests/test_interval_coverage.py checks
    interval: str = "cluster_bootstrap"
    # the judged planner: the one whose paired differences against every other planner (the
    # anchors nothing and optimal aside) the report gives and whose claims it checks
    judge: str = "inter_llm"

    def validate(self) -> None:
        _check(self.gamma_obj >= 0, "metrics.gamma_obj", "must be >= 0")
        _check(bool(self.judge.strip()), "metrics.judge", "must name a planner (one of planner.names)")
        _check(len(self.gamma_obj_sensitivity) >= 1 and all(g >= 0 for g in self.gamma_obj_sensitivity),
               "metrics.gamma_obj_sensitivity", f"must list values >= 0, got {self.gamma_obj_sensitivity}")
        _check(100 <= self.bootstrap_samples <= 100000, "metrics.bootstrap_samples",
               "must be in [100, 100000]")
        _check(0.5 <= self.ci < 1.0, "metrics.ci", f"must be in [0.5, 1), got {self.ci}")
        _choice(self.interval, "metrics.interval", INTERVAL_METHODS)


@dataclass
class ExperimentConfig:
    """The root config and every default; ``conf/config.yaml`` composes it (through the Hydra plugin
    ``hydra_plugins/interllm_schema``) with the option files' differences on top."""

    experiment: str = "paper"
    # the report section this experiment's multirun jobs feed (one of SWEEPS): `interllm report
    # --sweeps multirun` finds the jobs by it, not by the experiment's name, so a new experiment
    # file with `sweep: oracle` joins the oracle axis
    sweep: str = ""
    # the experiment's replicate: offsets the seeds of scene, mission, llm and sim (houses, mission
    # draws, LLM sampling, base-pose sampling) for a whole new draw; 0 leaves them as set.
    # metrics.seed (the bootstrap's) is not offset: replicates are judged by the same analysis
    seed: int = 0
    data_dir: str = "data"
    # the versioned benchmark (interllm/scene/benchmark.py): houses and missions frozen under
    # <benchmark_dir>/<benchmark>/, re-measured by the scenes stage, which reports every slot whose
    # measured feasibility changed since; "": generate the houses and draw the missions from this
    # run's own measurement (a simulator change then changes the missions)
    benchmark: str = ""
    benchmark_dir: str = "data/benchmarks"
    verbose: bool = False
    resume: bool = False  # skip a run already finished with this config, code, benchmark (stages/resume.py)
    jobs: int = 0  # worker processes for the missions stage (0: one per CPU core); results do not depend on it
    scenes_cache: str = ""  # scenes shared by a re-make's jobs (interllm/stages/shared_scenes.py); "": none
    scene: SceneConfig = field(default_factory=SceneConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    llm: LLMConfig = field(default_factory=LLMConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    metrics: MetricsConfig = field(default_factory=MetricsConfig)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        _check(0 <= self.seed <= SEED_MAX, "seed", f"must be in [0, {SEED_MAX}] (the experiment's replicate; 0: each "
                                                   f"group's own seed), got {self.seed}")
        if isinstance(self.jobs, bool) or not isinstance(self.jobs, int) or self.jobs < 0:
            raise ConfigError(f"config key 'jobs' must be an integer >= 0 (0: one worker per CPU core), "
                              f"got {self.jobs!r}")
        _choice(self.sweep, "sweep", SWEEPS)
        _check(self.benchmark == "" or BENCHMARK_NAME.fullmatch(self.benchmark) is not None, "benchmark",
               f"must be '' (draw from this run's measurement) or a benchmark name: 1-64 characters of a-z, 0-9, "
               f"'.', '_', '-', starting with a letter or digit (e.g. paper-v2), got {self.benchmark!r}")
        _check(bool(self.benchmark_dir.strip()), "benchmark_dir", "must name the folder holding the benchmarks")
        for group in (self.scene, self.mission, self.llm, self.planner, self.sim, self.metrics):
            group.validate()

    def seeded(self) -> ExperimentConfig:
        """The config the stages run: each seeded group's seed offset by the top-level ``seed`` (the
        replicate), metrics' not; ``seed`` 0 returns this config itself."""
        if self.seed == 0:
            return self
        offset = {g: dataclasses.replace(getattr(self, g), seed=getattr(self, g).seed + self.seed)
                  for g in SEEDED_GROUPS}
        return dataclasses.replace(self, **offset)


BENCHMARK_NAME = re.compile(r"[a-z0-9][a-z0-9._-]{0,63}")  # config key benchmark: one folder name
SEED_MAX = 2**31 - 1  # the top-level seed's largest value (a 32-bit seed offset)
SEEDED_GROUPS = ("scene", "mission", "llm", "sim")  # the groups whose seed the top-level seed offsets

_GROUPS = {"scene": SceneConfig, "mission": MissionConfig, "llm": LLMConfig, "planner": PlannerConfig,
           "sim": SimConfig, "metrics": MetricsConfig}


def from_dict(d: dict, source: str = "") -> ExperimentConfig:
    """Build and validate an ExperimentConfig from a plain nested dict (e.g. params.yaml).

    Checks every value's type against the dataclass annotations and rejects unknown keys (also
    those added with Hydra's ``+key=value``), naming the key, ``source`` and the valid choices. Under
    ``planner``, a mapping under a name that is no PlannerConfig key is the node of a planner defined
    outside the package (``PlannerConfig.external``, checked once its module is imported).
    """
    def group(k, v):
        data = {} if v is None else v
        return _planner_from_dict(data, source) if k == "planner" else build_section(_GROUPS[k], data, f"{k}.", source)

    if isinstance(d, dict):
        d = {k: (group(k, v) if k in _GROUPS else v) for k, v in d.items()}
    return build_section(ExperimentConfig, d, "", source)


def _planner_from_dict(data: dict, source: str) -> PlannerConfig:
    """The ``planner`` group: its own keys and built-in nodes typed; a mapping under any other name
    kept as an external planner's node; a flat key the nodes replaced named with its new key."""
    if not isinstance(data, dict):
        raise ConfigError(f"config key 'planner'{f' (in {source})' if source else ''} must be a mapping of "
                          f"keys, got {data!r}")
    own = {f.name for f in dataclasses.fields(PlannerConfig) if not f.metadata.get("internal")}
    for key in data:
        if key in LEGACY_PLANNER_KEYS:
            node, new = LEGACY_PLANNER_KEYS[key]
            raise ConfigError(f"config key 'planner.{key}'{f' (in {source})' if source else ''} is now "
                              f"'planner.{node}.{new}' (each planner's own settings are under planner.<name>); "
                              f"write planner.{node}.{new}={data[key]}")
    external = {k: v for k, v in data.items() if k not in own and isinstance(v, dict)}
    cfg = build_section(PlannerConfig, {k: v for k, v in data.items() if k not in external and k not in PLANNER_NODES},
                        "planner.", source)
    for name, cls in PLANNER_NODES.items():
        setattr(cfg, name, build_section(cls, {} if data.get(name) is None else data[name], f"planner.{name}.", source))
    cfg.external = {k: dict(v) for k, v in external.items()}
    return cfg


def to_dict(cfg: ExperimentConfig) -> dict:
    """The config as a plain nested dict, as it is composed: each external planner's node under
    ``planner.<name>``."""
    out = dataclasses.asdict(cfg)
    out["planner"].update(out["planner"].pop("external"))
    return out
