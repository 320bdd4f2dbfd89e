"""Imports the built-in algorithm modules so their @register decorators run."""
import importlib

# pf, gn, graph, oracle: each module registers its class with slam.base.register.
for _name in ("oracle", "gn", "pf", "graph"):
    try:
        importlib.import_module(f"slam.{_name}")
    except ModuleNotFoundError as _err:  # a family not built yet in this checkout
        if _err.name != f"slam.{_name}":
            raise
