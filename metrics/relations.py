"""The relation-based SLAM metric of Kuemmerle et al. 2009 ("On measuring the accuracy of SLAM
algorithms", Autonomous Robots 27(4)), computed as Cartographer's compute_relations_metrics does.

A relations file holds one relation a line, `t1 t2 x y z roll pitch yaw`: the pose at t2 in the
robot frame of the pose at t1 (the Freiburg / Radish files; z, roll and pitch are 0 in 2D).
For estimated poses P1, P2 at t1, t2 and the relation D, the error is
    E = (P1^-1 * P2) * D^-1
with translational error |t(E)| (m) and rotational error |angle(E)| (rad, wrapped), and the
report holds mean and sample standard deviation (N - 1) of the absolute and squared
translational errors (m, m^2) and of the absolute and squared rotational errors
(degrees, deg^2), as Cartographer prints them.

Looking a pose up at a relation timestamp t:
  * lookup="interpolate" (Cartographer): linear interpolation between the two trajectory poses
    around t (yaw along the shorter arc); t outside the trajectory's time span: the relation is
    skipped and counted (Cartographer aborts there);
  * with odometry (times (M,), poses (M, 3)) given: the trajectory pose P_k of the scan nearest
    in time is carried to t with the odometry motion between them,
    P(t) = P_k * (O(t_k)^-1 * O(t)), O interpolated in the odometry. A SLAM that keeps only
    some scans (the CSAIL .gfs holds 406 of 1988) has no pose at most relation times, and
    chaining odometry onto the nearest scan pose is what its own motion model would predict;
  * lookup="exact": only trajectory poses within `tolerance` seconds of t (the Radish README's
    check of the corrected CSAIL poses uses this: 129 of 1172 relations).
"""
from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from worlds.jsonio import dumps
from worlds.yamlio import InputError
from sim.logs.tum import read_number_rows
from slam.pose import compose, interpolate_poses, inverse, wrap_angle

__all__ = ["Relations", "read_relations", "write_relations", "lookup_poses", "relation_errors",
           "relations_error", "relations_from_files", "add_relations_arguments", "relations_main", "format_relations",
           "LOOKUPS", "STAT_KEYS"]

LOOKUPS = ("interpolate", "exact")
STAT_KEYS = ("abs_trans_mean", "abs_trans_std", "sq_trans_mean", "sq_trans_std",
             "abs_rot_deg_mean", "abs_rot_deg_std", "sq_rot_deg2_mean", "sq_rot_deg2_std")


@dataclass(frozen=True, eq=False)
class Relations:
    """Ground-truth relations: t1, t2 (R,) s; delta (R, 3) x, y (m), yaw (rad) of the pose at t2
    in the frame of the pose at t1."""

    t1: np.ndarray
    t2: np.ndarray
    delta: np.ndarray

    def __post_init__(self):
        t1 = np.asarray(self.t1, dtype=np.float64).reshape(-1)
        t2 = np.asarray(self.t2, dtype=np.float64).reshape(-1)
        d = np.asarray(self.delta, dtype=np.float64).reshape(-1, 3)
        if not (len(t1) == len(t2) == len(d)):
            raise ValueError(f"Relations: {len(t1)} t1, {len(t2)} t2, {len(d)} deltas")
        object.__setattr__(self, "t1", t1)
        object.__setattr__(self, "t2", t2)
        object.__setattr__(self, "delta", d)

    def __len__(self) -> int:
        return len(self.t1)


def read_relations(path: str | os.PathLike) -> Relations:
    """Read a relations text file (`t1 t2 x y z roll pitch yaw` a line, any blanks between).

    Blank and '#' lines are skipped. A line without 8 numbers, a non-finite number, a relation
    with roll or pitch (not planar) or a file without relations raises InputError naming the
    file and the line.
    """
    p, a, linenos = read_number_rows(path, "t1 t2 x y z roll pitch yaw", "no relations (not a relations file?)")
    tilted = np.flatnonzero((np.abs(a[:, 5]) > 1e-6) | (np.abs(a[:, 6]) > 1e-6))
    if len(tilted):
        i = tilted[0]
        raise InputError(f"{p}: line {linenos[i]}: roll/pitch {a[i, 5]}, {a[i, 6]} not zero "
                         "(a 2D metric needs planar relations)")
    return Relations(a[:, 0], a[:, 1], a[:, [2, 3, 7]])


def write_relations(path: str | os.PathLike, relations: Relations) -> None:
    """Write `relations` as a relations text file (what read_relations reads), atomically."""
    from worlds.yamlio import atomic_write_text
    lines = [f"{a:.6f} {b:.6f} {d[0]:.9g} {d[1]:.9g} 0 0 0 {d[2]:.9g}"
             for a, b, d in zip(relations.t1, relations.t2, relations.delta)]
    atomic_write_text(path, "\n".join(lines) + "\n")


def _check_trajectory(times, poses, what: str) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(t) != len(p):
        raise InputError(f"{what}: {len(t)} times but {len(p)} poses")
    if len(t) == 0:
        raise InputError(f"{what}: no poses")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{what}: times must increase strictly")
    return t, p


def lookup_poses(tq: np.ndarray, times: np.ndarray, poses: np.ndarray,
                 odom: tuple[np.ndarray, np.ndarray] | None = None,
                 lookup: str = "interpolate", tolerance: float = 1e-5) -> np.ndarray:
    """(Q, 3) trajectory poses at the query times tq (Q,) s; rows of NaN where there is none.

    times (N,) s increasing, poses (N, 3); odom: (times (M,), poses (M, 3)) or None.
    See the module docstring for the three lookups.
    """
    if lookup not in LOOKUPS:
        raise InputError(f"unknown lookup '{lookup}' (known: {', '.join(LOOKUPS)})")
    tq = np.asarray(tq, dtype=np.float64).reshape(-1)
    t, p = _check_trajectory(times, poses, "trajectory")
    out = np.full((len(tq), 3), np.nan)
    # nearest trajectory node of every query
    if len(t) == 1:
        near = np.zeros(len(tq), dtype=int)
    else:
        j = np.clip(np.searchsorted(t, tq), 1, len(t) - 1)
        near = np.where(np.abs(tq - t[j - 1]) <= np.abs(t[j] - tq), j - 1, j)
    if lookup == "exact":
        ok = np.abs(t[near] - tq) <= tolerance
        out[ok] = p[near[ok]]
        return out
    if odom is None:
        ok = (tq >= t[0] - tolerance) & (tq <= t[-1] + tolerance)
        if len(t) == 1:
            out[ok] = p[0]
        else:
            out[ok] = interpolate_poses(np.clip(tq[ok], t[0], t[-1]), t, p)
        return out
    ot, op = _check_trajectory(odom[0], odom[1], "odometry")
    # odometry exists only over its own span; the scan node must lie in it too
    ok = (tq >= ot[0] - tolerance) & (tq <= ot[-1] + tolerance)
    ok &= (t[near] >= ot[0] - tolerance) & (t[near] <= ot[-1] + tolerance)
    o_q = interpolate_poses(np.clip(tq[ok], ot[0], ot[-1]), ot, op)
    o_k = interpolate_poses(np.clip(t[near[ok]], ot[0], ot[-1]), ot, op)
    out[ok] = compose(p[near[ok]], compose(inverse(o_k), o_q))
    return out


def relation_errors(pose1: np.ndarray, pose2: np.ndarray, delta: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per-relation errors of E = (P1^-1 P2) D^-1: translational (R,) m and rotational (R,) rad >= 0.

    pose1, pose2, delta: (R, 3) x, y, yaw.
    """
    est = compose(inverse(np.asarray(pose1, float)), np.asarray(pose2, float))
    err = compose(est, inverse(np.asarray(delta, float)))
    return np.hypot(err[:, 0], err[:, 1]), np.abs(wrap_angle(err[:, 2]))


def _mean_std(v: np.ndarray) -> tuple[float, float]:
    if len(v) == 0:
        return float("nan"), float("nan")
    std = float(np.std(v, ddof=1)) if len(v) > 1 else float("nan")
    return float(np.mean(v)), std


def _stats(trans: np.ndarray, rot: np.ndarray) -> dict:
    rot_deg = np.rad2deg(rot)
    out = {"n": int(len(trans))}
    for name, v in (("abs_trans", trans), ("sq_trans", trans ** 2),
                    ("abs_rot_deg", rot_deg), ("sq_rot_deg2", rot_deg ** 2)):
        out[f"{name}_mean"], out[f"{name}_std"] = _mean_std(v)
    out["max_trans"] = float(trans.max()) if len(trans) else float("nan")
    out["max_rot_deg"] = float(rot_deg.max()) if len(rot) else float("nan")
    return out


def relations_error(times: np.ndarray, poses: np.ndarray, relations: Relations,
                    odom: tuple[np.ndarray, np.ndarray] | None = None, *,
                    lookup: str = "interpolate", tolerance: float = 1e-5,
                    long_s: float = 5.0) -> dict:
    """Score a trajectory (times (N,) s, poses (N, 3)) against `relations`.

    odom: optional (times (M,), poses (M, 3)) odometry for the poses between scans.
    Returns a dict: n_relations, n_used, n_skipped (no pose at one of the two times), lookup,
    the statistics over the used relations (n, abs_trans_mean/std m, sq_trans_mean/std m^2,
    abs_rot_deg_mean/std, sq_rot_deg2_mean/std, max_trans, max_rot_deg; std is the sample
    standard deviation, NaN below 2 relations), and the same statistics under "short" and
    "long" for the relations with |t2 - t1| < long_s and >= long_s seconds.
    """
    p1 = lookup_poses(relations.t1, times, poses, odom, lookup, tolerance)
    p2 = lookup_poses(relations.t2, times, poses, odom, lookup, tolerance)
    ok = np.isfinite(p1[:, 0]) & np.isfinite(p2[:, 0])
    trans, rot = relation_errors(p1[ok], p2[ok], relations.delta[ok])
    span = np.abs(relations.t2 - relations.t1)[ok]
    out = {"n_relations": int(len(relations)), "n_used": int(ok.sum()),
           "n_skipped": int((~ok).sum()),
           "lookup": "odometry" if (odom is not None and lookup == "interpolate") else lookup}
    out.update(_stats(trans, rot))
    out["long_s"] = float(long_s)
    out["short"] = _stats(trans[span < long_s], rot[span < long_s])
    out["long"] = _stats(trans[span >= long_s], rot[span >= long_s])
    return out


def _read_odometry(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Odometry (times, poses) from a sensor log: .npz, or a CARMEN / .gfs log."""
    p = Path(path)
    if p.suffix == ".npz":
        from sim.logs import read_log
        log = read_log(p)
    else:
        from sim.logs import import_log
        log = import_log(p)
    if not log.has_odometry:
        raise InputError(f"{p}: the log has no odometry")
    return log.odom_t, log.odom_pose


def relations_from_files(traj_path: str | os.PathLike, relations_path: str | os.PathLike,
                         odom_path: str | os.PathLike | None = None, *,
                         lookup: str = "interpolate", tolerance: float = 1e-5,
                         long_s: float = 5.0) -> dict:
    """relations_error of a TUM trajectory file against a relations file.

    odom_path: optional sensor log (.npz, CARMEN or .gfs) whose odometry carries the trajectory
    between its poses. Adds "trajectory" and "relations" (the paths) to the result.
    """
    from sim.logs.tum import read_tum
    t, poses = read_tum(traj_path)
    rel = read_relations(relations_path)
    odom = _read_odometry(odom_path) if odom_path is not None else None
    out = relations_error(t, poses, rel, odom, lookup=lookup, tolerance=tolerance, long_s=long_s)
    out["trajectory"] = str(traj_path)
    out["relations"] = str(relations_path)
    if odom_path is not None:
        out["odometry"] = str(odom_path)
    return out


def format_relations(res: dict) -> str:
    """Human-readable lines in the layout Cartographer prints (5 decimals)."""
    def block(s: dict, title: str) -> list[str]:
        if s["n"] == 0:
            return [f"{title}: no relations"]
        return [f"{title}: {s['n']} relations",
                f"  Abs translational error {s['abs_trans_mean']:.5f} +/- {s['abs_trans_std']:.5f} m",
                f"  Sqr translational error {s['sq_trans_mean']:.5f} +/- {s['sq_trans_std']:.5f} m^2",
                f"  Abs rotational error {s['abs_rot_deg_mean']:.5f} +/- {s['abs_rot_deg_std']:.5f} deg",
                f"  Sqr rotational error {s['sq_rot_deg2_mean']:.5f} +/- {s['sq_rot_deg2_std']:.5f} deg^2"]
    lines = [f"relations: {res['n_used']} of {res['n_relations']} scored "
             f"({res['n_skipped']} without a pose at both times; lookup: {res['lookup']})"]
    lines += block(res, "all")
    lines += block(res["short"], f"t2 - t1 < {res['long_s']:g} s")
    lines += block(res["long"], f"t2 - t1 >= {res['long_s']:g} s")
    return "\n".join(lines)


def add_relations_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `python -m metrics relations`."""
    from worlds.cli import non_negative_float
    parser.add_argument("--traj", required=True, help="estimated trajectory, TUM text file")
    parser.add_argument("--relations", required=True, help="relations file (t1 t2 x y z roll pitch yaw)")
    parser.add_argument("--odom", default=None,
                        help="sensor log (.npz, CARMEN or .gfs) whose odometry carries the "
                             "trajectory to relation times between its poses")
    parser.add_argument("--lookup", choices=LOOKUPS, default="interpolate",
                        help="interpolate between poses (default) or use only poses within "
                             "--tolerance of each relation time")
    parser.add_argument("--tolerance", type=non_negative_float, default=1e-5,
                        help="s, for --lookup exact")
    parser.add_argument("--long", dest="long_s", type=non_negative_float, default=5.0,
                        help="relations spanning at least this many seconds are also reported apart")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def relations_main(args: argparse.Namespace) -> int:
    """Run `metrics relations` for parsed args; InputError propagates to the CLI's handler."""
    res = relations_from_files(args.traj, args.relations, getattr(args, "odom", None),
                               lookup=getattr(args, "lookup", "interpolate"),
                               tolerance=getattr(args, "tolerance", 1e-5),
                               long_s=getattr(args, "long_s", 5.0))
    if getattr(args, "json", False):
        print(dumps(res, sort_keys=True))
    else:
        print(format_relations(res))
    return 0
