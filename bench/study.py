"""The reference study's published numbers (Zi, Wang, Santos, Zheng, "A new metric for
assessing the performance of 2D Lidar SLAMs", CERC 2020; Tables 1 and 2), for the reports.

Each of our algorithms stands beside the study's run of the family its class names
(slam.base.Slam.family): pf beside Gmapping, gn beside Hector, graph beside Cartographer, and
a plugin beside the family it declares. Values: (mean, std) over the study's 10 runs on
one recorded data set per world; ADNN in cells of 0.05 m. The paper prints the same std rows
under precision and sensitivity for Gmapping and Cartographer; they are kept as printed.
"""
from __future__ import annotations

__all__ = ["STUDY_WORLDS", "STUDY", "family_of"]

STUDY_WORLDS = ("rectangle_s", "rectangle_m", "rectangle_l", "swirl_s", "swirl_m", "swirl_l",
                "corridor")


def _table(means, stds):
    return {w: (m, s) for w, m, s in zip(STUDY_WORLDS, means, stds)}


# STUDY[algorithm][metric][world] = (mean, std)
STUDY = {
    "Gmapping": {
        "adnn_cells": _table((0.44, 0.77, 3.82, 1.28, 1.83, 2.81, 1.57),
                             (0.11, 0.25, 0.94, 0.57, 0.45, 0.54, 0.17)),
        "precision": _table((0.67, 0.44, 0.09, 0.39, 0.20, 0.13, 0.61),
                            (0.09, 0.07, 0.08, 0.15, 0.07, 0.04, 0.04)),
        "sensitivity": _table((0.89, 0.61, 0.12, 0.46, 0.22, 0.12, 0.50),
                              (0.09, 0.07, 0.08, 0.15, 0.07, 0.04, 0.04)),
    },
    "Cartographer": {
        "adnn_cells": _table((0.07, 0.28, 0.57, 0.11, 0.50, 1.02, 0.83),
                             (0.03, 0.20, 0.15, 0.01, 0.07, 0.05, 0.12)),
        "precision": _table((0.96, 0.78, 0.52, 0.92, 0.63, 0.44, 0.92),
                            (0.02, 0.17, 0.15, 0.01, 0.06, 0.04, 0.00)),
        "sensitivity": _table((0.99, 0.79, 0.61, 0.98, 0.69, 0.46, 0.90),
                              (0.02, 0.17, 0.15, 0.01, 0.06, 0.04, 0.00)),
    },
    "Hector": {
        "adnn_cells": _table((0.14, 0.16, 8.91, 0.13, 0.16, 5.16, 2.09), (0.0,) * 7),
        "precision": _table((0.88, 0.86, 0.23, 0.89, 0.86, 0.17, 0.72), (0.0,) * 7),
        "sensitivity": _table((1.00, 1.00, 0.34, 1.00, 1.00, 0.19, 0.62), (0.0,) * 7),
    },
}


def family_of(algo: str) -> str | None:
    """The study's algorithm `algo` stands beside: its class's `family` when the study ran that
    family; None for the oracle, an algorithm of another family and a map scored elsewhere."""
    from slam.registry import find
    family = getattr(find(algo), "family", None)
    return family if family in STUDY else None
