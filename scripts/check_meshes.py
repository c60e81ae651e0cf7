#!/usr/bin/env python3
"""Independent mesh checks of tipforge's output with trimesh and manifold3d.

Reads OUT/manifest.json and, for every part, the STL and 3MF it lists and the parameter file it
came from. Each failed rule prints `part: rule: measured value` and the exit code is 1.

    check_meshes.py [OUT]          check a build output folder (default: out)
    check_meshes.py --self-test    prove each rule fails on a mesh made to break it
"""
import json
import math
import sys
import tomllib
from pathlib import Path

import lib3mf
import manifold3d as m3
import numpy as np
import trimesh

RULES = []


def rule(fn):
    RULES.append(fn)
    return fn


class Ctx:
    """One part under test: meshes, manifold, manifest entry, parameters."""

    def __init__(self, name, entry, stl_mesh, other_mesh, params, root):
        self.name = name
        self.entry = entry
        self.mesh = stl_mesh
        self.other = other_mesh
        self.params = params
        self.root = root
        self.manifold = to_manifold(stl_mesh)
        f = entry.get("features", {})
        self.features = f if isinstance(f, dict) else {}
        self.tol = float(self.features.get("chordal_tolerance_mm", 0.01))


def to_manifold(mesh):
    # trimesh merges STL's repeated vertices on load (process=True); manifold needs shared vertices.
    return m3.Manifold(m3.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32), tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def read_3mf_strict(path):
    """Reads a 3MF with the 3MF Consortium's lib3mf in strict mode. Returns (objects, build item
    object ids, warnings): objects as (id, name, type name)."""
    w = lib3mf.get_wrapper()
    model = w.CreateModel()
    reader = model.QueryReader("3mf")
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(str(path))
    warnings = [reader.GetWarning(i)[1] for i in range(reader.GetWarningCount())]
    objs = []
    it = model.GetObjects()
    while it.MoveNext():
        o = it.GetCurrentObject()
        objs.append((o.GetResourceID(), o.GetName(), lib3mf.ObjectType(o.GetType()).name))
    items = []
    b = model.GetBuildItems()
    while b.MoveNext():
        items.append(b.GetCurrent().GetObjectResourceID())
    return objs, items, warnings


def check_3mf_file(path):
    """A 3MF as a slicer would take it: loads in lib3mf strict mode without warnings; reference
    objects (named "... (reference ...)") are type OTHER and not in the build; every build item is
    a model."""
    out = []
    try:
        objs, items, warnings = read_3mf_strict(path)
    except Exception as e:
        return [(path.name, "must load in lib3mf strict mode", repr(e))]
    if warnings:
        out.append((path.name, "lib3mf strict mode must give no warnings", "; ".join(warnings)))
    types = {i: t for i, _, t in objs}
    for i, name, t in objs:
        if "(reference" in name and (t.upper() != "OTHER" or i in items):
            out.append((path.name, "a reference object must be type OTHER and not a build item", f"{name}: type {t}, in build {i in items}"))
    for i in items:
        if types.get(i, "").upper() != "MODEL":
            out.append((path.name, "every build item must be a printable model", f"object {i}: type {types.get(i)}"))
    if not items:
        out.append((path.name, "a 3MF must place at least one object on the build", "0 build items"))
    return out


def frame_to_z(normal, origin):
    """3x4 transform taking `origin` to 0 and unit `normal` to +z."""
    w = np.asarray(normal, float)
    w = w / np.linalg.norm(w)
    helper = np.array([1.0, 0, 0]) if abs(w[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(helper, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    r = np.vstack([u, v, w])  # rows: new axes
    t = -r @ np.asarray(origin, float)
    return np.hstack([r, t[:, None]]), r


# ---------------------------------------------------------------- validity rules
@rule
def watertight(c):
    if not c.mesh.is_watertight:
        return "mesh must be watertight", "open edges present"


@rule
def winding(c):
    if not c.mesh.is_winding_consistent:
        return "winding must be consistent", "inconsistent face winding"


@rule
def is_volume_positive(c):
    v = c.mesh.volume
    if not c.mesh.is_volume or v <= 0:
        return "must be a positive volume (an inside-out mesh passes manifold status with negative volume)", f"is_volume={c.mesh.is_volume}, volume={v:.3f} mm3"


@rule
def manifold_status(c):
    st = c.manifold.status()
    if st != m3.Error.NoError:
        return "manifold3d status must be NoError after merging STL vertices", str(st)
    if c.manifold.volume() <= 0:
        return "manifold3d volume must be positive", f"{c.manifold.volume():.3f} mm3"


@rule
def one_body(c):
    n = len(c.manifold.decompose())
    if n != 1:
        return "a part must be one body", f"{n} bodies"


@rule
def no_self_overlap(c):
    parts = c.manifold.decompose()
    total = sum(p.volume() for p in parts)
    union = m3.Manifold.batch_boolean(parts, m3.OpType.Add).volume() if len(parts) > 1 else parts[0].volume() if parts else 0.0
    if abs(union - total) > 1e-6 * max(total, 1.0) or abs(c.mesh.volume - c.manifold.volume()) > 1e-4 * max(total, 1.0):
        return "no self-overlap: union volume must equal the summed volume", f"union {union:.4f}, sum {total:.4f}, trimesh {c.mesh.volume:.4f} mm3"


@rule
def genus_matches(c):
    g = c.manifold.genus()
    want = c.entry.get("genus")
    holes = c.features.get("holes")
    expected = len(holes) if isinstance(holes, list) else want
    if g != want or g != expected:
        return "genus must equal the number of through holes", f"genus {g}, manifest {want}, hole wall crossings {expected}"


@rule
def stl_and_3mf_agree(c):
    if c.other is None:
        return None
    a, b = c.mesh, c.other
    if len(a.faces) != len(b.faces) or abs(a.volume - b.volume) > 1e-6 * abs(a.volume) + 1e-6:
        return "STL and 3MF must hold the same mesh", f"faces {len(a.faces)} vs {len(b.faces)}, volume {a.volume:.4f} vs {b.volume:.4f}"
    if not np.allclose(np.sort(a.bounds, axis=0), np.sort(b.bounds, axis=0), atol=1e-5):
        return "STL and 3MF must hold the same mesh", f"bounds {a.bounds.tolist()} vs {b.bounds.tolist()}"


@rule
def on_the_bed(c):
    """A printed part is written in its print orientation resting on the bed (z = 0); a slicer
    would otherwise drop it silently, or print it in the air."""
    if c.entry.get("process") != "printed":
        return None
    zmin = float(c.mesh.bounds[0][2])
    if abs(zmin) > 1e-3:
        return ("a printed part must rest on the bed (min z = 0)", f"min z {zmin:.4f} mm")
    return None


@rule
def manifest_numbers(c):
    v = c.entry.get("volume_mm3")
    if v is None or abs(v - c.mesh.volume) > 1e-3 * abs(c.mesh.volume) + 0.01:
        return "manifest volume must match the mesh", f"manifest {v}, mesh {c.mesh.volume:.3f} mm3"
    if c.entry.get("triangles") != len(c.mesh.faces):
        return "manifest triangle count must match the mesh", f"{c.entry.get('triangles')} vs {len(c.mesh.faces)}"


def wall_losses(cs, r):
    """Pieces that an opening by radius r removes and that are walls (not corner slivers)."""
    opened = cs.offset(-r, m3.JoinType.Round, 2.0, 64).offset(r, m3.JoinType.Round, 2.0, 64)
    lost = cs - opened
    out = []
    for piece in lost.decompose():
        area = piece.area()
        perim = 0.0
        for poly in piece.to_polygons():
            p = np.asarray(poly)
            perim += np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1).sum()
        width = area / max(perim / 2.0, 1e-12)
        # a wall thinner than 2r is removed whole: its width estimate is its thickness and its area
        # grows with its length; a convex corner loses a sliver of width ~0.12 r (90°) to ~0.3 r (50°).
        if width > 0.45 * r and area > 0.5 * r * r:
            c = np.asarray(piece.to_polygons()[0]).mean(axis=0)
            out.append((width, area, c))
    return out


def ray_thickness(c, point):
    """Wall thickness at the surface nearest a 3D point: distance along the inward normal to the
    first surface facing the other way (opposite walls, normals within ~45° of antiparallel).
    Edges between faces meeting at an angle (wedges, chamfers) are not walls and are not counted."""
    closest, _, tri = trimesh.proximity.closest_point(c.mesh, [point])
    n = c.mesh.face_normals[tri[0]]
    origin = closest[0] - n * 1e-4
    locs, _, tris = c.mesh.ray.intersects_location([origin], [-n], multiple_hits=True)
    best = None
    for loc, t in zip(locs, tris):
        d = float(np.dot(loc - origin, -n))
        if d <= 1e-6:
            continue
        if np.dot(c.mesh.face_normals[t], n) < -0.7 and (best is None or d < best):
            best = d
    return best


@rule
def min_wall(c):
    """Slice stack along x, y and z; each slice is opened (inward offset, then outward) by half the
    minimum wall. A piece the opening removes is a thin-wall candidate; it is confirmed by measuring
    the wall in 3D across the nearest surface (slices cut oblique edges into thin strips that are not
    walls)."""
    w = c.features.get("min_wall_mm")
    if w is None:
        return None
    r = 0.5 * w - max(c.tol, 0.005)
    mf = c.manifold
    worst = None
    rots = [np.eye(3), np.array([[0, 0, 1.0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1.0, 0], [0, 0, 1], [1, 0, 0]])]
    checked = 0
    for axis, rot in zip("zxy", rots):
        t = np.hstack([rot, np.zeros((3, 1))])
        turned = mf.transform(t)
        lo, hi = turned.bounding_box()[2], turned.bounding_box()[5]
        n = max(8, int((hi - lo) / 0.4))
        for k in range(1, n):
            z = lo + (hi - lo) * k / n
            for width, area, cen in wall_losses(turned.slice(z), r):
                p3 = rot.T @ np.array([cen[0], cen[1], z])
                checked += 1
                th = ray_thickness(c, p3)
                if th is not None and th < w - 2 * c.tol - 1e-3 and (worst is None or th < worst[0]):
                    worst = (th, axis, z, p3)
    if worst:
        th, axis, z, p3 = worst
        return f"minimum wall must be at least {w} mm", f"a wall of {th:.3f} mm near {np.round(p3, 2).tolist()} (found in the {axis}-slice stack; {checked} candidates measured)"


# ---------------------------------------------------------------- dimensional rules
def loop_around(cs, point):
    """The smallest contour of a cross-section that contains `point` (2D)."""
    best = None
    for poly in cs.to_polygons():
        p = np.asarray(poly)
        if len(p) < 3:
            continue
        if trimesh.path.polygons.Polygon if False else True:
            inside = point_in_poly(point, p)
        if inside:
            area = abs(poly_area(p))
            if best is None or area < best[0]:
                best = (area, p)
    return best


def seg_distance_min(p, pt):
    """Smallest distance from point `pt` to the closed polygon `p`'s edges."""
    a = np.asarray(p, float)
    b = np.roll(a, -1, axis=0)
    q = np.asarray(pt, float)
    ab = b - a
    t = np.clip(((q - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-30), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + ab * t[:, None] - q, axis=1)))


def point_in_poly(pt, p):
    x, y = pt
    inside = False
    j = len(p) - 1
    for i in range(len(p)):
        xi, yi = p[i]
        xj, yj = p[j]
        if (yi > y) != (yj > y) and x < (xj - xi) * (y - yi) / (yj - yi + 1e-300) + xi:
            inside = not inside
        j = i
    return inside


def poly_area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@rule
def hole_diameters(c):
    for i, h in enumerate(c.features.get("holes", []) or []):
        if "axis_point" not in h:
            continue  # a tunnel counted for the genus, not a round hole
        t, _ = frame_to_z(h["axis_dir"], h["axis_point"])
        cs = c.manifold.transform(t).slice(0.0)
        found = loop_around(cs, (0.0, 0.0))
        if found is None:
            return "screw hole must be present", f"hole {i}: no contour around its axis"
        # the screw's diameter is the largest circle about the axis inside the contour: a round hole's
        # own, and a teardrop's (whose 45° cap above the circle only adds room)
        d = 2 * seg_distance_min(found[1], (0.0, 0.0))
        if abs(d - h["diameter_mm"]) > 2 * c.tol + 2e-3:
            return "hole diameter must match the parameter", f"hole {i}: {d:.4f} mm (largest circle about the axis), expected {h['diameter_mm']} mm"


def cast(mf, origin, direction, length=50.0):
    o = np.asarray(origin, float)
    e = o + np.asarray(direction, float) * length
    hits = mf.ray_cast(o.tolist(), e.tolist())
    return [hh.distance * length for hh in hits]


@rule
def seats(c):
    for i, s in enumerate(c.features.get("seats", []) or []):
        n = np.asarray(s["normal"], float)
        fc = np.asarray(s["flat_center"], float)
        _, r = frame_to_z(n, fc)
        u, v = r[0], r[1]
        away = np.asarray(s.get("channel_dir", [0, 0, 0]), float)
        start = 5.0
        # floor depth at the centre, flat plane on a ring between the pocket and the flat's rim
        d_floor = cast(c.manifold, fc + n * start, -n)
        if not d_floor:
            return "seat pocket must be present", f"seat {i}: ray found no floor"
        depth = d_floor[0] - start
        if abs(depth - s["seat_depth_mm"]) > 2e-3 + c.tol * 0.1:
            return "seat depth must match the parameter", f"seat {i}: {depth:.4f} mm, expected {s['seat_depth_mm']} mm"
        rr = 0.5 * (s["seat_diameter_mm"] + s["flat_diameter_mm"]) / 2.0
        heights = []
        for k in range(24):
            a = 2 * math.pi * k / 24
            d = math.cos(a) * u + math.sin(a) * v
            if np.dot(d, away) > 0.2:
                continue  # the tail channel leaves the seat this way
            hit = cast(c.manifold, fc + d * rr + n * start, -n)
            if hit:
                heights.append(hit[0] - start)
        # flat: nothing stands above the seat plane, and most of the ring lies on it (another
        # sensor's tail channel may cross the ring below the plane)
        on_plane = [h for h in heights if abs(h) <= c.tol + 2e-3]
        if not heights or min(heights) < -(c.tol + 2e-3) or len(on_plane) < 0.6 * len(heights):
            return "seat must be flat within the chordal tolerance", f"seat {i}: ring heights {np.round(heights, 4).tolist()} mm"
        # pocket diameter: slice at mid-depth, radius of the loop in directions away from the channel
        t, _ = frame_to_z(n, fc - n * s["seat_depth_mm"] / 2)
        cs = c.manifold.transform(t).slice(0.0)
        found = loop_around(cs, (0.0, 0.0))
        if found is not None:
            p = found[1]
        elif not s.get("opened_by_channels"):
            return "seat pocket must be present", f"seat {i}: no contour at mid-depth"
        else:
            # another sensor's tail channel opens into this pocket's rim, so the pocket's contour
            # runs on along that channel and no loop closes round the centre: in each of 72
            # directions take the nearest contour point (the pocket's wall, except across the
            # opening: a minority of directions, so the median below holds)
            pts = [np.asarray(q) for q in cs.to_polygons() if len(q) >= 3]
            pts = np.concatenate(pts) if pts else np.zeros((0, 2))
            near = []
            if len(pts):
                pts = pts[np.linalg.norm(pts, axis=1) < 0.6 * s["flat_diameter_mm"]]
                ang = np.floor((np.arctan2(pts[:, 1], pts[:, 0]) + math.pi) / (2 * math.pi) * 72).astype(int)
                for b in set(ang.tolist()):
                    q = pts[ang == b]
                    near.append(q[np.argmin(np.linalg.norm(q, axis=1))])
            p = np.asarray(near, float).reshape(-1, 2)
            if len(p) < 8:
                return "seat pocket must be present", f"seat {i}: no contour at mid-depth"
        p = np.asarray(p, float)
        dirs3 = p[:, :1] * u + p[:, 1:2] * v
        radii = np.linalg.norm(p, axis=1)
        keep = (dirs3 @ away) < 0.2 * radii
        if keep.sum() < 8:
            return "seat pocket must be measurable", f"seat {i}: {keep.sum()} points"
        rad = np.median(radii[keep])
        if abs(2 * rad - s["seat_diameter_mm"]) > 2 * c.tol + 4e-3:
            return "seat diameter must match the parameter", f"seat {i}: {2*rad:.4f} mm, expected {s['seat_diameter_mm']} mm"


@rule
def bounding_box(c):
    f = c.features
    if f.get("kind") != "fingertip":
        return None
    ext = c.mesh.bounds[1] - c.mesh.bounds[0]
    slack = 2 * c.tol + 2e-3
    w, t, l = f["width_mm"], f["thickness_mm"], f["length_mm"]
    if abs(ext[0] - w) > slack or abs(ext[2] - l) > slack or not (t - f["max_channel_depth_mm"] - 1.0 <= ext[1] <= t + slack):
        return "bounding box must match width x thickness x length", f"{np.round(ext, 4).tolist()} vs {[w, t, l]}"
    if abs(c.mesh.bounds[0][2]) > 1e-6:
        return "print orientation: the mount face must lie on the bed (z = 0)", f"min z {c.mesh.bounds[0][2]}"


def monotone(xs, ys, t):
    """The monotone cubic (Fritsch-Butland slopes, level ends, held beyond them) at t: the
    interpolation the anatomical body is lofted with, written again from its description."""
    n = len(xs)
    if n < 2 or t <= xs[0]:
        return ys[0]
    if t >= xs[-1]:
        return ys[-1]
    d = [(ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]) for i in range(n - 1)]
    m = [0.0] * n
    for i in range(1, n - 1):
        h0, h1 = xs[i] - xs[i - 1], xs[i + 1] - xs[i]
        if d[i - 1] * d[i] > 0:
            m[i] = 3 * (h0 + h1) / ((2 * h1 + h0) / d[i - 1] + (h1 + 2 * h0) / d[i])
    i = max(k for k in range(n - 1) if xs[k] <= t)
    h = xs[i + 1] - xs[i]
    u = (t - xs[i]) / h
    return ((2 * u**3 - 3 * u**2 + 1) * ys[i] + (u**3 - 2 * u**2 + u) * h * m[i]
            + (-2 * u**3 + 3 * u**2) * ys[i + 1] + (u**3 - u**2) * h * m[i + 1])


def envelope(xs, ys, x_cap):
    """Largest value of the interpolation over [0, x_cap], sampled every 0.05 mm and at the
    stations."""
    steps = max(1, int(x_cap / 0.05))
    ts = [x_cap * k / steps for k in range(steps + 1)] + [x for x in xs if 0 <= x <= x_cap]
    return max(monotone(xs, ys, t) for t in ts)


@rule
def params_match_manifest(c):
    if c.params is None:
        return None
    body = c.params.get("body")
    if body and c.features.get("kind") == "fingertip":
        if "station" in body:
            # anatomical: the envelope of the stations' interpolation over the body (widest; highest
            # nail over deepest pad)
            st, L, tip = body["station"], body["length_mm"], body["tip_length_mm"]
            env = {k: envelope([L - x["from_tip_mm"] for x in st], [x[k] for x in st], L - tip) for k in ("width_mm", "pad_depth_mm", "nail_height_mm")}
            want = {"width_mm": env["width_mm"], "length_mm": L, "thickness_mm": env["nail_height_mm"] + env["pad_depth_mm"]}
        else:
            want = {k: body[k] for k in ("width_mm", "length_mm", "thickness_mm")}
        for key, w in want.items():
            if abs(w - c.features[key]) > 1e-6:
                return "manifest features must come from the parameter file", f"{key}: {w} vs {c.features[key]}"
        sensors = c.params.get("sensor", [])
        # the seats are made for the sensor board the file names: pocket = board + 2 x clearance, as
        # deep as the board is thick
        board = c.params.get("_board", {})
        for i, (sp, sf) in enumerate(zip(sensors, c.features.get("seats", []))):
            want = {"seat_diameter_mm": board.get("board_diameter_mm", float("nan")) + 2 * sp.get("seat_clearance_mm", 0.2),
                    "seat_depth_mm": board.get("board_thickness_mm", float("nan")),
                    "dome_diameter_mm": board.get("dome_diameter_mm", float("nan"))}
            for key, w in want.items():
                if not abs(w - sf[key]) <= 1e-9:
                    return "manifest features must come from the parameter file and its sensor board", f"sensor[{i}].{key}: {w} vs {sf[key]}"


# ---------------------------------------------------------------- assemblies
def polys_centroid_area(cs):
    a = cx = cy = 0.0
    for poly in cs.to_polygons():
        p = np.asarray(poly)
        q = np.roll(p, -1, axis=0)
        cr = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
        a += cr.sum() / 2
        cx += ((p[:, 0] + q[:, 0]) * cr).sum() / 6
        cy += ((p[:, 1] + q[:, 1]) * cr).sum() / 6
    return (cx / a, cy / a), a


def check_rig(name, rig, man, root):
    """Assembly rules of the calibration rig, measured on the written meshes."""
    out = []
    base = to_manifold(trimesh.load(str(root / f"{rig['base']}.stl"), process=True))
    plm = trimesh.load(str(root / f"{rig['plunger']}.stl"), process=True)
    t = rig["plunger_print_to_assembled"]
    m = np.array([t["x"], t["y"], t["z"]], dtype=float)
    plunger = to_manifold(plm).transform(m)
    fail = lambda rule, val: out.append((f"{name}-assembly", rule, val))
    inter = (base ^ plunger).volume()
    if inter > 1e-4:
        fail("assembled parts must not intersect", f"{inter:.5f} mm3 shared")
    slider = plunger.trim_by_plane([0, 0, -1], -(rig["plate_bottom_z_mm"] - 1e-3))
    want = rig["clearance_mm"] - 0.02
    gaps = []
    for d in np.linspace(-rig["dome_height_mm"], rig["stop_gap_mm"], 9):
        gaps.append(slider.translate([0, 0, -d]).min_gap(base, 2 * rig["clearance_mm"] + 1))
    if min(gaps) < want:
        fail("sliding clearance must hold along the travel", f"min gap {min(gaps):.4f} mm (need >= {want:.3f})")
    # seat floor by a ray down the axis, then the dome top from the sensor's dimensions
    hits = base.ray_cast([0, 0, 100.0], [0, 0, -100.0])
    floor = 100.0 - hits[0].distance * 200.0
    dome_top = floor + rig["board_thickness_mm"] + rig["dome_height_mm"]
    # the seat recess is whole layers deep and no shallower than the board (issue 18, item 4)
    if "layer_height_mm" in rig:
        depth, lh = rig["base_top_z_mm"] - floor, rig["layer_height_mm"]
        if abs(depth / lh - round(depth / lh)) > 1e-3 or depth < rig["board_thickness_mm"] - 1e-6:
            fail("the seat recess must be whole layers deep and hold the whole board", f"{depth:.4f} mm at {lh} mm layers, board {rig['board_thickness_mm']} mm")
    face_z = plunger.bounding_box()[2]
    if abs(face_z - dome_top) > 0.05:
        fail("the frustum face must rest on the dome top (0 +/- 0.05 mm)", f"gap {face_z - dome_top:.4f} mm")
    (fx, fy), area = polys_centroid_area(plunger.slice(face_z + 1e-4))
    nominal = math.pi * (rig["face_diameter_mm"] / 2) ** 2
    if abs(area / nominal - 1) > 1e-3:
        fail("the small face must have the sensing area within 0.1 %", f"{area:.4f} vs {nominal:.4f} mm2 ({100*(area/nominal-1):+.3f} %)")
    # seat axis: circle fit to the recess wall (the tail slot opens one side, so it is no closed loop)
    r_seat = man["parts"][rig["base"]]["features"]["seat_diameter_mm"] / 2
    pts = np.vstack([np.asarray(p) for p in base.slice(floor + rig["board_thickness_mm"] / 2).to_polygons()])
    rad = np.hypot(pts[:, 0], pts[:, 1])
    pts = pts[(rad > 0.8 * r_seat) & (rad < 1.2 * r_seat)]
    if len(pts) < 8:
        fail("the base must have a sensor seat on the axis", f"{len(pts)} points of a recess wall found")
    else:
        for _ in range(3):  # fit, drop points off the circle (slot edges), refit
            a = np.column_stack([2 * pts[:, 0], 2 * pts[:, 1], np.ones(len(pts))])
            sol, *_ = np.linalg.lstsq(a, (pts ** 2).sum(axis=1), rcond=None)
            sx, sy = sol[0], sol[1]
            r = math.sqrt(sol[2] + sx * sx + sy * sy)
            keep = np.abs(np.hypot(pts[:, 0] - sx, pts[:, 1] - sy) - r) < 0.02
            if keep.all() or keep.sum() < 8:
                break
            pts = pts[keep]
        off = math.hypot(fx - sx, fy - sy)
        if off > 0.01:
            fail("frustum axis must be on the seat axis within 0.01 mm", f"{off:.4f} mm")
    zc = rig["plate_top_z_mm"] - rig["scale_depth_mm"] / 2
    cs = plunger.slice(zc)
    (rx, ry), _ = polys_centroid_area(cs)
    if cs.num_contour() < 3 or math.hypot(rx - fx, ry - fy) > 0.01:
        fail("the centring scale must be engraved and concentric with the frustum", f"{cs.num_contour()} contours, offset {math.hypot(rx - fx, ry - fy):.4f} mm")
    pre = man["parts"][rig["plunger"]].get("preload_g")
    exp = plm.volume / 1000 * rig["density_g_cm3"] * rig["infill"]
    if pre is None or abs(pre - exp) > 1e-3 * exp:
        fail("the manifest preload must be the plunger's mass", f"{pre} g vs {exp:.4f} g")
    print(f"{name}-assembly: {'ok' if not out else 'FAILED'} (face area {area:.4f} mm2 = {100*(area/nominal-1):+.4f} %, min sliding gap {min(gaps):.4f} mm, rest gap {face_z - dome_top:+.4f} mm)")
    return out


def polys_centroid_area_simple(p):
    q = np.roll(p, -1, axis=0)
    cr = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    a = cr.sum() / 2
    return (((p[:, 0] + q[:, 0]) * cr).sum() / (6 * a), ((p[:, 1] + q[:, 1]) * cr).sum() / (6 * a)), a


# ---------------------------------------------------------------- molds
def affine(m):
    """3x4 row matrix from the manifest to a manifold3d transform."""
    return np.asarray(m, dtype=float)


def mold_inputs(name, mold, man, root):
    """The assembled pieces, the cavity, the cover and the fingertip of a conforming mold, as
    manifolds in the mold's assembled frame, from the written STL files."""
    fr = mold["frames"]
    load = lambda part: to_manifold(trimesh.load(str(root / f"{part}.stl"), process=True))
    core = load(mold["pieces"][0]).transform(affine(fr["core_print_to_assembled"]))
    shell = load(mold["pieces"][1]).transform(affine(fr["shell_print_to_assembled"]))
    cover = load(mold["cover"]).transform(affine(fr["cover_print_to_assembled"]))
    tip = load(mold["fingertip_part"]).transform(affine(fr["fingertip_print_to_assembled"]))
    return core, shell, cover, tip


def grow(mf, k, center):
    c = np.asarray(center, float)
    return mf.translate(list(-c)).scale([k, k, k]).translate(list(c))


def regions(mf, min_volume=1e-3):
    return [p for p in mf.decompose() if p.volume() > min_volume]


def sprue_mouth_covered(mold, core, shell):
    """Area (mm2) of the sprue's mouth (its circle just under the parting plane, within the chordal
    tolerance) over the core or the shell: it must lie wholly over liquid."""
    sp, zp = mold["openings"][0], mold["parting_z_mm"]
    rm = sp["radius_mm"] - mold["chordal_tolerance_mm"]
    disc = m3.Manifold.cylinder(0.02, rm, rm, 96).translate([sp["xy"][0], sp["xy"][1], zp - 0.03])
    return ((disc ^ core).volume() + (disc ^ shell).volume()) / 0.02


def opening_plugs(mold, cavity):
    """Plugs for the sprue and vents from where they open (the rim, or a pocket's top) up through the
    flange, and for the sprue's gate well beside the rim (the sprue's, not the cover's)."""
    zp, zt = mold["parting_z_mm"], mold["flange_top_z_mm"]
    plugs = None
    for o in mold["openings"]:
        z0 = o.get("from_z_mm", zp)
        r = o["radius_mm"] + (zt - zp + 2) * math.tan(math.radians(45)) + 0.2 if "from_z_mm" not in o else o["radius_mm"] + 0.2
        c = m3.Manifold.cylinder(zt - z0 + 3, r, r, 48).translate([o["xy"][0], o["xy"][1], z0])
        plugs = c if plugs is None else plugs + c
        if "gate_well" in o:
            # 0.05 mm wider than the well's cone (its polygon's corners stand outside the circle)
            g = o["gate_well"]
            top = o["radius_mm"] + 0.01 * (o["radius_mm"] - g["radius_bottom_mm"]) / g["depth_mm"]
            well = m3.Manifold.cylinder(g["depth_mm"] + 0.01, g["radius_bottom_mm"] + 0.05, top + 0.05, 96)
            plugs = plugs + (well.translate([o["xy"][0], o["xy"][1], zp - g["depth_mm"]]) - cavity)
    return plugs


def in_gate_well(mold, p):
    """Which points lie within the sprue's gate well (its top radius, from its floor to the parting plane)."""
    sp, zp = mold["openings"][0], mold["parting_z_mm"]
    if "gate_well" not in sp:
        return np.zeros(len(p), bool)
    depth = sp["gate_well"]["depth_mm"]
    return (np.hypot(p[:, 0] - sp["xy"][0], p[:, 1] - sp["xy"][1]) < sp["radius_mm"] + 0.05) & (p[:, 2] > zp - depth - 0.05) & (p[:, 2] < zp + 0.05)


def check_mold(name, mold, core, shell, cover, tip, tol_sum=0.03):
    """Rules of an assembled conforming mold, independent of tipforge's own checks."""
    out = []
    fail = lambda rule, val: out.append((f"{name}-assembly", rule, val))
    fr = mold["frames"]
    k = fr["cavity_scale"]
    cavity = grow(cover, k, fr["cavity_scale_center"])
    # pieces and cavity are disjoint
    for what, a, b in (("core and shell", core, shell), ("core and cavity", core, cavity), ("shell and cavity", shell, cavity)):
        v = (a ^ b).volume()
        if v > 1e-3:
            fail("assembled pieces must not intersect each other or the cavity", f"{what}: {v:.4f} mm3")
    # the cavity is the cover grown by the shrinkage allowance
    if abs(cavity.volume() / k ** 3 / cover.volume() - 1) > 1e-4:
        fail("the cavity's volume must equal the cover's times the shrinkage allowance", f"{cavity.volume():.3f} vs {cover.volume():.3f} x {k ** 3:.5f}")
    # one cavity, open only through the sprue and vents: the box less the pieces is the air inside
    pieces = core + shell
    b = pieces.bounding_box()
    lo, hi = np.array(b[:3]), np.array(b[3:])
    box = m3.Manifold.cube(list(hi - lo)).translate(list(lo))
    air = regions(box - pieces)
    cav_air = [r for r in air if (r ^ cavity).volume() > 0.5 * cavity.volume()]
    top_band = m3.Manifold.cube([hi[0] - lo[0], hi[1] - lo[1], 0.05]).translate([lo[0], lo[1], hi[2] - 0.05])
    if len(cav_air) != 1 or (cav_air[0] ^ top_band).volume() < 1e-4:
        fail("the cavity must reach the outside through its openings", f"{len(cav_air)} air regions hold the cavity")
    zp, zt = mold["parting_z_mm"], mold["flange_top_z_mm"]
    covered = sprue_mouth_covered(mold, core, shell)
    if covered > 0.01:
        fail("the sprue's mouth must lie wholly over the cavity", f"{covered:.3f} mm2 of it over the core's plug or the shell's face")
    plugs = opening_plugs(mold, cavity)
    # the key holes' clearances are closed pockets, not the cavity (they touch it only along the
    # parting plane, where the pieces meet): filled, as the build's own check does
    keys = None
    for kh in mold.get("key_holes", []):
        t = kh["top"]
        c = m3.Manifold.cylinder(kh["depth_mm"], kh["r_bottom_mm"], kh["r_top_mm"], 48).translate([t[0], t[1], t[2] - kh["depth_mm"]])
        keys = c if keys is None else keys + c
    filled = pieces + plugs if keys is None else pieces + plugs + keys
    sealed = regions(box - filled)
    cav_sealed = [r for r in sealed if (r ^ cavity).volume() > 0.5 * cavity.volume()]
    enclosed = cav_sealed[0].volume() if len(cav_sealed) == 1 else float("nan")
    # air at the mold's outer faces (within 0.05 mm) means a leak; zero-volume films along the faces
    # where the pieces touch connect nothing
    inner_box = m3.Manifold.cube(list(hi - lo - 0.1)).translate(list(lo + 0.05))
    touches = len(cav_sealed) == 1 and (cav_sealed[0] - inner_box).volume() > 1e-4
    if len(cav_sealed) != 1 or touches or abs(enclosed / cavity.volume() - 1) > 2e-3:
        fail("with the sprue and vents plugged the cavity must be closed", f"{len(cav_sealed)} regions, enclosed {enclosed:.3f} vs cavity {cavity.volume():.3f} mm3, touches the mold's outside: {touches}")
    # the cover's inner surface lies on the fingertip: inner vertices (within half the thickness of
    # the fingertip) away from the pockets, channels and domes are within 0.05 mm of it
    t = mold["cover_thickness_mm"]
    cm = trimesh.Trimesh(*_mesh_of(cover))
    tm = trimesh.Trimesh(*_mesh_of(tip))
    v = cm.vertices
    keep = np.ones(len(v), bool)
    for st in mold["seats_assembled"]:
        rel = v - np.asarray(st["center"])
        h = rel @ np.asarray(st["normal"])
        radial = np.linalg.norm(rel - np.outer(h, st["normal"]), axis=1)
        keep &= radial >= st["seat_diameter_mm"] / 2 + 0.05
        path = np.asarray(st["channel_path_xy"])
        band = st["channel_width_mm"] / 2 + 2 * st["channel_depth_mm"] + 0.2
        for a2, b2 in zip(path[:-1], path[1:]):
            d = b2 - a2
            tt = np.clip(((v[:, :2] - a2) @ d) / (d @ d), 0, 1)
            keep &= np.linalg.norm(v[:, :2] - a2 - np.outer(tt, d), axis=1) >= band
    _, dist, _ = trimesh.proximity.closest_point(tm, v[keep])
    inner = dist[dist < t / 2]
    worst = float(inner.max()) if len(inner) else float("inf")
    if not len(inner) or worst > 0.05:
        fail("the cover's inner surface must lie on the fingertip within 0.05 mm", f"max {worst:.4f} mm over {len(inner)} vertices")
    # the cover does not enter the fingertip; each dome fits its cavity
    # both are tessellations inscribed in the same exact pad, so they may cross by the sum of their
    # chordal tolerances, no more: fingertip vertices inside the cover must be that close to it
    allow = tol_sum + 1e-3
    inside = tm.vertices[cm.contains(tm.vertices)]
    depth = float(trimesh.proximity.closest_point(cm, inside)[1].max()) if len(inside) else 0.0
    if depth > allow:
        fail("the cover must not enter the fingertip (beyond the chordal tolerances)", f"{depth:.4f} mm deep (allowed {allow:.3f})")
    for i, d in enumerate(mold["domes_assembled"]):
        r, h = d["dome_diameter_mm"] / 2, d["dome_height_mm"]
        n = np.asarray(d["normal"], float)
        t34, rot = frame_to_z(n, d["base"])
        inv = np.hstack([rot.T, np.asarray(d["base"], float)[:, None]])
        dome = m3.Manifold.cylinder(h, r, r, 96).transform(inv)
        ov = (dome ^ cover).volume()
        if ov > 1e-4:
            fail("each sensor dome must fit its cavity", f"dome {i}: {ov:.5f} mm3 inside the cover")
    # no undercut: every cavity face leans at least the draft from the opening direction and faces
    # the piece that leaves that way (up: the core; down: the shell)
    cav = trimesh.Trimesh(*_mesh_of(cavity))
    nz = cav.face_normals[:, 2]
    good = cav.area_faces > 1e-9
    slope = np.degrees(np.arcsin(np.clip(np.abs(nz[good]), 0, 1))).min()
    if slope + 0.02 < mold["draft_deg"]:  # float32 STL vertices tilt small faces by up to ~0.01 deg
        fail("cavity walls must lean by the draft angle", f"steepest {slope:.3f} deg, draft {mold['draft_deg']} deg")
    # short probes, slivers where two surfaces meet closer still (a seat's flare meets the end plane)
    step = np.clip(0.2 * np.sqrt(cav.area_faces), 1e-5, 0.004)
    probes = cav.triangles_center + step[:, None] * cav.face_normals
    cand = np.zeros(len(probes), bool)
    for o in mold["openings"]:
        near = np.hypot(probes[:, 0] - o["xy"][0], probes[:, 1] - o["xy"][1]) < o["radius_mm"] + (zt - zp) + 0.05
        # a pocket vent is drilled from 0.3 mm below the pocket's top (tipforge's mold), so the faces
        # it opens lie up to that far below it
        # (the sprue's gate well opens the cover's edge down to the well's floor)
        below = o["gate_well"]["depth_mm"] if "gate_well" in o else 0.0
        cand |= near & (probes[:, 2] > (o["from_z_mm"] - 0.35 if "from_z_mm" in o else zp - below - 0.05))
    core_m = trimesh.Trimesh(*_mesh_of(core))
    shell_m = trimesh.Trimesh(*_mesh_of(shell))
    # where the sprue or a vent opens onto the cavity, a face looks into the opening's air
    if cand.any():
        idx = np.nonzero(cand)[0]
        air = ~(core_m.contains(probes[idx]) | shell_m.contains(probes[idx]))
        opening = np.zeros(len(probes), bool)
        opening[idx[air]] = True
    else:
        opening = cand
    # a wall parallel to the opening direction (draft 0) may belong to either piece; STL's float32
    # vertices tilt such faces by up to ~1e-4
    flat = np.abs(nz) < 2e-4 if mold["draft_deg"] == 0 else np.zeros(len(nz), bool)
    up = (nz > 0) & good & ~opening & ~flat
    # faces looking down open only into the sprue's gate well (the cover's edge beside the rim)
    down = (nz < 0) & good & ~(opening & in_gate_well(mold, probes)) & ~flat
    either = flat & good
    wrong = int((~core_m.contains(probes[up])).sum() + (~shell_m.contains(probes[down])).sum())
    if either.any():
        wrong += int((~(core_m.contains(probes[either]) | shell_m.contains(probes[either]))).sum())
    if wrong:
        fail("each cavity face must belong to the piece that leaves in its direction (no undercut)", f"{wrong} of {int(up.sum() + down.sum())} faces")
    print(f"{name}-assembly: {'ok' if not out else 'FAILED'} (cavity {cavity.volume():.2f} mm3 = cover x {k ** 3:.4f}; inner surface within {worst:.4f} mm; steepest wall {slope:.3f} deg)")
    return out


def mold_self_test(root):
    """Each mold rule must fail on the real mold of ROOT made wrong on purpose."""
    root = Path(root)
    man = json.loads((root / "manifest.json").read_text())
    results = {}
    for name, mold in sorted(man.get("molds", {}).items()):
        if mold.get("style") != "conforming":
            continue
        core, shell, cover, tip = mold_inputs(name, mold, man, root)
        tols = mold["chordal_tolerance_mm"] + man["parts"][mold["fingertip_part"]]["features"]["chordal_tolerance_mm"]
        fails = lambda *a: {r for _, r, _ in check_mold(name, mold, *a, tol_sum=tols)}
        fails_with = lambda mo, *a: {r for _, r, _ in check_mold(name, mo, *a, tol_sum=tols)}
        results[f"{name}: the real mold passes"] = not check_mold(name, mold, core, shell, cover, tip, tol_sum=tols)
        results[f"{name}: a shell raised 0.3 mm intersects"] = any("intersect" in r for r in fails(core, shell.translate([0, 0, 0.3]), cover, tip))
        lid = m3.Manifold.cube([200, 200, 1]).translate([-100, -100, mold["flange_top_z_mm"] - 0.5])
        results[f"{name}: a lid over the sprue and vents traps the cavity"] = any("reach the outside" in r for r in fails(core + lid, shell, cover, tip))
        inward = json.loads(json.dumps(mold))
        inward["openings"][0]["xy"][0] -= 1.0
        results[f"{name}: a sprue 1 mm further in, over the plug, fails the mouth rule"] = any("mouth" in r for r in fails_with(inward, core, shell, cover, tip))
        results[f"{name}: a cover 2 % too large fails the volume and fit rules"] = len(fails(core, shell, grow(cover, 1.02, mold["frames"]["cavity_scale_center"]), tip)) >= 2
        results[f"{name}: a cover lifted 0.2 mm off the fingertip fails the inner-surface rule"] = any("inner surface" in r for r in fails(core, shell, cover, tip.translate([0, 0, 0.2])))
        mirrored = shell.mirror([0, 0, 1]).translate([0, 0, 2 * mold["parting_z_mm"]])
        results[f"{name}: a shell flipped over fails"] = len(fails(core, mirrored, cover, tip)) >= 1
    for k_, v_ in results.items():
        print(f"{'ok  ' if v_ else 'FAIL'} {k_}")
    print(f"{sum(results.values())} passed, {len(results) - sum(results.values())} failed")
    return 0 if results and all(results.values()) else 1


# ---------------------------------------------------------------- driver
def load_3mf(path):
    if not path.exists():
        return None
    scene = trimesh.load(str(path), file_type="3mf")
    geoms = list(scene.geometry.values()) if hasattr(scene, "geometry") else [scene]
    return trimesh.util.concatenate(geoms) if len(geoms) > 1 else geoms[0]


def check_part(name, entry, root):
    files = entry.get("files", [])
    stl = [f for f in files if f.endswith(".stl")]
    tmf = [f for f in files if f.endswith(".3mf")]
    if not stl:
        return [(name, "an STL must be listed", str(files))]
    mesh = trimesh.load(str(root / stl[0]), process=True)
    other = load_3mf(root / tmf[0]) if tmf else None
    params = None
    src = entry.get("source")
    if src and Path(src).exists():
        params = tomllib.loads(Path(src).read_text())
        board = params.get("sensor_board")
        if isinstance(board, str) and (Path(src).parent / board).exists():
            params["_board"] = tomllib.loads((Path(src).parent / board).read_text())
    c = Ctx(name, entry, mesh, other, params, root)
    out = []
    for r in RULES:
        try:
            res = r(c)
        except Exception as e:  # a rule that crashes is a failed rule, with its reason
            res = (f"rule {r.__name__} could not run", repr(e))
        if res:
            out.append((name, res[0], res[1]))
    return out


def main(root):
    root = Path(root)
    man = json.loads((root / "manifest.json").read_text())
    parts = man.get("parts", {})
    if not parts:
        print("no parts in manifest")
        return 1
    failures = []
    for name, entry in sorted(parts.items()):
        f = check_part(name, entry, root)
        failures += f
        print(f"{name}: {'ok' if not f else 'FAILED'} ({len(RULES)} rules)")
    for path in sorted(root.glob("*.3mf")):
        failures += check_3mf_file(path)
    for name, rig in sorted(man.get("rigs", {}).items()):
        failures += check_rig(name, rig, man, root)
    for name, mold in sorted(man.get("molds", {}).items()):
        if mold.get("style") == "conforming":
            tols = mold["chordal_tolerance_mm"] + man["parts"][mold["fingertip_part"]]["features"]["chordal_tolerance_mm"]
            failures += check_mold(name, mold, *mold_inputs(name, mold, man, root), tol_sum=tols)
    for name, rule_text, value in failures:
        print(f"  {name}: {rule_text}: {value}")
    print(f"{len(parts) - len({f[0] for f in failures})} passed, {len({f[0] for f in failures})} failed")
    return 1 if failures else 0


# ---------------------------------------------------------------- self-test
def self_test():
    """Each rule must fail on a mesh built to break it, and pass on a clean box."""
    def ctx_for(mesh, entry=None, feats=None):
        e = {"genus": 0, "volume_mm3": float(mesh.volume), "triangles": len(mesh.faces), "features": feats or {"min_wall_mm": 1.2, "holes": []}}
        if entry:
            e.update(entry)
        return Ctx("t", e, mesh, None, None, Path("."))

    box = trimesh.creation.box([10, 10, 10])
    results = {}
    clean = ctx_for(box)
    bad_clean = [r.__name__ for r in RULES if r(clean)]
    results["clean box passes every rule"] = not bad_clean
    inv = box.copy()
    inv.invert()
    results["inside-out mesh fails is_volume_positive"] = bool(is_volume_positive(ctx_for(inv, {"volume_mm3": float(inv.volume)})))
    opened = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    results["open mesh fails watertight"] = bool(watertight(Ctx("t", {"features": {}}, opened, None, None, Path("."))))
    two = trimesh.util.concatenate([box, box.copy().apply_translation([3, 0, 0])])
    c2 = ctx_for(two)
    results["overlapping shells fail no_self_overlap"] = bool(no_self_overlap(c2))
    results["two bodies fail one_body"] = bool(one_body(c2))
    thin = trimesh.boolean.difference([box, trimesh.creation.box([10, 9.4, 9.4]).apply_translation([0, 0.0, 0.0])], engine="manifold") if False else None
    # a 10 mm cube hollowed to leave a 0.5 mm wall on one side
    shell = m3.Manifold.cube([10, 10, 10]) - m3.Manifold.cube([8, 8, 8]).translate([1.5, 1, 1])
    shell = trimesh.Trimesh(*_mesh_of(shell))
    results["0.5 mm wall fails min_wall (1.2 mm)"] = bool(min_wall(ctx_for(shell, {"genus": 0})))
    thick = m3.Manifold.cube([10, 10, 10]) - m3.Manifold.cube([6, 6, 6]).translate([2, 2, 2])
    results["2 mm walls pass min_wall (1.2 mm)"] = not min_wall(ctx_for(trimesh.Trimesh(*_mesh_of(thick))))
    holed = m3.Manifold.cube([10, 10, 4]) - m3.Manifold.cylinder(10, 1.2, 1.2, 64).translate([5, 5, -3])
    hm = trimesh.Trimesh(*_mesh_of(holed))
    feats = {"min_wall_mm": 1.2, "holes": [{"axis_point": [5, 5, 2], "axis_dir": [0, 0, 1], "diameter_mm": 2.4}]}
    results["a hole without its genus fails genus_matches"] = bool(genus_matches(ctx_for(hm, {"genus": 0}, feats)))
    feats_wrong = {"min_wall_mm": 1.2, "holes": [{"axis_point": [5, 5, 2], "axis_dir": [0, 0, 1], "diameter_mm": 3.0}]}
    results["a 2.4 mm hole fails a 3.0 mm nominal"] = bool(hole_diameters(ctx_for(hm, {"genus": 1}, feats_wrong)))
    results["a 2.4 mm hole passes a 2.4 mm nominal"] = not hole_diameters(ctx_for(hm, {"genus": 1}, feats))
    lifted = box.copy().apply_translation([0, 0, 2.0 - box.bounds[0][2]])
    results["a printed part 2 mm above the bed fails on_the_bed"] = bool(on_the_bed(ctx_for(lifted, {"process": "printed"})))
    results["a cast part off the bed passes on_the_bed"] = not on_the_bed(ctx_for(lifted, {"process": "cast"}))
    results.update(self_test_3mf(box))
    ok = all(results.values())
    for k, v in results.items():
        print(f"{'ok  ' if v else 'FAIL'} {k}")
    if bad_clean:
        print("rules failing on the clean box:", bad_clean)
    print(f"{sum(results.values())} passed, {len(results) - sum(results.values())} failed")
    return 0 if ok else 1


def self_test_3mf(box):
    """check_3mf_file on hand-written 3MFs: a clean one passes; a reference object placed on the
    build, or typed model, fails; a build item of type OTHER is refused by lib3mf itself."""
    import tempfile
    import zipfile
    verts = "".join(f'<vertex x="{v[0]}" y="{v[1]}" z="{v[2]}"/>' for v in box.vertices)
    tris = "".join(f'<triangle v1="{f[0]}" v2="{f[1]}" v3="{f[2]}"/>' for f in box.faces)
    def model(objs, items):
        body = "".join(f'<object id="{i}" name="{n}" type="{t}"><mesh><vertices>{verts}</vertices><triangles>{tris}</triangles></mesh></object>' for i, n, t in objs)
        build = "".join(f'<item objectid="{i}"/>' for i in items)
        return f'<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources>{body}</resources><build>{build}</build></model>'
    ct = '<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>'
    rels = '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>'
    cases = {
        "a 3MF with a part and an unplaced OTHER reference passes": (([(1, "part", "model"), (2, "sensor (reference)", "other")], [1]), False),
        "a reference object typed model fails the 3MF check": (([(1, "part", "model"), (2, "sensor (reference)", "model")], [1]), True),
        "a reference object placed on the build fails the 3MF check": (([(1, "part", "model"), (2, "sensor (reference)", "model")], [1, 2]), True),
        "a build item of type OTHER fails the 3MF check (lib3mf strict)": (([(1, "part", "other")], [1]), True),
    }
    results = {}
    with tempfile.TemporaryDirectory() as d:
        for k, ((objs, items), should_fail) in cases.items():
            path = Path(d) / "t.3mf"
            with zipfile.ZipFile(path, "w") as z:
                z.writestr("[Content_Types].xml", ct)
                z.writestr("_rels/.rels", rels)
                z.writestr("3D/3dmodel.model", model(objs, items))
            results[k] = bool(check_3mf_file(path)) == should_fail
    return results


def _mesh_of(mf):
    mm = mf.to_mesh()
    return np.asarray(mm.vert_properties)[:, :3], np.asarray(mm.tri_verts)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--self-test":
        sys.exit(self_test())
    if len(sys.argv) > 2 and sys.argv[1] == "--mold-self-test":
        sys.exit(mold_self_test(sys.argv[2]))
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "out"))
