"""A metric that is not registered on import: the entry-point test registers it."""
from dataclasses import dataclass

from metrics.registry import Column, Metric
from metrics.result import Result, keys_of


@dataclass(frozen=True)
class PluginPoints(Result):
    """Occupied cells of the estimate (a count any map has)."""

    plugin_points: int


PLUGIN_POINTS = Metric(
    "plugin_points", "map", keys_of(PluginPoints),
    compute=lambda ctx: PluginPoints(int(len(ctx.est_points))),
    columns=(Column("plugin_points", "occupied cells of the estimate", 0),))
