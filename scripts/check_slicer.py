#!/usr/bin/env python3
"""A real slicer on tipforge's output: PrusaSlicer's CLI slices every printed part.

Reads OUT/manifest.json and slices the STL of every part whose `process` is "printed", in the
orientation and place the file gives (--dont-arrange; the profile's bed has its origin at its
centre), with the profile kept in the repository, scripts/slicer/pla-0.4-0.2.ini (0.4 mm nozzle,
0.2 mm layers, PLA). Each failed rule prints `part: rule: measured value` and the exit code is 1.

Rules:
  not on the bed     the part's min z (manifest bbox_mm.min and the STL itself) is not 0 within
                     0.01 mm: PrusaSlicer silently drops a floating part onto the bed and lifts a
                     sunken one, so the G-code would not be the designed part.
  slicer error       the slicer exits non-zero, logs an error or a warning, or writes no G-code /
                     G-code without extrusion.
  empty layer        a layer change between the first and the last printed layer with no
                     extrusion, a step between consecutive layer heights (;Z:) larger than one
                     layer height, or PrusaSlicer's own "Empty layer between ..." warning.
  support needed     a part whose manifest says `supports: "none"` gets more than
                     SUPPORT_LIMIT_MM3 of support extrusion (;TYPE:Support material and
                     ;TYPE:Support material interface) when sliced a second time with
                     --support-material (automatic supports, support_material_threshold = 43 in
                     the profile: overhangs up to 45 degrees from vertical print without support,
                     47 and more need it; see the profile for PrusaSlicer's T + 1 semantics). The failure names the volume and the layer heights.

Print time, filament grams and layer count come from the first slice (without supports) and are
written to OUT/slicing.json with the support volume the second slice would have added.

    check_slicer.py [OUT]          slice a build output folder (default: out)
    check_slicer.py --self-test    prove each rule fails on a mesh made to break it
    options: --jobs N (slices run at once, default 2), --keep DIR (keep the G-code there)

PrusaSlicer comes from scripts/install-slicer. Its CLI needs no display for --export-gcode.
"""
import concurrent.futures
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parent.parent
PROFILE_REL = "scripts/slicer/pla-0.4-0.2.ini"
PROFILE = ROOT / PROFILE_REL
SLICER = "prusa-slicer"
BED_TOL_MM = 0.01
# Support extrusion above this volume counts (0.5 mm3 is 0.21 mm of 1.75 mm filament, about 5.5 mm
# of a 0.45 x 0.2 mm bead): anything the slicer really generates under an overhang is far more.
SUPPORT_LIMIT_MM3 = 0.5
SLICE_TIMEOUT_S = 600


def profile_value(key):
    for line in PROFILE.read_text().splitlines():
        k, sep, v = line.partition("=")
        if sep and k.strip() == key:
            return v.strip()
    raise KeyError(f"{key} missing from {PROFILE_REL}")


LAYER_H = float(profile_value("layer_height"))
FIRST_LAYER_H = float(profile_value("first_layer_height"))
MAX_LAYER_H = float(profile_value("nozzle_diameter"))
FILAMENT_AREA = math.pi * (float(profile_value("filament_diameter")) / 2) ** 2


# ---------------------------------------------------------------- running the slicer
def slicer_exe():
    exe = shutil.which(SLICER)
    if exe is None:
        sys.exit(f"{SLICER} is not on PATH: run scripts/install-slicer")
    return exe


def slicer_version():
    r = subprocess.run([slicer_exe(), "--loglevel", "0", "--help"], capture_output=True, text=True, timeout=60)
    m = re.search(r"PrusaSlicer-\S+", r.stdout + r.stderr)
    return m.group(0) if m else "unknown"


def slice_cmd(stl, gcode, support):
    cmd = [slicer_exe(), "--loglevel", "1", "--export-gcode", "--load", str(PROFILE), "--dont-arrange"]
    if support:
        cmd.append("--support-material")
    return cmd + ["--output", str(gcode), str(stl)]


def run_slicer(stl, gcode, support):
    """Slices one STL. Returns (problems, gcode stats or None, seconds)."""
    t0 = time.monotonic()
    gcode = Path(gcode)
    gcode.unlink(missing_ok=True)
    try:
        r = subprocess.run(slice_cmd(stl, gcode, support), capture_output=True, text=True, timeout=SLICE_TIMEOUT_S)
        rc, log = r.returncode, r.stdout + r.stderr
    except subprocess.TimeoutExpired:
        rc, log = None, f"timed out after {SLICE_TIMEOUT_S} s"
    dt = time.monotonic() - t0
    problems = []  # (rule, value)
    # "[2026-01-01 00:00:00.000] [0x7f..] [error]   text" -> "error: text"
    log = re.sub(r"^\[[^\]]*\] \[[^\]]*\] \[(\w+)\]\s*", r"\1: ", log, flags=re.M)
    msgs = [l.strip() for l in log.splitlines() if l.strip()
            and not re.match(r"^\d+ => ", l.strip())            # progress
            and "Slicing result exported" not in l
            and not re.match(r"^(trace|debug|info): ", l.strip())]
    empty_warn = [m for m in msgs if "Empty layer" in m]
    if empty_warn:
        problems.append(("empty layer", "slicer: " + empty_warn[0].replace("print warning: ", "")))
    bad = [m for m in msgs if m not in empty_warn and re.search(r"error|warning|fail|can't|cannot|invalid", m, re.I)]
    if rc != 0:
        problems.append(("slicer error", f"exit {rc}: " + (" | ".join(msgs[:3]) or "no message")))
    elif bad:
        problems.append(("slicer error", " | ".join(bad[:3])))
    if rc != 0 or not gcode.is_file():
        if rc == 0:
            problems.append(("slicer error", "no G-code written"))
        return problems, None, dt
    stats = parse_gcode(gcode)
    if not stats["layers"] or stats["extruded_mm"] <= 0:
        problems.append(("slicer error", "G-code has no extrusion"))
    return problems, stats, dt


# ---------------------------------------------------------------- reading PrusaSlicer's G-code
def parse_duration(s):
    """'1d 2h 3m 4s' -> seconds."""
    units = {"d": 86400, "h": 3600, "m": 60, "s": 1}
    parts = re.findall(r"(\d+)\s*([dhms])", s)
    return sum(int(n) * units[u] for n, u in parts) if parts else None


def parse_gcode(path):
    """Layers as dicts {z, extruded_mm, support_mm, xy_support (min/max)} in print order, and the
    slicer's statistics (time, filament). Extrusion is filament length fed on moves with X or Y;
    both M82 (absolute) and M83 (relative) E are followed, with G92 E resets."""
    layers = []
    layer = None
    kind = None
    relative = False
    e_pos = 0.0
    stats = {"time_s": None, "time_text": None, "filament_g": None, "filament_mm": None}
    move = re.compile(r"^G[01]\s")
    word = re.compile(r"([XYZEF])(-?\d*\.?\d+)")
    for raw in Path(path).read_text(errors="replace").splitlines():
        line = raw.strip()
        if line.startswith(";"):
            if line == ";LAYER_CHANGE":
                layer = {"z": None, "extruded_mm": 0.0, "support_mm": 0.0, "support_xy": None}
                layers.append(layer)
            elif line.startswith(";Z:") and layer is not None and layer["z"] is None:
                layer["z"] = float(line[3:])
            elif line.startswith(";TYPE:"):
                kind = line[6:]
            elif line.startswith("; estimated printing time (normal mode) ="):
                stats["time_text"] = line.split("=", 1)[1].strip()
                stats["time_s"] = parse_duration(stats["time_text"])
            elif line.startswith("; total filament used [g] ="):
                stats["filament_g"] = float(line.split("=", 1)[1])
            elif line.startswith("; filament used [g] =") and stats["filament_g"] is None:
                stats["filament_g"] = sum(float(v) for v in line.split("=", 1)[1].split(",") if v.strip())
            elif line.startswith("; filament used [mm] ="):
                stats["filament_mm"] = sum(float(v) for v in line.split("=", 1)[1].split(",") if v.strip())
            continue
        code = line.split(";", 1)[0].strip()
        if code.startswith("M83"):
            relative = True
        elif code.startswith("M82"):
            relative = False
        elif code.startswith("G92"):
            w = dict(word.findall(code))
            if "E" in w:
                e_pos = float(w["E"])
        elif move.match(code):
            w = dict(word.findall(code))
            if "E" not in w:
                continue
            e = float(w["E"])
            de = e if relative else e - e_pos
            e_pos = e_pos + e if relative else e
            if de <= 0 or layer is None or not ("X" in w or "Y" in w):
                continue  # retraction, deretraction (E only), start G-code
            layer["extruded_mm"] += de
            if kind and kind.startswith("Support"):
                layer["support_mm"] += de
                x, y = float(w.get("X", "nan")), float(w.get("Y", "nan"))
                if not (math.isnan(x) or math.isnan(y)):
                    b = layer["support_xy"]
                    layer["support_xy"] = [x, y, x, y] if b is None else [min(b[0], x), min(b[1], y), max(b[2], x), max(b[3], y)]
    # A layer of the G-code without ;Z: takes its height from nothing: keep it but mark it.
    stats["layers"] = layers
    stats["extruded_mm"] = sum(l["extruded_mm"] for l in layers)
    stats["support_mm"] = sum(l["support_mm"] for l in layers)
    return stats


def z_ranges(zs):
    """[0.2, 0.4, 0.5, 3.0] -> '0.20-0.50, 3.00': heights less than the thickest layer the slicer
    may print (support layers are up to a nozzle diameter thick) apart are one range."""
    return ", ".join(f"{a:.2f}" if a == b else f"{a:.2f}-{b:.2f}" for a, b in z_groups(zs))


def z_groups(zs):
    out = []
    for z in sorted(zs):
        if out and z - out[-1][1] <= MAX_LAYER_H + 1e-3:
            out[-1][1] = z
        else:
            out.append([z, z])
    return out


def layer_problems(stats):
    """Empty layers and gaps in Z between the first and the last printed layer."""
    problems = []
    layers = stats["layers"]
    printed = [i for i, l in enumerate(layers) if l["extruded_mm"] > 0]
    if not printed:
        return problems
    inner = layers[printed[0]:printed[-1] + 1]
    if any(l["z"] is None for l in inner):
        problems.append(("empty layer", "layer change without ;Z:"))
        return problems
    empty = [l["z"] for l in inner if l["extruded_mm"] <= 0]
    if empty:
        problems.append(("empty layer", f"{len(empty)} layer(s) without extrusion at z {z_ranges(empty)} mm"))
    zs = [l["z"] for l in inner]
    first = zs[0]
    if abs(first - FIRST_LAYER_H) > 1e-3:
        problems.append(("empty layer", f"first printed layer at z {first:.2f} mm, not {FIRST_LAYER_H:.2f}"))
    for a, b in zip(zs, zs[1:]):
        if b - a > LAYER_H + 1e-3:
            problems.append(("empty layer", f"gap of {b - a:.2f} mm in z between layers {a:.2f} and {b:.2f} mm (layer height {LAYER_H:.2f})"))
        elif b <= a:
            problems.append(("empty layer", f"z goes from {a:.2f} to {b:.2f} mm"))
    return problems


def support_summary(stats):
    """Support volume and where it is: per range of layer heights, the xy extent of the support
    extrusion (its first layer spreads wider than the overhang above it)."""
    layers = [l for l in stats["layers"] if l["support_mm"] > 0 and l["z"] is not None]
    where = []
    for lo, hi in z_groups([l["z"] for l in layers]):
        xy = None
        for l in layers:
            b = l["support_xy"]
            if lo <= l["z"] <= hi and b:
                xy = b if xy is None else [min(xy[0], b[0]), min(xy[1], b[1]), max(xy[2], b[2]), max(xy[3], b[3])]
        z = f"{lo:.2f}" if lo == hi else f"{lo:.2f}-{hi:.2f}"
        where.append(f"z {z}" + (f" (x {xy[0]:.1f}..{xy[2]:.1f}, y {xy[1]:.1f}..{xy[3]:.1f})" if xy else ""))
    mm = stats["support_mm"]
    return {"mm3": mm * FILAMENT_AREA, "filament_mm": mm, "z": z_ranges([l["z"] for l in layers]),
            "where": ", ".join(where), "layers": len(layers)}


# ---------------------------------------------------------------- one part
def stl_min_z(path):
    try:
        m = trimesh.load(str(path), file_type="stl", force="mesh", process=False)
        return float(np.asarray(m.vertices)[:, 2].min())
    except Exception:
        return None  # the slicer reports what is wrong with it


def check_part(name, entry, root, work):
    """Returns (failures [(rule, value)], record for slicing.json, seconds of slicing)."""
    fails = []
    stls = [f for f in entry.get("files", []) if f.lower().endswith(".stl")]
    if not stls:
        return [("slicer error", "no STL among files " + ", ".join(entry.get("files", [])))], None, 0.0
    stl = root / stls[0]
    zmin_manifest = entry.get("bbox_mm", {}).get("min", [None, None, None])[2]
    zmin_stl = stl_min_z(stl) if stl.is_file() else None
    off = [f"{z:+.3f} mm ({src})" for z, src in ((zmin_manifest, "manifest"), (zmin_stl, "STL")) if z is not None and abs(z) > BED_TOL_MM]
    if off:
        fails.append(("not on the bed", "min z " + ", ".join(off)))
    if not stl.is_file():
        return fails + [("slicer error", f"{stl.name} missing")], None, 0.0

    p1, s1, t1 = run_slicer(stl, work / f"{name}.gcode", support=False)
    fails += p1
    record = None
    if s1 is not None:
        fails += [p for p in layer_problems(s1) if p not in fails]
        record = {
            "print_time_s": s1["time_s"],
            "filament_g": s1["filament_g"],
            "layers": len(s1["layers"]),
        }
        if s1["time_s"] is None:
            fails.append(("slicer error", "no '; estimated printing time (normal mode) =' line"))
        if s1["filament_g"] is None:
            fails.append(("slicer error", "no '; total filament used [g] =' line"))
        # `tipforge build --slice` wrote its own numbers into the manifest: they must be this slice's
        pr = entry.get("print")
        if pr is not None and s1["time_s"] is not None and s1["filament_g"] is not None:
            if abs(pr.get("time_s", -1) - s1["time_s"]) > 0.01 * s1["time_s"] + 1 or abs(pr.get("filament_g", -1) - s1["filament_g"]) > 0.01 * s1["filament_g"] + 0.01:
                fails.append(("manifest print numbers disagree", f"manifest {pr.get('time_s')} s / {pr.get('filament_g')} g, slicer {s1['time_s']} s / {s1['filament_g']} g"))

    if s1 is None:
        return fails, record, t1
    p2, s2, t2 = run_slicer(stl, work / f"{name}-supports.gcode", support=True)
    fails += [p for p in p2 if p not in fails]
    if s2 is not None:
        sup = support_summary(s2)
        if record is not None:
            record["support_mm3_if_enabled"] = round(sup["mm3"], 2)
            record["support_z_mm"] = sup["z"]
        if entry.get("supports") == "none" and sup["mm3"] > SUPPORT_LIMIT_MM3:
            fails.append(("support needed", f"{sup['mm3']:.1f} mm3 ({sup['filament_mm']:.1f} mm of filament) of support in "
                          f"{sup['layers']} layer(s) at {sup['where']} mm; design says none"))
    return fails, record, t1 + t2


def check_all(root, jobs=2, keep=None, label=None):
    """Slices every printed part of root/manifest.json. Returns (failures, slicing record)."""
    root = Path(root)
    manifest = json.loads((root / "manifest.json").read_text())
    parts = {n: e for n, e in sorted(manifest.get("parts", {}).items()) if e.get("process") == "printed"}
    work = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="tipforge-slice-"))
    work.mkdir(parents=True, exist_ok=True)
    version = slicer_version()
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs)) as ex:
        futs = {n: ex.submit(check_part, n, e, root, work) for n, e in parts.items()}
        for n, f in futs.items():
            results[n] = f.result()
    if not keep:
        shutil.rmtree(work, ignore_errors=True)
    failures = [(n, r, v) for n, (fs, _, _) in results.items() for r, v in fs]
    record = {
        "slicer": version,
        "profile": PROFILE_REL,
        "command": " ".join(["prusa-slicer"] + slice_cmd("PART.stl", "PART.gcode", False)[1:]).replace(str(PROFILE), PROFILE_REL),
        "support_command_adds": "--support-material",
        "support_limit_mm3": SUPPORT_LIMIT_MM3,
        "parts": {n: rec for n, (_, rec, _) in results.items() if rec is not None},
    }
    return failures, record, {n: t for n, (_, _, t) in results.items()}


def fmt_time(s):
    if s is None:
        return "-"
    h, r = divmod(int(s), 3600)
    return f"{h}h{r // 60:02d}m{r % 60:02d}s" if h else f"{r // 60}m{r % 60:02d}s"


def print_table(record, failures, secs):
    failed = {n for n, _, _ in failures}
    print(f"{'part':<16} {'time':>9} {'g':>6} {'layers':>6} {'support mm3':>11}  {'slice s':>7}  result")
    for n, rec in record["parts"].items():
        sup = rec.get("support_mm3_if_enabled")
        print(f"{n:<16} {fmt_time(rec['print_time_s']):>9} {rec['filament_g'] if rec['filament_g'] is not None else '-':>6} "
              f"{rec['layers']:>6} {sup if sup is not None else '-':>11}  {secs.get(n, 0):>7.1f}  {'FAIL' if n in failed else 'ok'}")
    for n in sorted(failed - set(record["parts"])):
        print(f"{n:<16} {'-':>9} {'-':>6} {'-':>6} {'-':>11}  {secs.get(n, 0):>7.1f}  FAIL")


def main(root, jobs, keep):
    t0 = time.monotonic()
    root = Path(root)
    failures, record, secs = check_all(root, jobs, keep)
    (root / "slicing.json").write_text(json.dumps(record, indent=2) + "\n")
    print(f"{record['slicer']}, profile {record['profile']}: {len(record['parts'])} printed part(s) sliced "
          f"with {jobs} job(s) in {time.monotonic() - t0:.1f} s -> {root / 'slicing.json'}")
    print_table(record, failures, secs)
    for n, r, v in failures:
        print(f"{n}: {r}: {v}")
    if failures:
        print(f"{len(failures)} slicer rule(s) failed")
        return 1
    print("slicer checks passed")
    return 0


# ---------------------------------------------------------------- self-test
def box(size, center):
    b = trimesh.creation.box(extents=size)
    b.apply_translation(center)
    return b


def self_test_meshes():
    """name -> (mesh or raw bytes, manifest bbox min z override or None, rules that must fail)."""
    mushroom = trimesh.boolean.union([box((3, 3, 8), (0, 0, 4)), box((20, 20, 2), (0, 0, 9))], engine="manifold")
    # Inverted frustums: walls overhanging 45 deg from vertical print without support, 50 deg do not.
    def funnel(overhang_deg, h=6.0, r0=4.0):
        r1 = r0 + h * math.tan(math.radians(overhang_deg))
        m = trimesh.creation.cylinder(radius=1.0, height=h, sections=64)
        v = m.vertices.copy()
        top = v[:, 2] > 0
        rr = np.hypot(v[:, 0], v[:, 1])
        scale = np.where(rr > 1e-9, np.where(top, r1, r0) / np.maximum(rr, 1e-9), 0.0)
        v[:, 0] *= scale
        v[:, 1] *= scale
        v[:, 2] += h / 2
        return trimesh.Trimesh(v, m.faces)
    return {
        "box": (box((12, 10, 5), (3, -2, 2.5)), []),
        "overhang-45deg": (funnel(45.0), []),
        "overhang-50deg": (funnel(50.0), ["support needed"]),
        "mushroom": (mushroom, ["support needed"]),
        "lifted": (box((10, 10, 5), (0, 0, 2.5 + 1.0)), ["not on the bed"]),
        "sunk": (box((10, 10, 5), (0, 0, 2.5 - 0.6)), ["not on the bed"]),
        "stacked-gap": (trimesh.util.concatenate([box((10, 10, 3), (0, 0, 1.5)), box((10, 10, 3), (0, 0, 3 + 1.2 + 1.5))]), ["empty layer", "support needed"]),
        "garbage": (b"solid tipforge\n this is not an STL facet list\nendsolid\n" * 20, ["slicer error"]),
    }


def self_test(jobs=2):
    t0 = time.monotonic()
    cases = self_test_meshes()
    with tempfile.TemporaryDirectory(prefix="tipforge-slicer-self-test-") as tmp:
        root = Path(tmp)
        parts = {}
        for name, (mesh, _) in cases.items():
            path = root / f"{name}.stl"
            if isinstance(mesh, bytes):
                path.write_bytes(mesh)
                lo, hi = [0, 0, 0], [1, 1, 1]
            else:
                mesh.export(path)
                lo, hi = mesh.bounds.tolist()
            parts[name] = {"files": [path.name], "process": "printed", "supports": "none",
                           "bbox_mm": {"min": lo, "max": hi}}
        # A cast part is not sliced even when its file would fail.
        (root / "cast-garbage.stl").write_bytes(b"garbage")
        parts["cast-garbage"] = {"files": ["cast-garbage.stl"], "process": "cast", "bbox_mm": {"min": [0, 0, 0], "max": [1, 1, 1]}}
        (root / "manifest.json").write_text(json.dumps({"parts": parts}))
        failures, record, _ = check_all(root, jobs)
    ok = True
    for name, (_, want) in cases.items():
        got = sorted({r for n, r, _ in failures if n == name})
        detail = "; ".join(f"{r}: {v}" for n, r, v in failures if n == name) or "passes"
        good = got == sorted(want)
        ok &= good
        print(f"  {'ok  ' if good else 'FAIL'} {name:<15} expected {', '.join(want) or 'pass'}: {detail}")
    if any(n == "cast-garbage" for n, _, _ in failures):
        ok = False
        print("  FAIL cast part was sliced")
    # PrusaSlicer skips the height of an empty layer (the stacked-gap case above): a layer change
    # without extrusion, as another slicer version might write it, fails too.
    gc = Path(tempfile.mkdtemp(prefix="tipforge-gcode-")) / "empty.gcode"
    gc.write_text("M83\n" + "".join(f";LAYER_CHANGE\n;Z:{z}\n;TYPE:External perimeter\nG1 X1 Y1 E{e}\nG1 E0.8\n"
                                     for z, e in ((0.2, 0.5), (0.4, 0), (0.6, 0.5))))
    got = layer_problems(parse_gcode(gc))
    shutil.rmtree(gc.parent)
    good = [r for r, _ in got] == ["empty layer"] and "0.40" in got[0][1]
    ok &= good
    print(f"  {'ok  ' if good else 'FAIL'} {'empty-gcode':<15} expected empty layer: {'; '.join(f'{r}: {v}' for r, v in got) or 'passes'}")
    rec = record["parts"].get("box", {})
    if not (rec.get("print_time_s") and rec.get("filament_g") and rec.get("layers") == 25):
        ok = False
        print(f"  FAIL box statistics: {rec}")
    else:
        print(f"  ok   box statistics: {fmt_time(rec['print_time_s'])}, {rec['filament_g']} g, {rec['layers']} layers")
    print(f"slicer self-test {'passed' if ok else 'FAILED'} ({record['slicer']}, {time.monotonic() - t0:.1f} s)")
    return 0 if ok else 1


def parse_args(argv):
    args = {"jobs": 2, "keep": None, "self_test": False, "out": "out"}
    it = iter(argv)
    for a in it:
        if a == "--self-test":
            args["self_test"] = True
        elif a == "--jobs":
            args["jobs"] = int(next(it))
        elif a == "--keep":
            args["keep"] = next(it)
        elif a.startswith("-"):
            sys.exit(__doc__)
        else:
            args["out"] = a
    return args


if __name__ == "__main__":
    a = parse_args(sys.argv[1:])
    if a["self_test"]:
        sys.exit(self_test(a["jobs"]))
    sys.exit(main(a["out"], a["jobs"], a["keep"]))
