"""What one planning call is about: :class:`PlanRequest`, the input every plan proposal, repair and
replan takes (``planning.proposers`` and the modes behind it: ``planning.generation``,
``planning.expansion``, ``planning.scoring``), and :class:`Exclusions`, what its plans must avoid.

What differs between the calls of one request (how many plans, the seed, the repair round, the
candidate's number, the failure text) is passed beside it as keyword arguments.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from interllm.core.actions import State
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import Command, SceneGraph


@dataclass(frozen=True)
class Exclusions:
    """Objects a plan must not take and furniture it must not deliver to (sorted ids)."""

    objects: tuple[str, ...] = ()
    targets: tuple[str, ...] = ()


@dataclass(frozen=True)
class PlanRequest:
    """A plan asked for ``command`` in ``scene`` from ``state``.

    n_objects: how many objects the plan should deliver (the command's, or what is left of it);
    known: the known costs its prompts may show (None: none are shown); exclude: the objects and
    targets it must avoid; context: the call-log labels of its LLM calls ((key, value) pairs)."""

    scene: SceneGraph
    state: State
    command: Command
    n_objects: int
    known: Optional[KnownCosts] = None
    exclude: Exclusions = Exclusions()
    context: tuple = ()
