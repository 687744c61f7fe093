#!/usr/bin/env python3
"""Pavilions whose floor and roof slabs are hollow: sealed voids inside thin slabs, as BIM
exports make them (hollow-core slabs, roof build-ups), under a low sun and a sky.

    scripts/sealed_voids.py OUT_DIR [SITES]

Writes OUT_DIR/sealed_voids.obj, sealed_voids.mtl, sun.json (one directional light, 1000 W/m²
on a surface facing it, travelling down at 35° from the horizon) and sun_sky.json (the same sun
and a uniform sky of radiance 30 W/(m²·sr)). SITES (default 2) pavilions stand on one ground.

Each slab is one connected mesh: an extruded ring profile (outer faces, the faces of a cavity
running its whole length, and the two ring-shaped end caps joining them). End plates, objects
of their own, close the cavity's two ends, so its faces see nothing but each other and the
plates: no light reaches them. Each cavity face lies within a slab's thickness of a lit outer
face with the same normal (0.2 m cavity in a 0.4 m slab), so a grid cell of the bake holds
both. Posts stand on the floor slab and run into the roof slab (their tops buried in it), a
back wall shades part of the floor. Only the Python standard library.
"""

import json
import math
import sys
from pathlib import Path

from architecture import box  # the six faces of an axis-aligned box, outward


def hollow_slab(x0, x1, outer, inner):
    """A slab along x from x0 to x1 with a cavity through its whole length, as one connected
    surface. `outer` and `inner` are (y0, y1, z0, z1) rectangles of the profile. Faces are
    counter-clockwise seen from the side they face: outwards on the outer faces, into the
    cavity on the inner ones, along ±x on the ring caps."""
    (oy0, oy1, oz0, oz1), (iy0, iy1, iz0, iz1) = outer, inner
    # The profile's rings, counter-clockwise about +x seen from +x (y up, z to the left).
    ring_o = [(oy0, oz1), (oy0, oz0), (oy1, oz0), (oy1, oz1)]
    ring_i = [(iy0, iz1), (iy0, iz0), (iy1, iz0), (iy1, iz1)]
    faces = []
    for k in range(4):
        (ay, az), (by, bz) = ring_o[k], ring_o[(k + 1) % 4]
        faces.append([(x0, ay, az), (x0, by, bz), (x1, by, bz), (x1, ay, az)])
        (ay, az), (by, bz) = ring_i[k], ring_i[(k + 1) % 4]
        faces.append([(x0, ay, az), (x0, by, bz), (x1, by, bz), (x1, ay, az)][::-1])
    for x, flip in ((x1, False), (x0, True)):
        for k in range(4):
            (oa, ob), (ia, ib) = (ring_o[k], ring_o[(k + 1) % 4]), (ring_i[k], ring_i[(k + 1) % 4])
            quad = [(x, *oa), (x, *ob), (x, *ib), (x, *ia)]
            faces.append(quad[::-1] if flip else quad)
    return faces


def pavilion(objects, ox, oz, tag):
    """One pavilion centred at (ox, oz): hollow floor and roof slabs with end plates, six
    posts, a back wall and a bench."""
    fx, fz = 5.0, 4.0  # floor half extents
    rx, rz = 7.0, 6.0  # roof half extents: overhangs of 2 m
    objects.append((f"{tag}_floor", "slab", hollow_slab(
        ox - fx, ox + fx, (0.0, 0.4, oz - fz, oz + fz), (0.1, 0.3, oz - fz + 0.3, oz + fz - 0.3))))
    objects.append((f"{tag}_roof", "roof", hollow_slab(
        ox - rx, ox + rx, (3.0, 3.4, oz - rz, oz + rz), (3.1, 3.3, oz - rz + 0.3, oz + rz - 0.3))))
    for end, x in (("w", ox - fx - 0.3), ("e", ox + fx)):
        objects.append((f"{tag}_floor_end_{end}", "plate", box((x, 0.0, oz - fz), (x + 0.3, 0.4, oz + fz))))
    for end, x in (("w", ox - rx - 0.3), ("e", ox + rx)):
        objects.append((f"{tag}_roof_end_{end}", "plate", box((x, 3.0, oz - rz), (x + 0.3, 3.4, oz + rz))))
    k = 0
    for px in (-4.2, 0.0, 4.2):
        for pz in (-3.2, 3.2):
            x, z = ox + px, oz + pz
            objects.append((f"{tag}_post_{k}", "post", box((x - 0.15, 0.4, z - 0.15), (x + 0.15, 3.2, z + 0.15))))
            k += 1
    objects.append((f"{tag}_back_wall", "wall", box((ox - 4.0, 0.4, oz - 3.6), (ox + 4.0, 2.6, oz - 3.4))))
    objects.append((f"{tag}_bench", "wood", box((ox - 1.5, 0.4, oz - 0.3), (ox + 1.5, 0.85, oz + 0.3))))


MATERIALS = {
    "ground": (0.25, 0.25, 0.2),
    "slab": (0.5, 0.5, 0.48),
    "roof": (0.45, 0.22, 0.16),
    "plate": (0.6, 0.6, 0.6),
    "post": (0.55, 0.55, 0.55),
    "wall": (0.65, 0.62, 0.58),
    "wood": (0.45, 0.3, 0.2),
}


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: sealed_voids.py OUT_DIR [SITES]")
    out = Path(sys.argv[1])
    sites = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    out.mkdir(parents=True, exist_ok=True)
    objects = [("ground", "ground", [[(-15.0, 0.0, -15.0 + 20.0 * (sites - 1) / 2), (-15.0, 0.0, 15.0 + 20.0 * (sites - 1) / 2),
                                      (15.0, 0.0, 15.0 + 20.0 * (sites - 1) / 2), (15.0, 0.0, -15.0 + 20.0 * (sites - 1) / 2)]])]
    # The ground sits 1 mm under the floor slabs' bottoms, which touch nothing.
    objects[0] = ("ground", "ground", [[(x, -0.001, z) for x, _, z in objects[0][2][0]]])
    for s in range(sites):
        pavilion(objects, 0.0, 20.0 * s, f"p{s}")
    lines = ["mtllib sealed_voids.mtl"]
    nv = 0
    for name, mat, faces in objects:
        lines += [f"o {name}", f"usemtl {mat}"]
        for f in faces:
            for v in f:
                lines.append("v {:.6f} {:.6f} {:.6f}".format(*v))
            idx = list(range(nv + 1, nv + len(f) + 1))
            nv += len(f)
            for k in range(1, len(idx) - 1):
                lines.append(f"f {idx[0]} {idx[k]} {idx[k + 1]}")
    (out / "sealed_voids.obj").write_text("\n".join(lines) + "\n")
    mtl = []
    for m, kd in MATERIALS.items():
        mtl += [f"newmtl {m}", "Kd {:.3f} {:.3f} {:.3f}".format(*kd), ""]
    (out / "sealed_voids.mtl").write_text("\n".join(mtl))
    elev, azim = math.radians(35.0), math.radians(200.0)
    d = [-math.cos(elev) * math.sin(azim), -math.sin(elev), -math.cos(elev) * math.cos(azim)]
    sun = {"type": "directional", "direction": d, "irradiance": [1000.0, 1000.0, 1000.0]}
    (out / "sun.json").write_text(json.dumps({"lights": [sun]}, indent=1) + "\n")
    sky = {"type": "sky", "radiance": [30.0, 30.0, 30.0]}
    (out / "sun_sky.json").write_text(json.dumps({"lights": [sun, sky]}, indent=1) + "\n")


if __name__ == "__main__":
    main()
