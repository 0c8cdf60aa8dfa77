"""The conventions of ``--help`` for every subcommand (see docs/cli.md): a flag shows no value type (typer
prints ``<bool>`` next to ``--resume``, which takes no value), and the usage line names arguments in
capitals, ``breachflow ingest [OPTIONS] FILES...`` (typer writes a required argument ``{files}...``)."""
from __future__ import annotations


def install() -> None:
    """Adjust typer's help rendering once (idempotent)."""
    import typer.core as core

    if getattr(core, "_breachflow_help", False):
        return
    core._breachflow_help = True
    display_type_rich = core.TyperOption.display_type_rich

    def option_type(self, ctx):
        if getattr(self, "is_flag", False) or getattr(self, "count", False):
            return None  # a flag takes no value
        return display_type_rich(self, ctx)

    core.TyperOption.display_type_rich = option_type

    def usage_name(self) -> str:
        name = (self.metavar or self.name or "").upper()
        name = name if self.required else f"[{name}]"
        return name + ("..." if self.nargs != 1 else "")

    if hasattr(core.TyperArgument, "_usage_display_name"):
        core.TyperArgument._usage_display_name = usage_name
