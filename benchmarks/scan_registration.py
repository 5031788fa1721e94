#!/usr/bin/env python3
"""2D scan registration: umbmark's matcher next to scipy ICP, small_gicp and KISS-ICP on the same scans.

    python benchmarks/scan_registration.py                           # writes ./umbmark-bench-scan-registration/
    python benchmarks/scan_registration.py --out benchmarks/results  # the results kept in the repository
    python benchmarks/scan_registration.py --quick                   # a few hundred pairs (seconds)

Writes scan_registration.json and scan_registration.md into --out (default: a new folder
./umbmark-bench-scan-registration). The scans come from the simulator (umbmark.model.sensors and
umbmark.model.drive): a 360-beam lidar with 5 mm range noise in the default 10 x 8 m room.

Data sets (every matcher gets the same scans and the same first guesses):

* ``drive, nominal odometry``: consecutive scans at 10 Hz of the example robot driving a mixed
  program (0.15-0.4 m/s, arcs, spins up to 1.2 rad/s); first guess: the displacement of the
  uncalibrated (nominal) odometry, the sensor pose unknown (the robot's displacement taken for
  the sensor's).
* ``drive, 2 % / 2 deg``: the same pairs; first guess: the true displacement, its translation
  2 % too long and its yaw 2 degrees off (either way).
* ``large, zero guess``: pairs 0.5-1 m and 15-30 degrees apart from anywhere in the room, first
  guess zero (umbmark with its coarse stage; the others as they are).

Accuracy: position error |(dx, dy)| [mm] and yaw error [deg] against the simulator's truth
(median, 95th percentile, largest); failures: errors above 10 mm or 0.5 degree. Speed: pairs
per CPU second of this process, on one thread (NUMBA_NUM_THREADS, OMP_NUM_THREADS and the BLAS
thread counts set to 1, the process pinned to one core, each library asked for one thread),
every per-scan preparation (points, trees, normals, maps) included; wall-clock rates too (the
machine may be shared). numba's compile time is measured apart (a fresh cache directory unless
--numba-cache) and not counted in the rates. Libraries that are not installed are listed as such.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before numpy, numba or a candidate library is imported

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import shlex  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

DEFAULT_OUT = "umbmark-bench-scan-registration"
FAIL_M = 0.010
FAIL_RAD = math.radians(0.5)


def parser() -> argparse.ArgumentParser:
    """The command-line options of this script."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="short drive, few large pairs (tests, examples)")
    p.add_argument("--duration", type=float, default=None, help="seconds of driving (default 300, quick 20)")
    p.add_argument("--large", type=int, default=None, help="large-displacement pairs (default 200, quick 20)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--numba-cache", action="store_true", help="use numba's usual cache (compile time then a load)")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"results folder (default ./{DEFAULT_OUT})")
    return p


# ---------------------------------------------------------------- machine and data


def machine_info() -> dict:
    """CPU model, cores, the core this process runs on, Python and library versions, load."""
    import numpy as np

    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    info = {
        "cpu_model": cpu,
        "cores": os.cpu_count(),
        "pinned_to_cpus": sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
    }
    for mod in ("numba", "scipy", "small_gicp", "kiss_icp"):
        try:
            m = __import__(mod)
            info[mod] = getattr(m, "__version__", None) or _dist_version(mod)
        except ImportError:
            info[mod] = None
    try:
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    return info


def _dist_version(mod: str) -> str | None:
    from importlib import metadata

    try:
        return metadata.version(mod.replace("_", "-"))
    except metadata.PackageNotFoundError:
        return None


def drive_set(duration_s: float, seed: int) -> dict:
    """Consecutive scans of a simulated drive, the truth and two first guesses."""
    import numpy as np

    from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
    from umbmark.model.se2 import between

    log = simulate_drive(mixed_program(duration_s, seed=seed), EXAMPLE_ROBOT, seed=seed + 1)
    truth = log.sensor_motion()
    odo = log.odometry()[np.round(log.scan_t_s * log.wheel_rate_hz).astype(int)]
    rng = np.random.default_rng(seed + 2)
    off = truth * [1.02, 1.02, 1.0]
    off[:, 2] += math.radians(2.0) * rng.choice([-1.0, 1.0], len(truth))
    k = len(truth)
    speed = np.hypot(truth[:, 0], truth[:, 1]) * log.scan_rate_hz
    return {
        "scans": log.ranges_m,
        "angles": log.angles_rad,
        "ref": np.arange(k),
        "cur": np.arange(k) + 1,
        "truth": truth,
        "guesses": {"nominal odometry": between(odo[:-1], odo[1:]), "2 % / 2 deg": off},
        "describe": {
            "pairs": int(k),
            "scan_rate_hz": log.scan_rate_hz,
            "sensor_speed_mps": {"median": float(np.median(speed)), "max": float(speed.max())},
            "turn_rate_radps": {
                "median": float(np.median(np.abs(truth[:, 2])) * log.scan_rate_hz),
                "max": float(np.abs(truth[:, 2]).max() * log.scan_rate_hz),
            },
        },
    }


def large_set(k: int, seed: int) -> dict:
    """Pairs 0.5-1 m and 15-30 degrees apart, anywhere in the room at least 0.4 m from a wall."""
    import numpy as np

    from umbmark.model.drive import EXAMPLE_ROBOT
    from umbmark.model.se2 import between, compose
    from umbmark.model.sensors import Room

    room = Room.default()
    rng = np.random.default_rng(seed)
    p0, p1 = [], []
    while len(p0) < k:
        a = np.array([rng.uniform(0.5, 9.5), rng.uniform(0.5, 7.5), rng.uniform(-np.pi, np.pi)])
        d, u = rng.uniform(0.5, 1.0), rng.uniform(-np.pi, np.pi)
        b = compose(a, [d * math.cos(u), d * math.sin(u), rng.choice([-1, 1]) * math.radians(rng.uniform(15, 30))])
        xy = np.array([a[:2], b[:2]])
        if room.contains(xy).all() and (room.distance_to_walls(xy) >= 0.4).all():
            p0.append(a)
            p1.append(b)
    lidar = EXAMPLE_ROBOT.lidar
    scans = np.concatenate([lidar.scan(room, np.array(p0), rng), lidar.scan(room, np.array(p1), rng)])
    return {
        "scans": scans,
        "angles": lidar.angles_rad,
        "ref": np.arange(k),
        "cur": np.arange(k) + k,
        "truth": between(np.array(p0), np.array(p1)),
        "guesses": {"zero guess": np.zeros((k, 3))},
        "describe": {"pairs": int(k), "distance_m": [0.5, 1.0], "turn_deg": [15, 30]},
    }


# ---------------------------------------------------------------- candidates


def points_of(ranges, angles):
    """The valid returns of one scan as ``(n, 2)`` points in the sensor frame."""
    import numpy as np

    ok = np.isfinite(ranges)
    return np.column_stack([ranges[ok] * np.cos(angles[ok]), ranges[ok] * np.sin(angles[ok])])


def _se2_matrix(pose):
    import numpy as np

    c, s = math.cos(pose[2]), math.sin(pose[2])
    t = np.eye(4)
    t[:2, :2] = [[c, -s], [s, c]]
    t[:2, 3] = pose[:2]
    return t


def _se2_of(t):
    return (float(t[0, 3]), float(t[1, 3]), math.atan2(t[1, 0], t[0, 0]))


class ScipyICP:
    """Plain point-to-line ICP in Python: scipy cKDTree nearest neighbours, normals from the 5
    nearest reference points, 0.3 m gate, the worst 10 % trimmed, Gauss-Newton steps to 1e-6."""

    name = "scipy cKDTree point-to-line ICP (Python)"

    def __init__(self):
        from scipy.spatial import cKDTree

        self.tree = cKDTree

    def prepare(self, ranges, angles):
        import numpy as np

        p = points_of(ranges, angles)
        tree = self.tree(p)
        _, nb = tree.query(p, k=5)
        q = p[nb] - p[nb].mean(axis=1, keepdims=True)
        cov = np.einsum("nki,nkj->nij", q, q)
        _, vec = np.linalg.eigh(cov)
        return p, tree, vec[:, :, 0]

    def match(self, ref, cur, guess):
        import numpy as np

        rp, tree, normals = ref
        cp = cur[0]
        x = np.array(guess, dtype=float)
        for _ in range(30):
            c, s = math.cos(x[2]), math.sin(x[2])
            q = cp @ np.array([[c, s], [-s, c]])
            p = q + x[:2]
            d, i = tree.query(p, distance_upper_bound=0.3)
            ok = np.isfinite(d)
            if ok.sum() < 10:
                return x, False
            n = normals[i[ok]]
            r = np.einsum("ij,ij->i", n, p[ok] - rp[i[ok]])
            keep = np.abs(r) <= np.quantile(np.abs(r), 0.9)
            n, r, qk = n[keep], r[keep], q[ok][keep]
            jac = np.column_stack([n, n[:, 1] * qk[:, 0] - n[:, 0] * qk[:, 1]])
            step = np.linalg.solve(jac.T @ jac, -jac.T @ r)
            x += step
            if math.hypot(step[0], step[1]) < 1e-6 and abs(step[2]) < 1e-6:
                return x, True
        return x, False


class SmallGICP:
    """small_gicp (C++, pybind11) on the scan's points at z = 0 (or the scan extruded to three
    heights, so that neighbourhoods are patches of vertical wall)."""

    def __init__(self, kind="GICP", defaults=False, extrude=False):
        import small_gicp

        self.lib = small_gicp
        self.kind = kind
        self.defaults = defaults
        self.extrude = extrude
        what = {"GICP": "GICP", "PLANE_ICP": "point-to-plane"}[kind]
        if defaults:
            self.name = f"small_gicp {what}, z = 0, align() defaults (0.25 m downsampling, 1 mm / 0.1 deg)"
        elif extrude:
            self.name = f"small_gicp {what}, scan extruded to z = -0.2, 0, 0.2 m, all points"
        else:
            self.name = f"small_gicp {what}, z = 0, all points"

    def prepare(self, ranges, angles):
        import numpy as np

        p = points_of(ranges, angles)
        pts = np.column_stack([p, np.zeros(len(p))])
        if self.extrude:
            pts = np.concatenate([pts + [0.0, 0.0, z] for z in (-0.2, 0.0, 0.2)])
        if self.defaults:
            return pts
        pc = self.lib.PointCloud(pts)
        tree = self.lib.KdTree(pc, num_threads=1)
        if self.kind == "GICP":
            self.lib.estimate_covariances(pc, tree, num_neighbors=10, num_threads=1)
        else:
            self.lib.estimate_normals(pc, tree, num_neighbors=10, num_threads=1)
        return pc, tree

    def match(self, ref, cur, guess):
        init = _se2_matrix(guess)
        if self.defaults:
            res = self.lib.align(ref, cur, init, registration_type=self.kind, num_threads=1)
        else:
            res = self.lib.align(
                ref[0],
                cur[0],
                ref[1],
                init_T_target_source=init,
                registration_type=self.kind,
                max_correspondence_distance=0.3,
                num_threads=1,
                max_iterations=30,
                rotation_epsilon=1e-6,
                translation_epsilon=1e-6,
            )
        return _se2_of(res.T_target_source), bool(res.converged)


class KissICP:
    """KISS-ICP's registration (C++, pybind11) driven from Python on z = 0 points: the reference
    scan in its voxel hash map (0.1 m voxels), point-to-point ICP with its robust kernel
    (0.1 m) and a 0.3 m correspondence distance, one thread."""

    name = "KISS-ICP point-to-point (voxel map), z = 0"

    def __init__(self):
        from kiss_icp.mapping import VoxelHashMap
        from kiss_icp.registration import Registration

        self.map = VoxelHashMap
        self.reg = Registration(max_num_iterations=500, convergence_criterion=1e-6, max_num_threads=1)

    def prepare(self, ranges, angles):
        import numpy as np

        p = points_of(ranges, angles)
        pts = np.column_stack([p, np.zeros(len(p))])
        vm = self.map(voxel_size=0.1, max_distance=100.0, max_points_per_voxel=20)
        vm.add_points(pts)
        return pts, vm

    def match(self, ref, cur, guess):
        t = self.reg.align_points_to_map(cur[0], ref[1], _se2_matrix(guess), 0.3, 0.1)
        return _se2_of(t), None


def run_generic(cand, data, guesses):
    """Poses (K, 3), converged flags (or None), CPU and wall seconds of one candidate on one set."""
    import numpy as np

    scans, angles = data["scans"], data["angles"]
    k = len(data["ref"])
    poses = np.zeros((k, 3))
    conv: list = []
    cache: dict = {}
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    for i in range(k):
        r, c = int(data["ref"][i]), int(data["cur"][i])
        for j in (r, c):
            if j not in cache:
                cache[j] = cand.prepare(scans[j], angles)
        pose, ok = cand.match(cache[r], cache[c], guesses[i])
        poses[i] = pose
        conv.append(ok)
        cache.pop(r - 1, None)  # consecutive pairs: the scan before the reference is done
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    return poses, (None if conv[0] is None else np.array(conv)), cpu, wall


def run_umbmark(data, guesses, coarse, per_pair=False):
    import numpy as np

    from umbmark.realrobot.scanmatch import ICPConfig, match_consecutive, match_scan_pairs, match_scans

    cfg = ICPConfig(coarse=coarse)
    scans, angles = data["scans"], data["angles"]
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    if per_pair:
        res = [match_scans(scans[r], scans[c], angles, g, cfg) for r, c, g in zip(data["ref"], data["cur"], guesses)]
        poses = np.array([m.pose for m in res])
        conv = np.array([m.converged for m in res])
    else:
        consecutive = np.array_equal(data["cur"], data["ref"] + 1) and data["ref"][0] == 0
        if consecutive:
            m = match_consecutive(scans, angles, guesses, cfg)
        else:
            m = match_scan_pairs(scans[data["ref"]], scans[data["cur"]], angles, guesses, cfg)
        poses, conv = m.poses, m.converged
    return poses, conv, time.process_time() - t_cpu, time.perf_counter() - t_wall


def summarise(poses, conv, cpu, wall, truth) -> dict:
    """The accuracy and speed figures of one candidate on one set."""
    import numpy as np

    d = poses - truth
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    pos = np.hypot(d[:, 0], d[:, 1])
    yaw = np.abs(d[:, 2])
    k = len(truth)
    out = {
        "pairs": int(k),
        "position_mm": {
            "median": float(np.median(pos) * 1e3),
            "p95": float(np.percentile(pos, 95) * 1e3),
            "max": float(pos.max() * 1e3),
        },
        "yaw_deg": {
            "median": float(np.degrees(np.median(yaw))),
            "p95": float(np.degrees(np.percentile(yaw, 95))),
            "max": float(np.degrees(yaw.max())),
        },
        "failures": float(np.mean((pos > FAIL_M) | (yaw > FAIL_RAD))),
        "converged": None if conv is None else float(np.mean(conv)),
        "pairs_per_cpu_s": float(k / cpu) if cpu > 0 else None,
        "pairs_per_wall_s": float(k / wall) if wall > 0 else None,
        "cpu_s": float(cpu),
    }
    if conv is not None:
        bad = (pos > FAIL_M) | (yaw > FAIL_RAD)
        out["converged_but_failed"] = float(np.mean(conv & bad))
    return out


def compile_times(cache_dir: str | None) -> dict:
    """umbmark's numba compile time (first match in this process) and, in a fresh process, the
    time of the first match when the cache is warm."""
    import numpy as np

    from umbmark.model.sensors import Lidar, Room
    from umbmark.realrobot.scanmatch import ICPConfig, match_scans

    lidar = Lidar()
    g = np.random.default_rng(0)
    a = lidar.scan(Room.default(), [5.0, 4.0, 0.1], g)
    b = lidar.scan(Room.default(), [5.03, 4.0, 0.15], g)
    t = time.perf_counter()
    match_scans(a, b, lidar.angles_rad, config=ICPConfig(coarse=True))
    first = time.perf_counter() - t
    t = time.perf_counter()
    match_scans(a, b, lidar.angles_rad, config=ICPConfig(coarse=True))
    again = time.perf_counter() - t
    code = (
        "import time, numpy as np\n"
        "from umbmark.model.sensors import Lidar, Room\n"
        "l = Lidar(); g = np.random.default_rng(0)\n"
        "a = l.scan(Room.default(), [5.0, 4.0, 0.1], g); b = l.scan(Room.default(), [5.03, 4.0, 0.15], g)\n"
        "t = time.perf_counter()\n"
        "from umbmark.realrobot.scanmatch import ICPConfig, match_scans\n"
        "match_scans(a, b, l.angles_rad, config=ICPConfig(coarse=True))\n"
        "print(time.perf_counter() - t)\n"
    )
    warm = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    return {
        "first_match_s": first,
        "compile_s": first - again,
        "first_match_warm_cache_s": warm,
        "cache": "fresh directory" if cache_dir else "numba's usual cache",
    }


def candidates() -> tuple[list, dict]:
    """The candidate matchers that can be built here, and why the others cannot."""
    out, missing = [], {}
    builders = [
        ("scipy", ScipyICP),
        ("small_gicp", lambda: SmallGICP("GICP", defaults=True)),
        ("small_gicp", lambda: SmallGICP("GICP")),
        ("small_gicp", lambda: SmallGICP("PLANE_ICP")),
        ("small_gicp", lambda: SmallGICP("GICP", extrude=True)),
        ("kiss_icp", KissICP),
    ]
    for lib, build in builders:
        try:
            out.append(build())
        except ImportError as e:
            missing[lib] = f"not installed ({e})"
    return out, missing


# ---------------------------------------------------------------- report


def fmt(v, digits=3) -> str:
    """A number for the tables: significant digits, or a dash."""
    if v is None:
        return "-"
    if isinstance(v, float) and not math.isfinite(v):
        return "inf"
    if abs(v) >= 100:
        return f"{v:,.0f}"
    return f"{v:.{digits}g}"


def markdown(res: dict) -> str:
    """The results page."""
    m = res["machine"]
    c = res["compile"]
    lines = [
        "# 2D scan registration",
        "",
        "umbmark's matcher (`umbmark.realrobot.scanmatch`, numba point-to-line ICP) next to other",
        "registration methods on the same simulated scans: 360 beams, 5 mm range noise, the default",
        "10 x 8 m room. Written by `benchmarks/scan_registration.py`; the definitions are in its docstring.",
        "",
        f"Command: `{res['command']}`",
        "",
        f"Machine: {m['cpu_model']}, {m['cores']} cores (this process pinned to CPU {m['pinned_to_cpus']}), "
        f"Python {m['python']}, numpy {m['numpy']}, numba {m['numba']}, scipy {m['scipy']}, "
        f"small_gicp {m['small_gicp']}, kiss-icp {m['kiss_icp']}; load average {m.get('load_average')} "
        f"at the start, {res.get('load_average_end')} at the end.",
        "",
        "Rates are pairs per CPU second of one thread (every library set to one thread), every",
        "per-scan preparation included; wall-clock rates beside them. Failures: position error",
        'above 10 mm or yaw error above 0.5 degree; "converged, failed": the pairs a matcher called',
        "converged although they failed (KISS-ICP reports no convergence).",
        "",
        f"numba compile of the matcher (not in the rates): {c['compile_s']:.1f} s ({c['cache']}); the first",
        f"match of a fresh process with the cache warm: {c['first_match_warm_cache_s']:.2f} s.",
        "",
    ]
    for name, s in res["sets"].items():
        lines += [f"## {name}", "", s["note"], ""]
        lines += [
            "| matcher | position median [mm] | p95 [mm] | max [mm] | yaw median [deg] | p95 [deg] | "
            "failures | converged | converged, failed | pairs/s (CPU) | pairs/s (wall) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for cand, r in s["results"].items():
            p, y = r["position_mm"], r["yaw_deg"]
            conv = "-" if r["converged"] is None else f"{r['converged']:.1%}"
            wrong = "-" if r["converged"] is None else f"{r['converged_but_failed']:.1%}"
            lines.append(
                f"| {cand} | {fmt(p['median'])} | {fmt(p['p95'])} | {fmt(p['max'])} | {fmt(y['median'])} | "
                f"{fmt(y['p95'])} | {r['failures']:.1%} | {conv} | {wrong} | {fmt(r['pairs_per_cpu_s'])} | "
                f"{fmt(r['pairs_per_wall_s'])} |"
            )
        lines.append("")
    if res["missing"]:
        lines += ["Not measured: " + "; ".join(f"{k}: {v}" for k, v in res["missing"].items()), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    a = parser().parse_args(argv)
    cache_dir = None
    if not a.numba_cache:
        cache_dir = tempfile.mkdtemp(prefix="umbmark-numba-")
        os.environ["NUMBA_CACHE_DIR"] = cache_dir
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    command = "python " + " ".join(shlex.quote(x) for x in [sys.argv[0]] + list(sys.argv[1:] if argv is None else argv))
    duration = a.duration if a.duration is not None else (20.0 if a.quick else 300.0)
    n_large = a.large if a.large is not None else (20 if a.quick else 200)

    machine = machine_info()
    print("compiling ...", file=sys.stderr)
    comp = compile_times(cache_dir)
    cands, missing = candidates()
    drive = drive_set(duration, a.seed)
    large = large_set(n_large, a.seed + 10)
    sets = {}
    plan = [
        ("drive, nominal odometry", drive, "nominal odometry", False),
        ("drive, 2 % / 2 deg", drive, "2 % / 2 deg", False),
        ("large, zero guess", large, "zero guess", True),
    ]
    notes = {
        "drive, nominal odometry": "Consecutive scans at 10 Hz of a simulated drive; first guess: the uncalibrated "
        "odometry's displacement, the sensor pose unknown.",
        "drive, 2 % / 2 deg": "The same pairs; first guess: the truth with 2 % more translation and 2 degrees "
        "of yaw either way.",
        "large, zero guess": "Pairs 0.5-1 m and 15-30 degrees apart, first guess zero; umbmark with its coarse "
        "stage (`ICPConfig(coarse=True)`), the others as they are.",
    }
    for name, data, guess_name, coarse in plan:
        guesses = data["guesses"][guess_name]
        truth = data["truth"]
        results = {}
        label = "umbmark match_consecutive" if not coarse else "umbmark match_scan_pairs, coarse stage"
        print(f"{name}: {label}", file=sys.stderr)
        results[label] = summarise(*run_umbmark(data, guesses, coarse), truth)
        if not coarse:
            results["umbmark match_scans, one call per pair"] = summarise(
                *run_umbmark(data, guesses, coarse, per_pair=True), truth
            )
        else:
            results["umbmark match_scan_pairs, no coarse stage"] = summarise(*run_umbmark(data, guesses, False), truth)
        for cand in cands:
            print(f"{name}: {cand.name}", file=sys.stderr)
            results[cand.name] = summarise(*run_generic(cand, data, guesses), truth)
        sets[name] = {"note": notes[name], "data": data["describe"], "results": results}
    from dataclasses import asdict

    from umbmark.realrobot.scanmatch import ICPConfig

    res = {
        "command": command,
        "machine": machine,
        "compile": comp,
        "umbmark_config": {k: (None if v == math.inf else v) for k, v in asdict(ICPConfig()).items()},
        "lidar": {"beams": 360, "range_noise_m": 0.005, "max_range_m": 12.0, "room": "Room.default()"},
        "failure_threshold": {"position_mm": FAIL_M * 1e3, "yaw_deg": math.degrees(FAIL_RAD)},
        "sets": sets,
        "missing": missing,
    }
    try:
        res["load_average_end"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "scan_registration.json").write_text(json.dumps(res, indent=2) + "\n", encoding="utf-8")
    (out / "scan_registration.md").write_text(markdown(res) + "\n", encoding="utf-8")
    print(markdown(res))
    print("written:", out / "scan_registration.json", out / "scan_registration.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
