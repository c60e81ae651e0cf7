#!/usr/bin/env python3
"""tipforge against CadQuery and Python manifold3d on the same parts, side by side in one run.

For the default one-sensor fingertip and the rig plunger, each at the chordal tolerance of its
parameter file, it measures for tipforge, CadQuery and manifold3d:
- wall time: in-process (model + mesh, median of runs; tipforge's from `cargo bench --bench build`
  with one part) and whole-process (a fresh process that builds the part and writes an STL);
- triangles; volume against the exact B-rep volume OCCT computes for the CadQuery model;
- the largest distance of the mesh from that exact surface (sampled at the centroids of every
  triangle and at points a third of the way to each corner);
- whether the mesh passes the foundation's mesh-validity rules of scripts/check_meshes.py.

    bench_peers.py [--runs N] [--json OUT]
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
import check_meshes as cm  # noqa: E402
import peer_models as pm  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TIPFORGE = ROOT / "target/release/tipforge"


def timed(fn, runs):
    ts = []
    out = None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts) * 1000, out


def whole_process(cmd, runs):
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts) * 1000


def tipforge_in_process(stem, runs):
    env = dict(os.environ, TIPFORGE_BENCH_ONLY=stem, TIPFORGE_BENCH_RUNS=str(runs))
    out = subprocess.run(["cargo", "bench", "--quiet", "--bench", "build"], cwd=ROOT, env=env, check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith(stem):
            return float(line.split()[2])
    raise RuntimeError(out)


def sample_points(v, t):
    tri = v[t]
    pts = [tri.mean(axis=1)]
    c = tri.mean(axis=1)
    for k in range(3):
        pts.append(c + (tri[:, k] - c) * (2 / 3))
    return np.vstack(pts)


def max_deviation(points, shape):
    """Largest distance from the points to the exact OCCT shape (BRepExtrema)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Pnt

    worst = 0.0
    dss = BRepExtrema_DistShapeShape()
    dss.LoadS2(shape.wrapped)
    for p in points:
        dss.LoadS1(BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, p))).Vertex())
        dss.Perform()
        worst = max(worst, dss.Value())
    return worst


def passes_checks(v, t, genus, tol, name):
    mesh = trimesh.Trimesh(v, t, process=True)
    entry = {"genus": genus, "volume_mm3": float(mesh.volume), "triangles": len(mesh.faces), "features": {"kind": "peer", "chordal_tolerance_mm": tol}}
    ctx = cm.Ctx(name, entry, mesh, None, None, ROOT)
    failed = []
    for r in cm.RULES:
        try:
            res = r(ctx)
        except Exception as e:  # noqa: BLE001
            res = ("crashed", repr(e))
        if res:
            failed.append(f"{r.__name__}: {res[1]}")
    return failed


def main():
    runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 5
    out_json = sys.argv[sys.argv.index("--json") + 1] if "--json" in sys.argv else None
    work = Path(tempfile.mkdtemp(prefix="tipforge-peers-"))
    subprocess.run([str(TIPFORGE), "build", "fingertip-1s", "rig", "--out", str(work / "tf")], check=True, capture_output=True)
    man = json.loads((work / "tf/manifest.json").read_text())
    (work / "manifest.json").write_text(json.dumps(man))
    import cadquery  # noqa: F401  (import cost outside the timings)
    import manifold3d
    import OCP  # noqa: F401

    versions = {"cadquery": cadquery.__version__, "manifold3d": getattr(manifold3d, "__version__", "3.5.4 (pinned)"), "python": sys.version.split()[0]}
    rows = []
    for part, stem, tf_part in (("fingertip", "fingertip-1s", "fingertip-1s"), ("plunger", "rig", "rig-plunger")):
        tol = man["parts"][tf_part]["features"]["chordal_tolerance_mm"]
        genus = man["parts"][tf_part]["genus"]
        # the reference: OCCT's exact B-rep of the CadQuery model
        _, (_, _, exact) = timed(lambda: pm.build("cadquery", part, man, tol), 1)
        ref_volume = exact.Volume()
        tm = trimesh.load(str(work / f"tf/{tf_part}.stl"), process=True)
        v_tf = np.asarray(tm.vertices)
        # tipforge writes print poses; the peers model the fingertip in its design frame
        if part == "fingertip":
            v_tf = v_tf[:, [2, 0, 1]]
        results = {"tipforge": (v_tf, np.asarray(tm.faces))}
        times = {"tipforge": (tipforge_in_process(tf_part, runs), whole_process([str(TIPFORGE), "build", stem, "--out", str(work / "w")], runs))}
        for tool in ("cadquery", "manifold3d"):
            ms, (v, t, _) = timed(lambda: pm.build(tool, part, man, tol), runs)
            results[tool] = (v, t)
            whole = whole_process([sys.executable, str(ROOT / "scripts/peer_models.py"), tool, part, str(work / f"{tool}-{part}.stl"), "--manifest", str(work / "manifest.json")], max(3, runs // 2))
            times[tool] = (ms, whole)
        for tool, (v, t) in results.items():
            vol = trimesh.Trimesh(v, t, process=True).volume
            dev = max_deviation(sample_points(v, t), exact)
            fails = passes_checks(v, t, genus, tol, f"{tool}-{part}")
            rows.append({
                "part": part, "tool": tool, "tolerance_mm": tol,
                "in_process_ms": times[tool][0], "whole_process_ms": times[tool][1],
                "triangles": int(len(t)), "volume_mm3": float(vol), "reference_volume_mm3": float(ref_volume),
                "volume_error_percent": float(100 * (vol / ref_volume - 1)), "max_deviation_mm": float(dev),
                "check_meshes": "pass" if not fails else "; ".join(fails),
            })
            r = rows[-1]
            print(f"{part:<10} {tool:<11} tol {tol:<5} in-process {r['in_process_ms']:8.1f} ms  whole {r['whole_process_ms']:8.1f} ms  "
                  f"{r['triangles']:7d} tris  volume {r['volume_error_percent']:+.4f} %  max dev {dev:.4f} mm  checks {r['check_meshes']}", flush=True)
    print("versions:", versions)
    if out_json:
        Path(out_json).write_text(json.dumps({"versions": versions, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
