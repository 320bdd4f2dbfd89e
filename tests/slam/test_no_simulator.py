"""A SLAM reads its input through sim.logs alone: importing slam, reading a log and running an
algorithm on it (a fresh interpreter, so no other test has loaded anything) imports neither
pymunk nor any of sim's simulator modules (robot, record, sensors, noise)."""
import subprocess
import sys
from pathlib import Path

import numpy as np

from sim.logs import write_log
from tests.slam.synthlog import box_room_segments, make_log

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import sys
import slam, slam.replay
from sim.logs import read_log
result = slam.run_algorithm("oracle", read_log(sys.argv[1]))
assert len(result.times) > 0
print(" ".join(sorted(m for m in sys.modules
                      if m.split(".")[0] == "pymunk"
                      or (m.startswith("sim.") and not m.startswith("sim.logs")))))
"""


def test_reading_a_log_and_running_a_slam_loads_no_simulator(tmp_path):
    log = make_log(box_room_segments(), np.array([[1.0, 1.0], [1.6, 1.0]]), seed=1)
    write_log(log, tmp_path / "log.npz")
    done = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path / "log.npz")], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == [], f"loaded: {done.stdout.strip()}"
