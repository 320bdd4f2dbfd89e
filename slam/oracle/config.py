"""OracleConfig: the oracle has nothing to estimate, only the output map to build."""
from __future__ import annotations

from dataclasses import dataclass, field

from slam.output_map import OutputMapConfig

__all__ = ["OracleConfig"]


@dataclass(frozen=True)
class OracleConfig:
    """Oracle mapping: only the output map (the block every algorithm has)."""

    output_map: OutputMapConfig = field(default_factory=OutputMapConfig)
