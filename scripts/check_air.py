#!/usr/bin/env python3
"""Trapped-air check of tipforge's conforming molds (issue 18, item 3: "Molds that cast clean").

Reads OUT/manifest.json, reassembles every conforming mold's core and shell from the written STL
files in the pour orientation, voxelises the space the PDMS can reach (the cavity and the sprue and
vent channels that join it to the open air above the mold) and finds the air the rising liquid
traps: a voxel traps air when every path from it to the open air must go below the voxel's own
height (air only rises). Prints one line per mold, writes OUT/air.json, exits 1 when any mold traps
more than the tolerance.

    check_air.py [OUT]                       check a build output folder (default: out)
    check_air.py OUT --voxel 0.0125 --dz 0.005   finer voxels (default 0.025 x 0.025 x 0.01 mm)
    check_air.py OUT --tilt-deg 10           pour with the tip end raised by 10 degrees
    check_air.py --self-test [OUT]           prove the check on synthetic molds made to trap air or
                                             not; with OUT, also that its real molds pass once a
                                             vent is drilled up from each pocket's apex

Pour orientation. The mold is poured as it is assembled: the core (flange with the sprue and vents)
on top, the shell below, the pad facing down. The manifest says so through the openings: every
`openings[i]` is a vertical channel (only `xy` is given) that runs from the cavity's rim at
`parting_z_mm` up through the core's flange to its top face at `flange_top_z_mm`; air leaves there,
so "up" is the assembled frame's +z when flange_top_z_mm > parting_z_mm (-z otherwise). A field
`pour_up` (unit vector, assembled frame) is used instead when the manifest has one.

Algorithm. Space: the pieces' bounding box less core ∪ shell (manifold3d), plus the atmosphere
outside the box. Voxels: h x h cells in plan, layers dz tall, each layer rasterised at its cells'
centres from manifold3d's exact slice of core ∪ shell at the layer's mid-height (even-odd scanline
fill of the slice's polygons). Layers are processed from the top down; each layer's air is labelled in 2-D (face
connectivity) and joined by union-find to the air directly above it, so after layer j the
union-find holds the connected components of {air with z >= z_j}. A component is open when it
holds atmosphere. A voxel of layer j traps air exactly when, after layer j, its component is not
open: then every path to the atmosphere dips below it (the max-over-paths of the min height along
the path, the "bottleneck" height, is below the voxel). The layer at which its component later
joins an open one is the pocket's spill level (the liquid seals the bubble when it reaches it);
components that never join one (the key holes' clearance gaps, sealed by the pieces) are not part
of the cavity and are left out. Pockets are the face-connected components of trapped voxels; each
is reported with its volume, its depth (apex less spill level) and its apex (the top of its highest
layer, at that layer's voxel nearest the layer's centroid), in the pour frame, the assembled frame
and (shrinkage allowance undone) the fingertip's print frame, which the cast cover sits on.
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

import manifold3d as m3
import numpy as np
import trimesh
from scipy import ndimage

# Voxels 0.025 mm across and 0.01 mm tall: a 0.3 mm deep pocket spans 30 layers. Where a pocket
# spills is a wedge of the core thinning to nothing (the seat's flat meeting the pad), which cell
# centres miss until it is a cell wide, so coarser cells spill early and under-read: the 1s pocket
# reads 1.87 / 2.00 / 2.13 / 2.19 mm3 at 0.1 / 0.05 / 0.025 / 0.0125 mm cells (0.01 mm layers).
# 0.025 mm takes about 10 s a mold on one core. The self-test's synthetic molds use 0.05 mm.
DEFAULT_VOXEL_MM = 0.025
DEFAULT_DZ_MM = 0.01
SELF_TEST_VOXEL_MM = 0.05
# Tolerance on a mold's trapped volume: 0.01 mm3, a bubble 0.27 mm across, under the printer's
# finest detail (min_detail_mm = 0.4) and 100-200 times under the crescents. It is 1600
# voxels of the default size: resolution noise cannot reach it. A spurious pocket needs a local high
# point of the voxelised ceiling; the tessellated pad (convex) has none, and a ripple of the mesh's
# chordal error (0.02 mm, 2 layers) over a facet holds ~1e-3 mm3. The real molds vented at their
# apexes read 0 (see the self-test with OUT). Voxels coarser than 0.17 mm raise the limit to 2 voxels
# so one misplaced voxel never fails a mold.
TOLERANCE_MM3 = 0.01
SEAM = math.pi * 1e-4  # offsets the voxel grid off round-numbered planes (the parting plane, flats)


# ---------------------------------------------------------------- geometry helpers
def to_manifold(mesh):
    return m3.Manifold(m3.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32), tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def affine4(rows):
    a = np.eye(4)
    a[:3, :] = np.asarray(rows, float)
    return a


def apply(a4, p):
    return (a4[:3, :3] @ np.asarray(p, float)) + a4[:3, 3]


def rot_y(deg):
    """Rotation about y lifting +x by `deg` (z' = x sin + z cos)."""
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])


def rot_to_z(up):
    """Rotation taking unit `up` to +z (identity when it is +z)."""
    w = np.asarray(up, float)
    w = w / np.linalg.norm(w)
    if np.allclose(w, [0, 0, 1]):
        return np.eye(3)
    if np.allclose(w, [0, 0, -1]):
        return np.diag([1.0, -1.0, -1.0])
    helper = np.array([1.0, 0, 0]) if abs(w[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(helper, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    return np.vstack([u, v, w])


def transform(mf, r):
    return mf.transform(np.hstack([r, np.zeros((3, 1))]))


def raster(polys, x0, y0, h, nx, ny):
    """Even-odd fill of polygons on the cells (i, j) with centres (x0 + (i+.5)h, y0 + (j+.5)h).
    Returns a bool array (ny, nx)."""
    if not polys:
        return np.zeros((ny, nx), bool)
    a = np.concatenate([np.asarray(p, float) for p in polys])
    b = np.concatenate([np.roll(np.asarray(p, float), -1, axis=0) for p in polys])
    ylo, yhi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    # rows whose centre y_j satisfies ylo <= y_j < yhi (half-open: a vertex is crossed once)
    j0 = np.ceil((ylo - y0) / h - 0.5).astype(np.int64)
    j1 = np.ceil((yhi - y0) / h - 0.5).astype(np.int64)
    j0, j1 = np.clip(j0, 0, ny), np.clip(j1, 0, ny)
    n = j1 - j0
    keep = n > 0
    a, b, j0, n = a[keep], b[keep], j0[keep], n[keep]
    if not len(n):
        return np.zeros((ny, nx), bool)
    e = np.repeat(np.arange(len(n)), n)
    j = j0[e] + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
    yc = y0 + (j + 0.5) * h
    t = (yc - a[e, 1]) / (b[e, 1] - a[e, 1])
    x = a[e, 0] + t * (b[e, 0] - a[e, 0])
    # the crossing toggles inside/outside from the first cell whose centre lies at or beyond it
    i = np.clip(np.ceil((x - x0) / h - 0.5).astype(np.int64), 0, nx)
    tog = np.zeros((ny, nx + 1), np.int32)
    np.add.at(tog, (j, i), 1)
    return (np.cumsum(tog, axis=1)[:, :nx] & 1).astype(bool)


# ---------------------------------------------------------------- the trapped-air computation
class UF:
    def __init__(self):
        self.parent, self.size, self.open, self.joined = [], [], [], []

    def add(self, n, open_flags):
        base = len(self.parent)
        self.parent += range(base, base + n)
        self.size += [1] * n
        self.open += list(open_flags)
        self.joined += [None] * n
        return base

    def find(self, a):
        # no path compression: `spill` walks the chains as they were built
        while self.parent[a] != a:
            a = self.parent[a]
        return a

    def union(self, a, b, layer):
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return
        oa, ob = self.open[ra], self.open[rb]
        if oa != ob:  # a closed tree reaches the open air at this layer
            self.joined[rb if oa else ra] = layer
        if self.size[ra] < self.size[rb]:
            ra, rb = rb, ra
        self.parent[rb] = ra
        self.size[ra] += self.size[rb]
        self.open[ra] = oa or ob

    def spill(self, a):
        """The layer at which component `a` first joined an open one (None: never)."""
        while True:
            if self.joined[a] is not None:
                return self.joined[a]
            if self.parent[a] == a:
                return None
            a = self.parent[a]


def trapped_air(pieces, box_lo, box_hi, region_lo, region_hi, h, dz, rot=np.eye(3), keep_grid=False):
    """Air trapped by a liquid rising in the space `box` less `pieces` (manifolds in the mold's
    frame; `rot` turns that frame into the pour frame, whose +z is up). `region_*`: a box of the
    mold's frame holding the space the liquid reaches. Voxels h x h x dz (dz vertical). Returns a
    dict (pour frame coordinates); with `keep_grid` also the air and trapped voxels (nz, ny, nx)."""
    t0 = time.time()
    pm = transform(pieces, rot)
    corners = np.array([[x, y, z] for x in (region_lo[0], region_hi[0]) for y in (region_lo[1], region_hi[1]) for z in (region_lo[2], region_hi[2])]) @ rot.T
    lo, hi = corners.min(axis=0) - 2 * max(h, dz), corners.max(axis=0) + 2 * max(h, dz)
    x0, y0 = lo[0] - SEAM, lo[1] - SEAM
    z_top = hi[2] + SEAM
    nx, ny, nz = (int(math.ceil((hi[0] - x0) / h)), int(math.ceil((hi[1] - y0) / h)), int(math.ceil((z_top - lo[2]) / dz)))
    xs = x0 + (np.arange(nx) + 0.5) * h
    ys = y0 + (np.arange(ny) + 0.5) * h
    gx, gy = np.meshgrid(xs, ys)  # (ny, nx)
    blo, bhi = np.asarray(box_lo, float), np.asarray(box_hi, float)
    # which cells lie inside the mold's box (the rest is atmosphere), back in the mold's frame
    rt = rot.T
    plan = rt[:, :2] @ np.vstack([gx.ravel(), gy.ravel()])
    if np.allclose(rt[:2, 2], 0) and np.allclose(rt[2, :2], 0):  # the pour keeps the box's top level
        in_plan = np.all((plan[:2] >= blo[:2, None]) & (plan[:2] <= bhi[:2, None]), axis=0).reshape(ny, nx)
        inbox_at = lambda zc: in_plan if blo[2] <= rt[2, 2] * zc <= bhi[2] else np.zeros((ny, nx), bool)
    else:
        inbox_at = lambda zc: np.all(((q := plan + zc * rt[:, 2:3]) >= blo[:, None]) & (q <= bhi[:, None]), axis=0).reshape(ny, nx)
    uf = UF()
    prev = None
    grid_air, grid_inbox = [], []
    trapped = []  # (layer, row idx, col idx, global comp id) of voxels closed at their insertion
    liquid_count = {}  # comp id -> voxels inside the mold's box
    for k in range(nz):
        zc = z_top - (k + 0.5) * dz
        inbox = inbox_at(zc)
        solid = raster(pm.slice(zc).to_polygons(), x0, y0, h, nx, ny)
        air = ~solid | ~inbox
        if keep_grid:
            grid_air.append(air)
            grid_inbox.append(inbox)
        lab, n = ndimage.label(air)  # faces: in-plane 4-connectivity
        flat = lab.ravel()
        cnt = np.bincount(flat, weights=inbox.ravel(), minlength=n + 1)
        atm = np.bincount(flat, minlength=n + 1) > cnt  # holds cells outside the box
        base = uf.add(n, atm[1:])
        for c in np.nonzero(cnt[1:])[0]:
            liquid_count[base + int(c)] = int(cnt[c + 1])
        # join the air of this layer to the air straight above it
        if prev is not None:
            both = (flat > 0) & (prev >= 0)
            if both.any():
                pairs = np.unique((flat[both].astype(np.int64) + base - 1) * (1 << 32) + prev[both])
                for p in pairs.tolist():
                    uf.union(p >> 32, p & 0xFFFFFFFF, k)
        closed = np.array([False] + [not uf.open[uf.find(base + c)] for c in range(n)], bool)
        if closed.any():
            jj, ii = np.nonzero(closed[lab])
            trapped.append((np.full(len(jj), k), jj, ii, lab[jj, ii].astype(np.int64) + base - 1))
        prev = np.where(flat > 0, flat.astype(np.int64) + base - 1, -1)
    # components never reaching the open air are sealed gaps between the pieces, not the cavity
    liquid_vox = sum(v for c, v in liquid_count.items() if uf.open[uf.find(c)])
    if trapped:
        K, J, I, C = (np.concatenate(a) for a in zip(*trapped))
        comps = np.unique(C)
        spill = {int(c): uf.spill(int(c)) for c in comps}
        keep = np.array([spill[int(c)] is not None for c in C], bool)
        K, J, I, C = K[keep], J[keep], I[keep], C[keep]
    else:
        K = J = I = C = np.zeros(0, np.int64)
        spill = {}
    pockets = []
    if len(K):
        lo3 = np.array([K.min(), J.min(), I.min()])
        sub = np.zeros((K.max() - lo3[0] + 1, J.max() - lo3[1] + 1, I.max() - lo3[2] + 1), bool)
        sub[K - lo3[0], J - lo3[1], I - lo3[2]] = True
        plab, npk = ndimage.label(sub)
        pid = plab[K - lo3[0], J - lo3[1], I - lo3[2]]
        for p in range(1, npk + 1):
            sel = pid == p
            k_apex = K[sel].min()
            top = np.nonzero(sel & (K == k_apex))[0]
            # the apex: the voxel of the highest layer nearest that layer's centroid (a real voxel
            # of the pocket even where the layer's voxels form an arc)
            cx, cy = xs[I[top]].mean(), ys[J[top]].mean()
            top = top[np.argmin((xs[I[top]] - cx) ** 2 + (ys[J[top]] - cy) ** 2)]
            # the spill level of the bubble: the lowest at which any of its voxels reaches open air
            lvl = max(spill[int(c)] for c in np.unique(C[sel]))
            apex = [float(xs[I[top]]), float(ys[J[top]]), float(z_top - k_apex * dz)]
            pockets.append({
                "volume_mm3": float(sel.sum() * h * h * dz),
                "voxels": int(sel.sum()),
                "depth_mm": float((lvl - k_apex) * dz),
                "apex_pour": apex,
                "spill_z_pour": float(z_top - lvl * dz),
            })
    pockets.sort(key=lambda p: -p["volume_mm3"])
    return {
        "voxel_mm": [h, h, dz],
        "grid": [nx, ny, nz],
        "liquid_volume_voxels_mm3": liquid_vox * h * h * dz,
        "trapped_mm3": float(len(K) * h * h * dz),
        "pockets": pockets,
        "seconds": time.time() - t0,
        **({"air": np.stack(grid_air), "atmosphere": ~np.stack(grid_inbox), "trapped": trapped_grid(K, J, I, (nz, ny, nx))} if keep_grid else {}),
    }


def trapped_grid(K, J, I, shape):
    g = np.zeros(shape, bool)
    g[K, J, I] = True
    return g


def trapped_by_levels(air, atmosphere):
    """The same question answered another way, for the self-test: for every layer j (top down),
    label the air of layers 0..j in 3-D; a voxel of layer j traps air when its component holds no
    atmosphere. Components that never hold any (sealed gaps) are left out."""
    out = np.zeros(air.shape, bool)
    final, _ = ndimage.label(air)
    live = np.zeros(final.max() + 1, bool)
    live[np.unique(final[atmosphere & air])] = True
    live[0] = False
    for j in range(air.shape[0]):
        lab, n = ndimage.label(air[: j + 1])
        has = np.zeros(n + 1, bool)
        has[np.unique(lab[atmosphere[: j + 1] & air[: j + 1]])] = True
        has[0] = True
        out[j] = ~has[lab[j]] & live[final[j]]
    return out


SEAL_MM = 0.005


def tolerance(h, dz):
    return max(TOLERANCE_MM3, 2 * h * h * dz)


# ---------------------------------------------------------------- the molds of a build
def pour_up(mold):
    if "pour_up" in mold:
        return np.asarray(mold["pour_up"], float), "manifest pour_up"
    zp, zt = mold["parting_z_mm"], mold["flange_top_z_mm"]
    return np.array([0.0, 0.0, 1.0 if zt > zp else -1.0]), "openings run from parting_z_mm up to flange_top_z_mm (assembled z)"


def load_pieces(mold, root):
    """Core ∪ shell in the assembled frame, from the written STL files."""
    fr = mold["frames"]
    load = lambda part, rows: to_manifold(trimesh.load(str(root / f"{part}.stl"), process=True)).transform(np.asarray(rows, float))
    core, shell = load(mold["pieces"][0], fr["core_print_to_assembled"]), load(mold["pieces"][1], fr["shell_print_to_assembled"])
    # where the pieces touch (the parting plane), float32 STL vertices leave films a fraction of a
    # micrometre thick that can join the key holes to the cavity: seal every place where they lie
    # within SEAL_MM of each other along the opening direction (the smallest designed gap is 0.2 mm);
    # the core lies on the `up` side of the parting plane, the shell below it
    up, _ = pour_up(mold)
    shift = lambda m, d: m.translate(list(up * d))
    return core + shell + (shift(core, -SEAL_MM) ^ shift(shell, SEAL_MM))


def drill(pieces, mold, points, r=0.4):
    """The pieces with a vent of radius r drilled from 0.2 mm below each point (assembled frame) up
    through the top face."""
    up, _ = pour_up(mold)
    turn = np.hstack([rot_to_z(up).T, np.zeros((3, 1))])
    for p in points:
        v = m3.Manifold.cylinder(60.0, r, r, 24).translate([0, 0, -0.2]).transform(turn).translate(list(p))
        pieces = pieces - v
    return pieces


def check_mold(name, mold, root, h, dz, tilt_deg, pieces=None):
    fr = mold["frames"]
    if pieces is None:
        pieces = load_pieces(mold, root)
    b = pieces.bounding_box()
    lo, hi = np.array(b[:3]), np.array(b[3:])
    up, why = pour_up(mold)
    rot = rot_y(tilt_deg) @ rot_to_z(up)
    # the space the liquid reaches: the air inside the box that comes to the box's top face (within
    # 0.05 mm; the films where the pieces touch are sealed by load_pieces)
    box = m3.Manifold.cube(list(hi - lo)).translate(list(lo))
    top_face = hi if up[2] > 0 else lo
    band = m3.Manifold.cube([hi[0] - lo[0], hi[1] - lo[1], 0.05]).translate([lo[0], lo[1], (top_face[2] - 0.05) if up[2] > 0 else lo[2]])
    space = [r for r in (box - pieces).decompose() if r.volume() > 1e-3 and (r ^ band).volume() > 1e-5]
    if not space:
        raise SystemExit(f"{name}: no air space inside the mold reaches its top face")
    liquid = m3.Manifold.batch_boolean(space, m3.OpType.Add)
    bb = liquid.bounding_box()
    res = trapped_air(pieces, lo, hi, bb[:3], bb[3:], h, dz, rot)
    res["liquid_volume_exact_mm3"] = liquid.volume()
    res["pour_up_assembled"] = up.tolist()
    res["pour_up_from"] = why
    res["tilt_deg"] = tilt_deg
    # back from the pour frame: to the assembled frame, then (undoing the shrinkage allowance) to
    # the cast cover, which sits on the fingertip's print frame
    k, c = fr["cavity_scale"], np.asarray(fr["cavity_scale_center"], float)
    tip_inv = np.linalg.inv(affine4(fr["fingertip_print_to_assembled"]))
    domes = mold.get("domes_assembled", [])
    for p in res["pockets"]:
        a = rot.T @ np.asarray(p["apex_pour"])
        p["apex_assembled"] = a.tolist()
        p["apex_fingertip_print"] = apply(tip_inv, c + (a - c) / k).tolist()
        if domes:
            d = [np.linalg.norm(a - np.asarray(x["base"])) for x in domes]
            i = int(np.argmin(d))
            base = np.asarray(domes[i]["base"])
            # +x of the assembled (design) frame runs from the mount to the tip
            p["nearest_dome"] = {"index": i, "distance_mm": float(d[i]), "offset_assembled_mm": (a - base).tolist(), "side": "tip" if a[0] > base[0] else "mount"}
    # the pour frame must agree with the openings: each is air where it meets the top face
    zt = mold["flange_top_z_mm"]
    sgn = 1.0 if up[2] > 0 else -1.0
    res["openings_open_at_top"] = [
        (pieces ^ m3.Manifold.cube([0.1, 0.1, 0.1]).translate([o["xy"][0] - 0.05, o["xy"][1] - 0.05, zt - 0.1 if sgn > 0 else zt])).volume() < 1e-6 for o in mold.get("openings", [])
    ]
    res["tolerance_mm3"] = tolerance(h, dz)
    res["ok"] = res["trapped_mm3"] <= res["tolerance_mm3"] and all(res["openings_open_at_top"])
    return res


def describe(name, r):
    pk = r["pockets"]
    head = f"{name}: trapped air: {r['trapped_mm3']:.2f} mm3 in {len(pk)} pocket{'s' if len(pk) != 1 else ''}"
    lines = []
    for p in pk:
        a, f = p["apex_assembled"], p["apex_fingertip_print"]
        nd = p.get("nearest_dome")
        side = f", {nd['side']} side of dome {nd['index']} ({nd['distance_mm']:.2f} mm from its base)" if nd else ""
        lines.append(f"    {p['volume_mm3']:.3f} mm3, {p['depth_mm']:.2f} mm deep, apex at ({a[0]:.2f}, {a[1]:.2f}, {a[2]:.2f}) assembled = ({f[0]:.2f}, {f[1]:.2f}, {f[2]:.2f}) fingertip print frame{side}")
    if pk:
        a = pk[0]["apex_assembled"]
        head += f" at ({a[0]:.2f}, {a[1]:.2f}, {a[2]:.2f})" + (" ..." if len(pk) > 1 else "")
    shut = [i for i, o in enumerate(r["openings_open_at_top"]) if not o]
    verdict = "ok" if r["ok"] else f"FAILED (limit {r['tolerance_mm3']:.3g} mm3" + (f"; openings {shut} are not open at the top face: the pour orientation is wrong" if shut else "") + ")"
    tail = f"    {verdict}; voxels {' x '.join(f'{v:g}' for v in r['voxel_mm'])} mm, grid {'x'.join(map(str, r['grid']))}, liquid {r['liquid_volume_voxels_mm3']:.2f} mm3 voxelised vs {r['liquid_volume_exact_mm3']:.2f} exact, {r['seconds']:.1f} s"
    return "\n".join([head] + lines + [tail])


def main(root, h, dz, tilt_deg):
    root = Path(root)
    man = json.loads((root / "manifest.json").read_text())
    out = {"voxel_mm": [h, h, dz], "tilt_deg": tilt_deg, "tolerance_mm3": tolerance(h, dz), "molds": {}}
    bad = 0
    molds = {n: m for n, m in sorted(man.get("molds", {}).items()) if m.get("style") == "conforming"}
    if not molds:
        print("no conforming molds in manifest")
    for name, mold in molds.items():
        r = check_mold(name, mold, root, h, dz, tilt_deg)
        out["molds"][name] = r
        print(describe(name, r))
        bad += not r["ok"]
    (root / "air.json").write_text(json.dumps(out, indent=1) + "\n")
    return 1 if bad else 0


# ---------------------------------------------------------------- self-test
def synthetic(kind):
    """A block mold (core and shell in one) whose cavity is a flat slab 24 x 12 x 2 mm with its
    ceiling at z = -3 and a 3 mm sprue up from one end to the top face (z = 0). Returns
    (pieces, box lo, box hi, expected trapped mm3 or None, the pocket's apex or None)."""
    lo, hi = np.array([-2.0, -8.0, -10.0]), np.array([26.0, 8.0, 0.0])
    block = m3.Manifold.cube(list(hi - lo)).translate(list(lo))
    ceiling = -3.0
    slab = m3.Manifold.cube([24.0, 12.0, 2.0]).translate([0.0, -6.0, ceiling - 2.0])
    sprue = m3.Manifold.cylinder(3.5, 1.5, 1.5, 48).translate([22.0, 0.0, ceiling - 0.5])
    holes = [slab, sprue]
    expect, apex = 0.0, None
    cap_a, cap_d = 2.5, 1.0  # dome pocket in the ceiling: base radius, depth
    R = (cap_a ** 2 + cap_d ** 2) / (2 * cap_d)
    cap_c = np.array([5.0, 0.0, ceiling + cap_d - R])
    cap = m3.Manifold.sphere(R, 256).translate(list(cap_c)) ^ m3.Manifold.cube([10.0, 10.0, 2.0]).translate([0.0, -5.0, ceiling - 0.5])
    cap_vol = math.pi * cap_d ** 2 * (3 * R - cap_d) / 3
    bell_r, bell_h = 2.0, 1.5  # an upside-down cup standing on the slab
    bell = m3.Manifold.cylinder(bell_h + 0.5, bell_r, bell_r, 96).translate([12.0, 0.0, ceiling - 0.5])
    sealed = m3.Manifold.sphere(1.0, 48).translate([12.0, 0.0, -8.0])  # a closed void, no cavity
    if kind in ("cap", "cap+vent", "cap+offvent"):
        holes.append(cap)
        expect, apex = cap_vol, cap_c + [0, 0, R]
        if kind == "cap+vent":
            holes.append(m3.Manifold.cylinder(4.0, 0.4, 0.4, 24).translate([5.0, 0.0, ceiling]))
            expect, apex = 0.0, None
        if kind == "cap+offvent":
            # a vent 2 mm off the apex leaves the part of the cap above the vent's highest edge
            off = 2.0
            holes.append(m3.Manifold.cylinder(4.0, 0.4, 0.4, 24).translate([5.0 + off, 0.0, ceiling]))
            zc = cap_c[2] + math.sqrt(R ** 2 - (off - 0.4) ** 2)  # height of the ceiling at the vent's inner edge
            d = cap_c[2] + R - zc
            expect = math.pi * d ** 2 * (3 * R - d) / 3
    if kind in ("bell", "bell+vent"):
        holes += [bell, sealed]
        expect, apex = math.pi * bell_r ** 2 * bell_h, np.array([12.0, 0.0, ceiling + bell_h])
        if kind == "bell+vent":
            holes.append(m3.Manifold.cylinder(3.0, 0.4, 0.4, 24).translate([12.0, 0.0, ceiling + bell_h - 0.1]))
            expect, apex = 0.0, None
    if kind == "slope":
        # the ceiling is a cone rising 4 degrees from everywhere to the sprue's axis
        t = math.tan(math.radians(4.0))
        cone = m3.Manifold.cylinder(2.5, 2.5 / t, 0.0, 256).translate([22.0, 0.0, ceiling - 2.0])
        holes = [m3.Manifold.cube([24.0, 12.0, 3.0]).translate([0.0, -6.0, ceiling - 2.0]) ^ cone, m3.Manifold.cylinder(4.0, 1.5, 1.5, 48).translate([22.0, 0.0, ceiling])]
    pieces = block - m3.Manifold.batch_boolean(holes, m3.OpType.Add)
    return pieces, lo, hi, expect, apex


def self_test(h=SELF_TEST_VOXEL_MM, dz=DEFAULT_DZ_MM, root=None):
    """Synthetic molds made to trap air or not; with ROOT also its real molds, vented where the
    check says."""
    fails = 0

    def run(kind, tilt=0.0, h=h, dz=dz, keep_grid=False):
        pieces, lo, hi, expect, apex = synthetic(kind)
        air = [r for r in (m3.Manifold.cube(list(hi - lo)).translate(list(lo)) - pieces).decompose() if r.volume() > 1e-3]
        bb = m3.Manifold.batch_boolean(air, m3.OpType.Add).bounding_box()
        rot = rot_y(tilt)
        r = trapped_air(pieces, lo, hi, bb[:3], bb[3:], h, dz, rot, keep_grid)
        for p in r["pockets"]:
            p["apex"] = (rot.T @ np.asarray(p["apex_pour"])).tolist()
        return r, expect, apex

    def case(what, ok, detail):
        nonlocal fails
        fails += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {what}: {detail}")

    tol = tolerance(h, dz)
    for kind, what in (
        ("cap", "a dome-shaped pocket (2.5 mm base radius, 1 mm deep) in a level ceiling, sprue at the far end, traps its volume at its apex"),
        ("bell", "an upside-down cup (r 2 mm, 1.5 mm tall) open only at its bottom rim traps its volume (a sealed void in the block is no part of the cavity)"),
        ("cap+offvent", "a vent 2 mm off the dome's apex leaves the cap above the vent's edge"),
    ):
        r, expect, apex = run(kind)
        got = r["trapped_mm3"]
        top = r["pockets"][0] if r["pockets"] else None
        near = top is not None and np.linalg.norm(np.asarray(top["apex"]) - apex) < 2 * max(h, dz)
        ok = abs(got - expect) <= 0.2 * expect and len(r["pockets"]) == 1 and near
        case(what, ok, f"{got:.3f} mm3 vs {expect:.3f} analytic ({100 * (got / expect - 1):+.1f} %), {len(r['pockets'])} pocket(s), apex {np.round(top['apex'], 2).tolist() if top else None} vs {np.round(apex, 2).tolist()}, depth {top['depth_mm'] if top else 0:.2f} mm, {r['seconds']:.1f} s")
    for kind, what in (
        ("cap+vent", "the same dome pocket with a 0.8 mm vent drilled up from its apex traps nothing"),
        ("bell+vent", "the upside-down cup with a vent from its top traps nothing"),
        ("slope", "a cavity whose ceiling rises 4 degrees everywhere to the sprue (a cone) traps nothing"),
    ):
        r, _, _ = run(kind)
        case(what, r["trapped_mm3"] <= tol, f"{r['trapped_mm3']:.4f} mm3 in {len(r['pockets'])} pocket(s) (limit {tol} mm3), {r['seconds']:.1f} s")
    # the same rising ceiling poured with its sprue end lowered by 10 degrees (net 6 degrees down to
    # the sprue): the far end becomes the pocket
    r, _, _ = run("slope", tilt=-10.0)
    top = r["pockets"][0] if r["pockets"] else None
    case("the rising ceiling poured tilted 10 degrees the wrong way traps air at its far (x = 0) end", r["trapped_mm3"] > 1.0 and top is not None and top["apex"][0] < 1.0,
         f"{r['trapped_mm3']:.2f} mm3, apex {np.round(top['apex'], 2).tolist() if top else None}")
    # the union-find against a plain level-by-level 3-D labelling, voxel for voxel (coarse voxels)
    for kind, tilt in (("cap", 0.0), ("bell", 0.0), ("cap+offvent", 0.0), ("cap+vent", 0.0), ("slope", -10.0), ("bell", 25.0)):
        r, _, _ = run(kind, tilt, 0.2, 0.1, keep_grid=True)
        other = trapped_by_levels(r["air"], r["atmosphere"])
        diff = int((other != r["trapped"]).sum())
        case(f"union-find = level-by-level labelling on '{kind}' tilted {tilt:g} deg", diff == 0, f"{int(r['trapped'].sum())} vs {int(other.sum())} trapped voxels, {diff} differ")
    # the rasteriser against trimesh's point containment on one synthetic mold
    pieces, lo, hi, _, _ = synthetic("cap+offvent")
    mesh = trimesh.Trimesh(*(lambda m: (m.vert_properties[:, :3], m.tri_verts))(pieces.to_mesh()))
    rng = np.random.default_rng(1)
    zc = -3.2 + SEAM
    cells = raster(pieces.slice(zc).to_polygons(), lo[0], lo[1], h, int((hi[0] - lo[0]) / h), int((hi[1] - lo[1]) / h))
    jj, ii = rng.integers(0, cells.shape[0], 4000), rng.integers(0, cells.shape[1], 4000)
    pts = np.column_stack([lo[0] + (ii + 0.5) * h, lo[1] + (jj + 0.5) * h, np.full(4000, zc)])
    agree = (mesh.contains(pts) == cells[jj, ii]).mean()
    case("the slice rasteriser agrees with trimesh's contains() on 4000 random cells", agree >= 0.999, f"{100 * agree:.2f} % agree")
    if root is not None:
        root = Path(root)
        man = json.loads((root / "manifest.json").read_text())
        for name, mold in sorted(man.get("molds", {}).items()):
            if mold.get("style") != "conforming":
                continue
            pieces = load_pieces(mold, root)
            r = check_mold(name, mold, root, h, dz, 0.0, pieces)
            apexes = [p["apex_assembled"] for p in r["pockets"]]
            v = check_mold(name, mold, root, h, dz, 0.0, drill(pieces, mold, apexes))
            case(f"{name} with a 0.8 mm vent drilled up from each of its {len(apexes)} pocket apexes traps nothing", v["ok"] and len(v["openings_open_at_top"]) > 0,
                 f"{r['trapped_mm3']:.3f} mm3 before, {v['trapped_mm3']:.4f} mm3 in {len(v['pockets'])} pocket(s) after (limit {v['tolerance_mm3']:.3g}), openings open at the top {v['openings_open_at_top']}")
    print(f"self-test: {'all passed' if not fails else f'{fails} FAILED'}")
    return 1 if fails else 0


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", default=None, help="build output folder (default: out); with --self-test, also vent its real molds")
    ap.add_argument("--voxel", type=float, default=None, help=f"voxel width and length (mm), default {DEFAULT_VOXEL_MM} ({SELF_TEST_VOXEL_MM} in the self-test)")
    ap.add_argument("--dz", type=float, default=DEFAULT_DZ_MM, help="voxel height (mm), default %(default)s")
    ap.add_argument("--tilt-deg", type=float, default=0.0, help="pour with the tip end (+x) raised by this (deg)")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        sys.exit(self_test(a.voxel or SELF_TEST_VOXEL_MM, a.dz, a.out))
    sys.exit(main(a.out or "out", a.voxel or DEFAULT_VOXEL_MM, a.dz, a.tilt_deg))
