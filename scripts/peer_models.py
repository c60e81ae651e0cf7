#!/usr/bin/env python3
"""The default one-sensor fingertip and the rig plunger written as equivalent models in CadQuery
(OCCT) and in Python manifold3d, for scripts/bench-peers.

Both peers build the same parts tipforge builds, from the same parameter files, at a matched chordal
tolerance: the fingertip's exact body (the side profile revolved, scaled to the pad and dorsal
heights), the flat seat's spot face and pocket, the tail channel whose floor follows the pad, the
socket, the cross hole and its two counterbores; the plunger's frustum, stem, plate and engraved
centring scale. Seat placement (a numerical search on the exact pad) is read from tipforge's
manifest, so all three cut the seat in the same place.

    peer_models.py TOOL PART OUT.stl [--manifest M]   build once and write an STL (whole-process timing)
"""
import math
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


# ---------------------------------------------------------------- shared geometry
class Body:
    """The fingertip's side profile r(x) (pad units) and scales, as in src/fingertip/shape.rs."""

    def __init__(self, b):
        self.L = b["length_mm"]
        self.pd = (b["width_mm"] / 2) ** 2 / b["pad_transverse_radius_mm"]
        self.dh = b["thickness_mm"] - self.pd
        self.lat = b["width_mm"] / 2 / self.pd
        self.rl, self.rt = b["pad_longitudinal_radius_mm"], b["tip_radius_mm"]
        self.c2 = (self.L - self.rt, 0.0)
        self.x1 = self.L - self.rt - math.sqrt(max((self.rl - self.rt) ** 2 - (self.rl - self.pd) ** 2, 0))
        self.c1 = (self.x1, self.pd - self.rl)
        d = (self.c2[0] - self.c1[0], self.c2[1] - self.c1[1])
        dn = math.hypot(*d)
        self.tp = (self.c1[0] + d[0] / dn * self.rl, self.c1[1] + d[1] / dn * self.rl)

    def r(self, x):
        if x < 0 or x > self.L:
            return 0.0
        if x <= self.x1:
            return self.pd
        if x <= self.tp[0]:
            return self.c1[1] + math.sqrt(max(self.rl ** 2 - (x - self.c1[0]) ** 2, 0))
        return math.sqrt(max(self.rt ** 2 - (x - self.c2[0]) ** 2, 0))

    def z_pad(self, x, y):
        r = self.r(x)
        q = 1 - (y / (self.lat * r)) ** 2
        return -r * math.sqrt(q) if r > 0 and q >= 0 else None

    def flank_y(self, x, z):
        r = self.r(x)
        zr = z * self.pd / self.dh if z >= 0 else z
        q = 1 - (zr / r) ** 2
        return self.lat * r * math.sqrt(q)

    def arc_mid(self, c, r, a, b):
        m = ((a[0] + b[0]) / 2 - c[0], (a[1] + b[1]) / 2 - c[1])
        mn = math.hypot(*m)
        return (c[0] + m[0] / mn * r, c[1] + m[1] / mn * r)

    def profile(self, tol):
        """Profile polygon (x, radius) from the axis at the mount face round to the tip, arcs
        divided so each chord stays within `tol`."""
        pts = [(0.0, 0.0), (0.0, self.pd), (self.x1, self.pd)]

        def arc(c, r, a, b):
            a0, a1 = math.atan2(a[1] - c[1], a[0] - c[0]), math.atan2(b[1] - c[1], b[0] - c[0])
            n = max(2, math.ceil(abs(a1 - a0) / (2 * math.acos(1 - min(tol / r, 1)))))
            return [(c[0] + r * math.cos(a0 + (a1 - a0) * k / n), c[1] + r * math.sin(a0 + (a1 - a0) * k / n)) for k in range(1, n + 1)]

        pts += arc(self.c1, self.rl, (self.x1, self.pd), self.tp)
        pts += arc(self.c2, self.rt, self.tp, (self.L, 0.0))
        return pts


def to_design(p):
    """tipforge's fingertip print frame (y, z, x) back to the design frame."""
    return [p[2], p[0], p[1]]


def load_fingertip(manifest):
    params = tomllib.loads((ROOT / "params/fingertip-1s.toml").read_text())
    feats = manifest["parts"]["fingertip-1s"]["features"]
    return params, feats


def channel_pieces(body, s, tol):
    """Hull point sets of the tail channel, as tipforge cuts it: pieces whose floor (the pad raised
    by the channel depth) stays within tol/2 of the chord, walls flared at 45°."""
    xs, ys, yc = body.L - s["position_from_tip_mm"], s.get("lateral_offset_mm", 0.0), s.get("channel_offset_mm", s.get("lateral_offset_mm", 0.0))
    path = [(xs, ys)]
    if abs(yc - ys) > 1e-9:
        path.append((xs - abs(yc - ys), yc))
    path.append((-1.0, yc))
    pts = []
    for a, b in zip(path[:-1], path[1:]):
        ln = math.hypot(b[0] - a[0], b[1] - a[1])
        t = ((b[0] - a[0]) / ln, (b[1] - a[1]) / ln)
        n = max(1, math.ceil(ln / 0.25))
        pts += [((a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n), t) for k in range(n + 1)]
    # the tail channel is the sensor board's tail + 2 x the clearance (params/fsr-8mm.toml)
    board = tomllib.loads((ROOT / "params" / params_sensor_board()).read_text())
    w, d = board["tail_width_mm"] + 2 * s.get("channel_clearance_mm", 0.1), s["channel_depth_mm"]
    zb = -body.pd - 2.0

    def edge(q, t, side):
        ex, ey = q[0] - t[1] * side * w / 2, q[1] + t[0] * side * w / 2
        return (ex, ey, body.z_pad(max(ex, 1e-9), ey) + d)

    pieces, start = [], 0
    while start + 1 < len(pts):
        end = start + 1
        while end + 1 < len(pts) and pts[end + 1][1] == pts[start][1]:
            cand, fits = end + 1, True
            for side in (-1.0, 1.0):
                a, b = edge(*pts[start], side), edge(*pts[cand], side)
                for mid in range(start + 1, cand):
                    m = edge(*pts[mid], side)
                    f = (mid - start) / (cand - start)
                    if abs(a[2] + (b[2] - a[2]) * f - m[2]) > tol / 2:
                        fits = False
            if not fits:
                break
            end = cand
        a, b = pts[start], pts[end]
        start = end
        if abs(a[0][0] - b[0][0]) + abs(a[0][1] - b[0][1]) < 1e-9:
            continue
        hull = []
        for q, t in (a, b):
            for side in (-1.0, 1.0):
                fp = edge(q, t, side)
                fl = fp[2] - zb
                hull += [fp, (fp[0] - t[1] * side * fl, fp[1] + t[0] * side * fl, zb)]
        pieces.append(hull)
    return pieces


def fingertip_spec(manifest, tol):
    params, feats = load_fingertip(manifest)
    body = Body(params["body"])
    s = params["sensor"][0]
    seat = feats["seats"][0]
    m = params["mount"]
    spec = {"body": body, "cones": [], "cyls": [], "boxes": [], "hulls": channel_pieces(body, s, tol)}
    n = np.asarray(to_design(seat["normal"]))
    rf, rs = seat["flat_diameter_mm"] / 2, seat["seat_diameter_mm"] / 2
    flare = seat["flat_depth_mm"] + 2.0
    spec["cones"].append((to_design(seat["flat_center"]), n, flare, rf, rf + flare))
    far = params["body"]["thickness_mm"] + 4.0
    spec["cones"].append((to_design(seat["floor_center"]), n, seat["seat_depth_mm"] + seat["flat_depth_mm"] + far, rs, rs))
    sw, sh, sd, sz = m["socket_width_mm"], m["socket_height_mm"], m["socket_depth_mm"], m["socket_center_z_mm"]
    spec["boxes"].append(((-1.0, -sw / 2, sz - sh / 2), (sd, sw / 2, sz + sh / 2)))
    farh = params["body"]["width_mm"] / 2 + 2.0
    hole, head_d, head_depth = screw_recess(m)
    r, rh = hole / 2, head_d / 2
    for x, z in m["holes"]:
        spec["cones"].append(((x, -farh, z), np.array([0, 1.0, 0]), 2 * farh, r, r))
        fy = body.flank_y(x, z) - head_depth
        for sg in (-1.0, 1.0):
            spec["cones"].append(((x, sg * fy, z), np.array([0, sg, 0]), farh - fy, rh, rh))
    spec["genus"] = 2 * len(m["holes"])
    return spec


# the pan head screws the default fingertips name (ISO 7045 max head sizes, ISO 273 medium hole);
# the peers model only these, as tipforge's src/params/screws.rs does for every size
PAN_HEADS = {"ISO 7045 M2": (2.4, 4.0, 1.6), "ISO 7045 M2.5": (2.9, 5.0, 2.1), "ISO 7045 M3": (3.4, 5.6, 2.4)}


def screw_recess(m):
    """(hole, counterbore diameter, counterbore depth) of a [mount] table, by hand or from its screw."""
    if "screw" not in m:
        return m["hole_diameter_mm"], m["head_diameter_mm"], m["head_depth_mm"]
    hole, dk, k = PAN_HEADS[m["screw"]]
    return hole, dk + 2 * m.get("head_clearance_mm", 0.3), k + m.get("head_sink_mm", 0.2)


def params_sensor_board():
    return tomllib.loads((ROOT / "params/fingertip-1s.toml").read_text()).get("sensor_board", "fsr-8mm.toml")


def plunger_spec():
    rig = tomllib.loads((ROOT / "params/rig.toml").read_text())
    q = rig["plunger"]
    rf, rt, rs, rp = q["face_diameter_mm"] / 2, q["frustum_top_diameter_mm"] / 2, q["stem_diameter_mm"] / 2, q["plate_diameter_mm"] / 2
    pt, sl, fh = q["plate_thickness_mm"], q["stem_length_mm"], q["frustum_height_mm"]
    up = np.array([0, 0, 1.0])
    # print pose: plate face down on the bed, the engraved scale in that face
    solids = [((0, 0, 0), up, pt, rp, rp), ((0, 0, pt - 0.01), up, sl + 0.02, rs, rs), ((0, 0, pt + sl), up, fh, rt, rf)]
    depth, pitch, lw = q["scale_depth_mm"], q["scale_pitch_mm"], q["scale_line_width_mm"]
    rings, k = [], 1
    while k * pitch + lw / 2 < rp - 2:
        rings.append((k * pitch - lw / 2, k * pitch + lw / 2))
        k += 1
    arm = rp - 2
    lines = [((-arm, -lw / 2, -1.0), (arm, lw / 2, depth)), ((-lw / 2, -arm, -1.0), (lw / 2, arm, depth))]
    return {"solids": solids, "rings": rings, "ring_z": (-1.0, depth), "lines": lines, "genus": 0, "tol": rig["print"]["chordal_tolerance_mm"]}


def segments(r, tol):
    t = min(tol / r, 1.0)
    n = math.ceil(math.pi / math.acos(1 - t))
    return max(12, -(-n // 4) * 4)


def frame(w):
    w = np.asarray(w, float) / np.linalg.norm(w)
    h = np.array([1.0, 0, 0]) if abs(w[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(h, w)
    u /= np.linalg.norm(u)
    return u, np.cross(w, u), w


# ---------------------------------------------------------------- CadQuery (OCCT, exact B-rep)
def cq_fingertip(spec):
    import cadquery as cq
    from OCP.BRepBuilderAPI import BRepBuilderAPI_GTransform
    from OCP.gp import gp_GTrsf, gp_Mat

    b = spec["body"]
    m1 = b.arc_mid(b.c1, b.rl, (b.x1, b.pd), b.tp)
    m2 = b.arc_mid(b.c2, b.rt, b.tp, (b.L, 0.0))
    prof = cq.Workplane("XY").moveTo(0, 0).lineTo(0, b.pd).lineTo(b.x1, b.pd).threePointArc(m1, b.tp).threePointArc(m2, (b.L, 0)).close()
    rev = prof.revolve(360, (0, 0, 0), (1, 0, 0)).val()

    def scaled(zs):
        g = gp_GTrsf()
        g.SetVectorialPart(gp_Mat(1, 0, 0, 0, b.lat, 0, 0, 0, zs))
        return cq.Shape.cast(BRepBuilderAPI_GTransform(rev.wrapped, g, True).Shape())

    big = 100.0
    dorsal = scaled(b.dh / b.pd).intersect(cq.Solid.makeBox(2 * big, 2 * big, big, cq.Vector(-big, -big, 0)))
    pad = scaled(1.0).intersect(cq.Solid.makeBox(2 * big, 2 * big, big, cq.Vector(-big, -big, -big)))
    body = dorsal.fuse(pad).clean()
    cutters = []
    for base, d, h, r0, r1 in spec["cones"]:
        if abs(r0 - r1) < 1e-12:
            cutters.append(cq.Solid.makeCylinder(r0, h, cq.Vector(*base), cq.Vector(*d)))
        else:
            cutters.append(cq.Solid.makeCone(r0, r1, h, cq.Vector(*base), cq.Vector(*d)))
    for lo, hi in spec["boxes"]:
        cutters.append(cq.Solid.makeBox(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], cq.Vector(*lo)))
    for hull in spec["hulls"]:
        # a piece is the ruled solid between its two end quads (floor edges and flared feet)
        q0 = [cq.Vector(*p) for p in (hull[0], hull[2], hull[3], hull[1])]
        q1 = [cq.Vector(*p) for p in (hull[4], hull[6], hull[7], hull[5])]
        cutters.append(cq.Solid.makeLoft([cq.Wire.makePolygon(q0, close=True), cq.Wire.makePolygon(q1, close=True)], True))
    cut = cutters[0].fuse(*cutters[1:]).clean()
    return body.cut(cut).clean()


def cq_plunger(spec):
    import cadquery as cq

    def solid(base, d, h, r0, r1):
        if abs(r0 - r1) < 1e-12:
            return cq.Solid.makeCylinder(r0, h, cq.Vector(*base), cq.Vector(*d))
        return cq.Solid.makeCone(r0, r1, h, cq.Vector(*base), cq.Vector(*d))

    parts = [solid(*s) for s in spec["solids"]]
    body = parts[0].fuse(*parts[1:]).clean()
    z0, z1 = spec["ring_z"]
    cuts = []
    for ri, ro in spec["rings"]:
        cuts.append(cq.Solid.makeCylinder(ro, z1 - z0, cq.Vector(0, 0, z0)).cut(cq.Solid.makeCylinder(ri, z1 - z0 + 1, cq.Vector(0, 0, z0 - 0.5))))
    for lo, hi in spec["lines"]:
        cuts.append(cq.Solid.makeBox(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], cq.Vector(*lo)))
    return body.cut(cuts[0].fuse(*cuts[1:]).clean()).clean()


def cq_mesh(shape, tol, r_max):
    """OCCT's tessellation at linear deflection `tol`. OCCT also bounds the angle between adjacent
    facets, and with a loose angle its linear deflection is not held on large radii (a 30 mm
    cylinder at 0.01 mm and 0.5 rad lost 0.8 % of the plunger's volume), so the angle is set to the
    one that gives a chord sag of `tol` on the part's largest curvature radius."""
    v, t = shape.tessellate(tol, 2 * math.acos(1 - tol / r_max))
    return np.array([[p.x, p.y, p.z] for p in v]), np.array(t, dtype=np.int64)


# ---------------------------------------------------------------- Python manifold3d
def m3_fingertip(spec, tol):
    import manifold3d as m3

    b = spec["body"]
    prof = b.profile(tol)
    # revolve: the cross-section's x is the radius, y the axis; Manifold.revolve turns it about z
    cs = m3.CrossSection([[(r, x) for x, r in prof]])
    n = segments(max(b.lat * b.pd, b.dh), tol)
    rev = m3.Manifold.revolve(cs, n)
    k = b.pd / b.dh

    def warp(p):
        # revolved (u, v, z=axis) → design (x = axis, y = lateral · u, z = v scaled to the dorsal height, pad contracted)
        x, y, z = p[:, 2], p[:, 0] * b.lat, p[:, 1] * (b.dh / b.pd)
        z = np.where(z < 0, z * k, z)
        return np.column_stack([x, y, z])

    body = rev.warp_batch(warp)
    cutters = []
    for base, d, h, r0, r1 in spec["cones"]:
        u, v, w = frame(d)
        nseg = segments(max(r0, r1), tol)
        kk = math.sqrt(2 * math.pi / (nseg * math.sin(2 * math.pi / nseg)))  # area-matched polygon
        c = m3.Manifold.cylinder(h, r0 * kk, r1 * kk, nseg)
        cutters.append(c.transform(np.column_stack([u, v, w, np.asarray(base, float)])))
    for lo, hi in spec["boxes"]:
        cutters.append(m3.Manifold.cube(list(np.subtract(hi, lo))).translate(list(lo)))
    for hull in spec["hulls"]:
        cutters.append(m3.Manifold.hull_points([list(p) for p in hull]))
    return body - m3.Manifold.batch_boolean(cutters, m3.OpType.Add)


def m3_plunger(spec, tol):
    import manifold3d as m3

    def solid(base, d, h, r0, r1):
        nseg = segments(max(r0, r1), tol)
        kk = math.sqrt(2 * math.pi / (nseg * math.sin(2 * math.pi / nseg)))
        return m3.Manifold.cylinder(h, r0 * kk, r1 * kk, nseg).translate(list(base))

    body = m3.Manifold.batch_boolean([solid(*s) for s in spec["solids"]], m3.OpType.Add)
    z0, z1 = spec["ring_z"]
    cuts = []
    for ri, ro in spec["rings"]:
        cuts.append(solid((0, 0, z0), None, z1 - z0, ro, ro) - solid((0, 0, z0 - 0.5), None, z1 - z0 + 1, ri, ri))
    for lo, hi in spec["lines"]:
        cuts.append(m3.Manifold.cube(list(np.subtract(hi, lo))).translate(list(lo)))
    return body - m3.Manifold.batch_boolean(cuts, m3.OpType.Add)


def m3_mesh(mf):
    mm = mf.to_mesh()
    return np.asarray(mm.vert_properties)[:, :3].astype(float), np.asarray(mm.tri_verts).astype(np.int64)


def build(tool, part, manifest, tol=None):
    """(vertices, triangles, exact_shape_or_None) of one part by one peer."""
    if part == "fingertip":
        tol = tol or 0.01
        spec = fingertip_spec(manifest, tol)
        if tool == "cadquery":
            s = cq_fingertip(spec)
            b = spec["body"]
            return (*cq_mesh(s, tol, max(b.rl, b.lat * b.pd, b.dh)), s)
        return (*m3_mesh(m3_fingertip(spec, tol)), None)
    spec = plunger_spec()
    tol = tol or spec["tol"]
    if tool == "cadquery":
        s = cq_plunger(spec)
        return (*cq_mesh(s, tol, max(r for *_, r0, r1 in spec["solids"] for r in (r0, r1))), s)
    return (*m3_mesh(m3_plunger(spec, tol)), None)


if __name__ == "__main__":
    import json

    import trimesh

    tool, part, out = sys.argv[1], sys.argv[2], sys.argv[3]
    man = json.loads(Path(sys.argv[5] if len(sys.argv) > 5 else ROOT / "out/manifest.json").read_text())
    v, t, _ = build(tool, part, man)
    trimesh.Trimesh(v, t, process=False).export(out)
