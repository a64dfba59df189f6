"""The ``nothing`` anchor: a planner that does nothing.

Every slot of every command stays unfilled, so its m_overall is what the scoring rule charges for
not acting at all (``γ_man + γ_obj`` per slot). The report places every other planner between this
anchor (position 0) and the ``optimal`` one (position 1); a planner that scores worse than
doing nothing has a negative position. It calls no LLM and moves nothing.
"""

from __future__ import annotations

from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import finish, new_result
from interllm.scene.graph import Command


@PLANNERS.register("nothing", label="Nothing (anchor)", color="0.6", order=3, anchor=True)
class NothingPlanner:
    name = "nothing"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        result.notes.append("the nothing anchor does not act")
        return finish(ctx, result)
