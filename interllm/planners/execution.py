"""Executing a plan with the rule every planner shares for failures.

``execute_plan`` runs a plan action by action (``world.execute``), adding every result to the
known costs and the run log. When an action fails (or is not executable in the current state,
checked symbolically just before execution), the rest of that object's actions are skipped (the
object is not delivered) and execution continues with the next object. If the robot still holds
the object, it first puts it back on the furniture it came from (recovery actions are executed
and counted like any other). A planner may pass a ``replanner`` (MoMa-LLM) that returns new
remaining actions after a failure.

``open_baseline_command`` is the opening SayPlan and MoMa-LLM share: the baseline's candidates,
logged, and the first one feasible within the repair bound.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Optional

from interllm.core.actions import Action, Plan, State, plan_to_list
from interllm.core.results import ActionResult
from interllm.planners.base import CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.repair import first_feasible
from interllm.planning.feasibility import action_violations
from interllm.scene.graph import Command, SceneGraph
from interllm.scene.placement import Placement, placement_of, surface_placement

Replanner = Callable[[Optional[ActionResult], str, Action, list[str]], Optional[Plan]]


def segments(plan: Plan) -> list[list[Action]]:
    """Split a plan into per-object segments, each ending with a place (the tail may not)."""
    out: list[list[Action]] = []
    cur: list[Action] = []
    for a in plan:
        cur.append(a)
        if a.kind == "place":
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return out


def measured_placement(scene: SceneGraph, action: Action, res: ActionResult) -> Optional[Placement]:
    """Where a manipulation's object was as it was measured (after ``world.execute``): a pickup's
    object still stands where it was taken from in the scene graph; a placed one stands at its
    new spot; a failed place has only the target surface."""
    if action.furniture not in scene.furniture or (action.obj or "") not in scene.objects:
        return None
    if action.kind == "pickup":
        return placement_of(scene, action.obj) if scene.objects[action.obj].furniture == action.furniture else None
    if action.kind == "place":
        return placement_of(scene, action.obj) if res.success else surface_placement(scene, action.furniture)
    return None


def execute(ctx: PlannerContext, action: Action, command: Command, result: CommandResult) -> ActionResult:
    """Run one action, remember its cost under the state before it, log it."""
    before: State = ctx.world.state
    res = ctx.world.execute(action)
    ctx.memory.add_result(res, before, measured_placement(ctx.world.scene, action, res))
    result.actions.append(res)
    ctx.recorder.action(res, {"planner": ctx.planner, "scene": ctx.mission.scene_id,
                              "mission": ctx.mission.id, "command": command.id})
    return res


def put_back(ctx: PlannerContext, command: Command, result: CommandResult) -> None:
    """After a failure with an object in hand: carry it back to the furniture it came from."""
    world = ctx.world
    held = world.state.holding
    if held is None:
        return
    src = world.scene.objects[held].furniture
    steps = []
    if world.state.at_furniture != src:
        steps.append(Action("navigate", src, room=world.scene.furniture[src].room))
    steps.append(Action("place", src, obj=held))
    for a in steps:
        if action_violations(a, world.scene, world.state) or not execute(ctx, a, command, result).success:
            result.notes.append(f"could not put {held} back on {src}; the robot keeps holding it")
            return
    result.notes.append(f"put {held} back on {src} after a failure")


def execute_plan(ctx: PlannerContext, command: Command, plan: Plan, result: CommandResult,
                 replanner: Optional[Replanner] = None) -> list[str]:
    """Execute ``plan`` with the skip rule (module docstring); returns the delivered objects.

    ``replanner(failed_result_or_None, failure_text, failed_action, delivered)`` may return a
    new plan for the rest of the command (or None to continue with the remaining segments).
    """
    queue = segments(plan)
    delivered: list[str] = []
    while queue:
        seg = queue.pop(0)
        failure: Optional[tuple[Optional[ActionResult], str, Action]] = None
        for a in seg:
            v = action_violations(a, ctx.world.scene, ctx.world.state)
            if v:
                failure = (None, "not executable: " + "; ".join(x.text for x in v), a)
                break
            res = execute(ctx, a, command, result)
            if not res.success:
                failure = (res, res.reason or f"{a} failed", a)
                break
            if a.kind == "place":
                delivered.append(a.obj)
                ctx.command_delivered.append(a.obj)
        if failure is None:
            continue
        res, text, a = failure
        head = "" if text.startswith(str(a)) else f"{a}: "
        result.notes.append(f"{head}{text}; skipping the rest of this object's actions")
        put_back(ctx, command, result)
        if replanner is not None:
            new = replanner(res, text, a, list(delivered))
            if new is not None:
                queue = segments(new)
    return delivered


def new_result(command: Command) -> CommandResult:
    return CommandResult(command_id=command.id)


def finish(ctx: PlannerContext, result: CommandResult) -> CommandResult:
    """Fill in the command's LLM usage."""
    result.llm_calls = ctx.tally.calls
    result.llm_tokens_in = ctx.tally.tokens_in
    result.llm_tokens_out = ctx.tally.tokens_out
    return result


def open_baseline_command(ctx: PlannerContext, command: Command, *, max_rounds: int,
                          note_no_candidates: bool = False) -> tuple[CommandResult, Optional[Plan]]:
    """SayPlan's and MoMa-LLM's opening of a command: start it, take the baseline's candidates
    (``ctx.candidates``), log them on /planner/candidates and select the first one feasible
    within ``max_rounds`` repairs (``repair.first_feasible``).

    Returns the command's result (its ``selected_plan`` set) and the selected plan, or None with a
    note saying why: no candidates at all (that note only with ``note_no_candidates``) or none
    feasible."""
    ctx.start_command()
    result = new_result(command)
    proposed, source = ctx.candidates(command)
    ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(p) for p in proposed],
                                               "source": source})
    if note_no_candidates and not proposed:
        result.notes.append(f"no initial candidates for command {command.id!r}")
        return result, None
    selected = first_feasible(ctx, command, proposed, max_rounds, result)
    if selected is None:
        result.notes.append("no feasible candidate: nothing executed for this command")
        return result, None
    result.selected_plan = selected
    return result, selected
