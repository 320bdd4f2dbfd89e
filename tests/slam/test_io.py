"""write_result / read_result: the files docs/formats.md lists, read back."""
import json

import numpy as np

from slam.base import SlamResult
from slam.io import read_result, write_result
from worlds.grid import Grid


def _result():
    prob = np.full((6, 8), np.nan)
    prob[1, 1:7] = 1.0
    prob[2:5, 1:7] = 0.0
    grid = Grid(prob, 0.05, np.array([-0.1, 0.2, 0.0]))
    t = np.array([0.0, 0.2, 0.4])
    poses = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.5], [0.2, 0.05, -3.0]])
    return SlamResult(grid, t, poses, {"wall_time_s": 0.1, "realtime_factor": 4.0, "scans_processed": 3},
                      {"map_resolution": 0.05, "nested": {"a": [1, 2]}})


def test_writes_the_design_files_and_reads_them_back(tmp_path):
    res = _result()
    write_result(res, tmp_path / "out")
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["config.yaml", "map.pgm", "map.yaml", "stats.json", "trajectory.tum"]
    back = read_result(tmp_path / "out")
    assert back.grid.equals(res.grid)
    np.testing.assert_allclose(back.times, res.times)
    np.testing.assert_allclose(back.poses, res.poses, atol=1e-9)
    assert back.stats == res.stats
    assert back.config == res.config
    assert json.loads((tmp_path / "out" / "stats.json").read_text())["realtime_factor"] == 4.0
    line = (tmp_path / "out" / "trajectory.tum").read_text().splitlines()[0].split()
    assert len(line) == 8 and line[3] == "0"   # TUM: t x y z qx qy qz qw, z = 0
