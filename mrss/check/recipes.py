"""Which actions a project's RCL handles, and whether the skills its recipes name exist.

How `mrss check` knows statically which actions a layer handles (docs/projects.md,
"Which actions the RCL handles"):
1. a class attribute `actions = {"name": arity, ...}` on the layer (arity None: any) is the
   declaration; a layer that overrides `action_cb` (its own action convention) must have it;
2. otherwise `refine_action` is read with `ast`: every `if` whose test compares the action's
   name (`action.name`, or a local assigned from it) `== "name"` (or `in (...)`) is a
   recipe, and a `len(action.args) == N` in the same test is its arity (else any arity);
   the skills of a recipe are the `skills.X(...)` / `X(...)` calls in that branch;
3. a layer with no recipe at all handles no action.
Every environment action of agent.asl (each arity used) needs a recipe; every skill a
recipe names must be a Skill subclass of skills.py; every Skill subclass's start, run,
finish and terminate must take what the base class's take (the RCL calls them so).
"""

from __future__ import annotations

import ast
import inspect
from dataclasses import dataclass, field
from typing import Any

from mrss.api import RobotCommLayer, Skill
from mrss.check.agent import AgentUses
from mrss.check.findings import Report, did_you_mean
from mrss.check.sources import PySource

HOOKS = ("start", "run", "finish", "terminate")
ANY = None


@dataclass
class Recipe:
    """One action the layer handles: its name, arity (None: any), and the skills it names."""

    name: str
    arity: int | None
    line: int
    skills: list[tuple[str, int, int]] = field(default_factory=list)  # (class, line, col)


@dataclass
class LayerActions:
    """What the layer handles; `known` False when it cannot be told statically."""

    recipes: list[Recipe]
    known: bool = True
    how: str = "refine_action"

    def handles(self, name: str, arity: int) -> bool:
        return any(r.name == name and r.arity in (ANY, arity) for r in self.recipes)

    def describe(self) -> str:
        return ", ".join(sorted({r.name + ("" if r.arity is None else f"/{r.arity}")
                                 for r in self.recipes})) or "none"


def layer_actions(layer: type[RobotCommLayer], source: PySource, report: Report) -> LayerActions:
    """The recipes of `layer`, from its `actions` declaration or its refine_action."""
    declared = vars(layer).get("actions")
    node = source.class_node(layer.__name__)
    refine = _method(node, "refine_action") if node else None
    parsed = _recipes(refine) if refine is not None else []
    if declared is not None:
        recipes = _declared(declared, layer, source, report)
        by_name = {r.name: r for r in parsed}
        for r in recipes:  # the skills the matching branches name are still checked
            r.skills = by_name[r.name].skills if r.name in by_name else []
        return LayerActions(recipes, how="actions")
    if "action_cb" in vars(layer):
        report.warning(str(source.path), f"{layer.__name__} overrides action_cb: declare the "
                       "actions it handles, e.g. actions = {\"move\": 4}, to have them checked",
                       line=source.line_of(layer), check="recipes")
        return LayerActions(parsed, known=False)
    if refine is None:
        return LayerActions([], how="none (no refine_action)")
    if not parsed:
        report.warning(str(source.path), f"{layer.__name__}.refine_action compares no action "
                       "name with a string: declare actions = {\"name\": arity} to have the "
                       "agent's actions checked", line=refine.lineno, check="recipes")
        return LayerActions([], known=False)
    return LayerActions(parsed)


def _declared(value: Any, layer: type, source: PySource, report: Report) -> list[Recipe]:
    line = source.line_of(layer)
    if not isinstance(value, dict) or not all(
            isinstance(k, str) and (v is None or (isinstance(v, int) and not isinstance(v, bool)))
            for k, v in value.items()):
        report.error(str(source.path), f"{layer.__name__}.actions must be a dict of action "
                     f"name -> arity (None: any arity), not {value!r}", line=line,
                     check="recipes")
        return []
    return [Recipe(k, v, line) for k, v in value.items()]


def _method(node: ast.ClassDef, name: str) -> ast.FunctionDef | None:
    for item in node.body:
        if isinstance(item, ast.FunctionDef) and item.name == name:
            return item
    return None


def _recipes(method: ast.FunctionDef) -> list[Recipe]:
    param = method.args.args[1].arg if len(method.args.args) > 1 else "action"
    names = {f"{param}.name"}
    args = {f"{param}.args"}
    for node in ast.walk(method):  # locals assigned from action.name / action.args
        if isinstance(node, ast.Assign):
            for target, value in _pairs(node):
                text = ast.unparse(value)
                if text in names:
                    names.add(target)
                elif text in args:
                    args.add(target)
    recipes: list[Recipe] = []
    for node in ast.walk(method):
        if not isinstance(node, ast.If):
            continue
        found = _names_in(node.test, names)
        if not found:
            continue
        arity = _arity_in(node.test, args)
        skills = [(call_name, call.lineno, call.col_offset + 1)
                  for stmt in node.body for call in ast.walk(stmt)
                  if isinstance(call, ast.Call) and (call_name := _class_call(call))]
        recipes += [Recipe(n, arity, node.lineno, skills) for n in found]
    return recipes


def _pairs(node: ast.Assign) -> list[tuple[str, ast.expr]]:
    pairs = []
    for target in node.targets:
        if isinstance(target, ast.Name):
            pairs.append((target.id, node.value))
        elif isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple):
            pairs += [(t.id, v) for t, v in zip(target.elts, node.value.elts, strict=False)
                      if isinstance(t, ast.Name)]
    return pairs


def _names_in(test: ast.expr, names: set[str]) -> list[str]:
    found = []
    for node in ast.walk(test):
        if isinstance(node, ast.Compare) and len(node.ops) == 1 \
                and ast.unparse(node.left) in names:
            right = node.comparators[0]
            if isinstance(node.ops[0], ast.Eq) and isinstance(right, ast.Constant) \
                    and isinstance(right.value, str):
                found.append(right.value)
            elif isinstance(node.ops[0], ast.In) and isinstance(right, ast.Tuple | ast.List
                                                                  | ast.Set):
                found += [e.value for e in right.elts
                          if isinstance(e, ast.Constant) and isinstance(e.value, str)]
    return found


def _arity_in(test: ast.expr, args: set[str]) -> int | None:
    for node in ast.walk(test):
        if isinstance(node, ast.Compare) and len(node.ops) == 1 \
                and isinstance(node.ops[0], ast.Eq) and isinstance(node.left, ast.Call) \
                and ast.unparse(node.left.func) == "len" and len(node.left.args) == 1 \
                and ast.unparse(node.left.args[0]) in args:
            right = node.comparators[0]
            if isinstance(right, ast.Constant) and isinstance(right.value, int):
                return right.value
    return None


def _class_call(call: ast.Call) -> str:
    """`X` of a call `skills.X(...)` or `X(...)` where X looks like a class name."""
    func = call.func
    name = func.attr if isinstance(func, ast.Attribute) else \
        func.id if isinstance(func, ast.Name) else ""
    return name if name[:1].isupper() else ""


# -- checks ------------------------------------------------------------------------------------
def check_actions(uses: AgentUses, handled: LayerActions, layer: str, rcl_file: str,
                  report: Report) -> None:
    """An error at each agent action (first use of each arity) no recipe handles."""
    if not handled.known:
        return
    seen: set[tuple[str, int]] = set()
    for use in uses.actions:
        if (use.name, use.arity) in seen or handled.handles(use.name, use.arity):
            continue
        seen.add((use.name, use.arity))
        same = [r for r in handled.recipes if r.name == use.name]
        if same:
            arities = ", ".join(f"{r.name}/{r.arity}" for r in same)
            why = f"{layer} in {rcl_file} handles only {arities}"
        else:
            why = (f"{layer} in {rcl_file} has no recipe for it (it handles "
                   f"{handled.describe()})"
                   + did_you_mean(use.name, [r.name for r in handled.recipes], what="known"))
        report.error(str(uses.file), f"action {use.name}/{use.arity}: {why}; add a branch to "
                     "refine_action (or declare it in the layer's `actions`)", line=use.line,
                     col=use.col, check="recipes")


def check_recipe_skills(handled: LayerActions, skills: PySource | None, rcl: PySource,
                        report: Report) -> None:
    """An error at each skill a recipe names that skills.py does not define."""
    if skills is None or skills.module is None:
        return
    defined = {c.__name__ for c in skills.classes(Skill)}
    rcl_defined = {c.__name__ for c in rcl.classes(Skill)}
    other = {name for name, obj in vars(rcl.module).items() if isinstance(obj, type)} \
        if rcl.module else set()
    for recipe in handled.recipes:
        for name, line, col in recipe.skills:
            if name in defined or name in rcl_defined:
                continue
            if name in other and not _is_skill_name(name, skills):
                continue  # a class of its own (an error type, a helper), not a skill
            report.error(str(rcl.path), f"recipe {recipe.name!r} uses skill {name!r}, which "
                         f"{skills.path.name} does not define"
                         + did_you_mean(name, defined, what="its skills"),
                         line=line, col=col, check="recipes")


def _is_skill_name(name: str, skills: PySource) -> bool:
    return hasattr(skills.module, name)


def check_skill_signatures(skills: PySource, report: Report) -> None:
    """Each Skill subclass's hooks accept exactly what the RCL passes (the base's parameters)."""
    for cls in skills.classes(Skill):
        for hook in HOOKS:
            method = vars(cls).get(hook)
            if method is None or not callable(method):
                continue
            expected = _required(getattr(Skill, hook))
            own = inspect.signature(method)
            required = _required(method)
            positional = [p for p in own.parameters.values() if p.name != "self"
                          and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
            takes_rest = any(p.kind is p.VAR_POSITIONAL for p in own.parameters.values())
            base = inspect.signature(getattr(Skill, hook))
            if len(required) > len(expected) or (len(positional) < len(expected)
                                                 and not takes_rest):
                report.error(str(skills.path), f"{cls.__name__}.{hook}{_plain(own)} does not "
                             f"match Skill.{hook}{_plain(base)}: the RCL calls "
                             f"{hook}({', '.join(expected)})", line=skills.line_of(method),
                             check="skills")


def _required(function: Any) -> list[str]:
    sig = inspect.signature(function)
    return [p.name for p in sig.parameters.values()
            if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
            and p.default is p.empty and p.name != "self"]


def _plain(sig: inspect.Signature) -> str:
    return "(" + ", ".join(p.name for p in sig.parameters.values()) + ")"
