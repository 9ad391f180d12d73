"""`[operator.commands]`: does the agent handle what each declared command produces?

The declarations themselves are read by `mrss.config.operator_declarations` (a mistake
is an error at its key's line, with "did you mean"); here each command's percept is
held against the agent's plans: a command whose percept no `+name(...)` plan of that
arity reacts to would be sent, accepted by the events manager and then ignored, so the
operator would believe an exclusion zone is in place that no robot knows of. That is
an error, naming the closest predicates the agent does react to.
"""

from __future__ import annotations

from mrss.check.agent import AgentUses
from mrss.check.findings import Report, did_you_mean
from mrss.check.toml_lines import key_line
from mrss.config.operator import SECTION, OperatorConfig
from mrss.config.operator_declarations import COMMANDS_KEY
from mrss.config.project import ProjectConfig


def check_commands(config: ProjectConfig, report: Report, operator: OperatorConfig,
                   uses: AgentUses | None, *, events_running: bool) -> None:
    """Findings for the declared commands (none without `[operator.commands]`)."""
    if not operator.commands:
        return
    file = str(config.file)
    if not events_running:
        key = f"{SECTION}.{COMMANDS_KEY}"
        report.error(file, "[operator.commands] declares commands, but no events manager "
                     "runs (kind = \"events\") to make them percepts",
                     line=key_line(config, key), check="operator", key=key)
    if uses is None:
        return  # the agent did not parse: its own error says why
    handled = {(t.name, t.arity) for t in uses.triggers}
    names = {t.name for t in uses.triggers}
    for spec in operator.commands.values():
        if (spec.functor, spec.arity) in handled:
            continue
        key = f"{SECTION}.{COMMANDS_KEY}.{spec.name}.percept"
        other = f" (it has +{spec.functor} of another arity)" if spec.functor in names else \
            did_you_mean(spec.functor, names, what="it handles")
        report.error(file, f"[operator.commands.{spec.name}] becomes {spec.functor}/"
                     f"{spec.arity}, but {uses.file.name} has no +{spec.functor}(...) plan "
                     f"for it{other}", line=key_line(config, key), check="operator", key=key)
    listed = ", ".join(f"{s.name} -> {s.functor}/{s.arity}" for s in operator.commands.values())
    report.summary.append(f"  operator commands: {listed}")


def command_functors(operator: OperatorConfig | None) -> set[str]:
    """The percepts the declared commands produce (the events manager publishes them)."""
    return {s.functor for s in operator.commands.values()} if operator else set()
