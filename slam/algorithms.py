"""Imports the built-in algorithm modules so their @register decorators run."""
import slam.gn  # noqa: F401
import slam.graph  # noqa: F401
import slam.oracle  # noqa: F401
import slam.pf  # noqa: F401
