#!/usr/bin/env python3
"""Thin, many-part architecture lit by a low sun: open pavilions on columns under deep roof
overhangs, stairs, railings and closed buildings, all standing on one large shared ground.

    scripts/architecture.py OUT_DIR [SITES]

Writes OUT_DIR/architecture.obj, architecture.mtl, sun.json (one directional light, 1000 W/m²
on a surface facing it, travelling down at 28° from the horizon) and sun_sky.json (the same
sun and a uniform sky of radiance 30 W/(m²·sr), π·30 ≈ 94 W/m² on open ground). SITES (default
56) is the number of sites on a grid; each holds a pavilion (a plinth, steps on two
sides, a ring of 16-sided columns, beams, a roof slab overhanging the columns by 2–3 m, a
railing of 6-sided posts and rails along the open sides, benches) and, on about half the sites, a
closed building behind it. At 56 sites the scene has 126,682 triangles, 5,221 objects and
82 materials: every part is an object of its own, so `solve --json` reports it.

The steps are boxes from the ground up to their treads, each higher one standing inside the
one below (whose top it partly buries), the columns stand on the plinth and carry the beams, and the
ground is two triangles: the bake, not the modeller, must place patches where the light varies.
Only the Python standard library; every size and material comes from a fixed seed.
"""

import math
import random
import sys
from pathlib import Path

SPACING = 26.0  # metres between site centres
MATERIALS = 82


def box(lo, hi):
    """The six faces of an axis-aligned box as quads, counter-clockwise seen from outside."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # top (+y)
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # bottom (-y)
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # +z
        [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],  # -z
        [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)],  # +x
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # -x
    ]


def column(cx, cz, r, y0, y1, sides=16):
    """A closed prism of `sides` sides around the vertical axis through (cx, cz): side quads
    and the two caps as polygons, counter-clockwise seen from outside."""
    ring = [
        (cx + r * math.cos(2 * math.pi * k / sides), cz - r * math.sin(2 * math.pi * k / sides))
        for k in range(sides)
    ]
    faces = []
    for k in range(sides):
        (ax, az), (bx, bz) = ring[k], ring[(k + 1) % sides]
        faces.append([(ax, y0, az), (bx, y0, bz), (bx, y1, bz), (ax, y1, az)])
    faces.append([(x, y1, z) for x, z in ring][::-1])  # top, facing +y
    faces.append([(x, y0, z) for x, z in ring])  # bottom, facing -y
    return faces


def site(rng, objects, mats, tag, ox, oz):
    """One pavilion (and maybe a closed building) centred at (ox, oz)."""
    m = lambda: mats[rng.randrange(len(mats))]  # noqa: E731
    w, d = rng.uniform(9.0, 13.0), rng.uniform(7.0, 10.0)  # the plinth's half-sizes x2
    ph = rng.choice((0.6, 0.9, 1.2))  # plinth height
    x0, x1, z0, z1 = ox - w / 2, ox + w / 2, oz - d / 2, oz + d / 2
    plinth_m, col_m, roof_m, rail_m, step_m = m(), m(), m(), m(), m()
    objects.append((f"{tag}_plinth", plinth_m, box((x0, 0, z0), (x1, ph, z1))))
    # Steps on the -z and +x sides: each a box from the ground up to its tread.
    n = round(ph / 0.15)
    for side in ("s", "e"):
        for k in range(n):
            top = ph * (k + 1) / n
            run = (n - k) * 0.3
            if side == "s":
                lo, hi = (ox - 1.5, 0, z0 - run), (ox + 1.5, top, z0)
            else:
                lo, hi = (x1, 0, oz - 1.5), (x1 + run, top, oz + 1.5)
            objects.append((f"{tag}_step_{side}{k}", step_m, box(lo, hi)))
    # Columns on a ring inset 0.6 m from the plinth's edge.
    ch = rng.uniform(3.2, 4.5)
    r = rng.uniform(0.16, 0.26)
    nx, nz = rng.randint(5, 7), rng.randint(4, 5)
    xs = [x0 + 0.6 + (w - 1.2) * i / (nx - 1) for i in range(nx)]
    zs = [z0 + 0.6 + (d - 1.2) * j / (nz - 1) for j in range(nz)]
    ring = [(x, z) for x in xs for z in (zs[0], zs[-1])] + [
        (x, z) for x in (xs[0], xs[-1]) for z in zs[1:-1]
    ]
    for k, (x, z) in enumerate(ring):
        objects.append((f"{tag}_column{k}", col_m, column(x, z, r, ph, ph + ch)))
    # Beams along the ring's four sides, on top of the columns.
    bt = ph + ch
    for k, (lo, hi) in enumerate(
        (
            ((xs[0] - 0.3, bt, zs[0] - 0.3), (xs[-1] + 0.3, bt + 0.5, zs[0] + 0.3)),
            ((xs[0] - 0.3, bt, zs[-1] - 0.3), (xs[-1] + 0.3, bt + 0.5, zs[-1] + 0.3)),
            ((xs[0] - 0.3, bt, zs[0] + 0.3), (xs[0] + 0.3, bt + 0.5, zs[-1] - 0.3)),
            ((xs[-1] - 0.3, bt, zs[0] + 0.3), (xs[-1] + 0.3, bt + 0.5, zs[-1] - 0.3)),
        )
    ):
        objects.append((f"{tag}_beam{k}", roof_m, box(lo, hi)))
    # A thin roof slab overhanging the plinth by 2-3 m, and a fascia under its rim.
    oh = rng.uniform(2.0, 3.0)
    rt = bt + 0.5
    objects.append(
        (f"{tag}_roof", roof_m, box((x0 - oh, rt, z0 - oh), (x1 + oh, rt + 0.25, z1 + oh)))
    )
    fm = m()
    for k, (lo, hi) in enumerate(
        (
            ((x0 - oh, rt - 0.4, z0 - oh), (x1 + oh, rt, z0 - oh + 0.1)),
            ((x0 - oh, rt - 0.4, z1 + oh - 0.1), (x1 + oh, rt, z1 + oh)),
            ((x0 - oh, rt - 0.4, z0 - oh + 0.1), (x0 - oh + 0.1, rt, z1 + oh - 0.1)),
            ((x1 + oh - 0.1, rt - 0.4, z0 - oh + 0.1), (x1 + oh, rt, z1 + oh - 0.1)),
        )
    ):
        objects.append((f"{tag}_fascia{k}", fm, box(lo, hi)))
    # Railings on the +z and -x sides (the ones without steps): posts every 0.5 m, two rails.
    for side in ("n", "w"):
        if side == "n":
            pts = [(x0 + 0.2 + 0.5 * i, z1 - 0.15) for i in range(int((w - 0.4) / 0.5) + 1)]
        else:
            pts = [(x0 + 0.15, z0 + 0.2 + 0.5 * i) for i in range(int((d - 0.4) / 0.5) + 1)]
        for k, (x, z) in enumerate(pts):
            objects.append(
                (f"{tag}_post_{side}{k}", rail_m, column(x, z, 0.03, ph, ph + 1.0, sides=6))
            )
        for k, y in enumerate((ph + 0.5, ph + 1.0)):
            if side == "n":
                lo, hi = (pts[0][0] - 0.05, y, z1 - 0.2), (pts[-1][0] + 0.05, y + 0.05, z1 - 0.1)
            else:
                lo, hi = (x0 + 0.1, y, pts[0][1] - 0.05), (x0 + 0.2, y + 0.05, pts[-1][1] + 0.05)
            objects.append((f"{tag}_rail_{side}{k}", rail_m, box(lo, hi)))
    # Benches under the roof: a seat and two legs each, all objects of their own.
    bm = m()
    for k in range(rng.randint(2, 4)):
        bx = xs[0] + 1.0 + (xs[-1] - xs[0] - 3.0) * rng.random()
        bz = zs[0] + 1.0 + (zs[-1] - zs[0] - 2.0) * rng.random()
        objects.append((f"{tag}_bench{k}_seat", bm, box((bx, ph + 0.42, bz), (bx + 1.6, ph + 0.47, bz + 0.4))))
        for j, lx in enumerate((bx + 0.1, bx + 1.4)):
            objects.append((f"{tag}_bench{k}_leg{j}", bm, box((lx, ph, bz + 0.05), (lx + 0.1, ph + 0.42, bz + 0.35))))
    # Half the sites: a closed building of one or two storeys behind the pavilion (+z), with a
    # floor slab sticking out as a ledge between storeys.
    if rng.random() < 0.55:
        bz0 = z1 + oh + 0.8
        bz1 = min(bz0 + rng.uniform(3.0, 5.0), oz + SPACING / 2 - 0.5)
        storeys = rng.randint(1, 2)
        wm = m()
        for s in range(storeys):
            objects.append(
                (f"{tag}_house_storey{s}", wm, box((x0, 3.2 * s, bz0), (x1, 3.2 * (s + 1), bz1)))
            )
            objects.append(
                (f"{tag}_house_ledge{s}", m(), box((x0 - 0.4, 3.2 * (s + 1), bz0 - 0.6), (x1 + 0.4, 3.2 * (s + 1) + 0.2, bz1 + 0.4)))
            )
    # Lamp posts at the site's corners, standing on the ground.
    lm = m()
    for k, (x, z) in enumerate(((x0 - 2.5, z0 - 2.5), (x1 + 3.5, z0 - 2.5))):
        objects.append((f"{tag}_lamp{k}", lm, column(x, z, 0.08, 0.0, 4.0, sides=8)))


def main():
    out = Path(sys.argv[1])
    sites = int(sys.argv[2]) if len(sys.argv) > 2 else 56
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(47)
    mats = [f"m{k:02d}" for k in range(MATERIALS - 1)]
    kd = {name: tuple(round(rng.uniform(0.1, 0.8), 3) for _ in range(3)) for name in mats}
    kd["ground"] = (0.3, 0.3, 0.28)
    cols = math.ceil(math.sqrt(sites))
    g = cols * SPACING / 2 + 10.0
    objects = [("ground", "ground", [[(-g, 0, -g), (-g, 0, g), (g, 0, g), (g, 0, -g)]])]
    for k in range(sites):
        i, j = k % cols, k // cols
        ox = (i - (cols - 1) / 2) * SPACING
        oz = (j - (cols - 1) / 2) * SPACING
        site(rng, objects, mats, f"s{k:02d}", ox, oz)
    used = sorted({mat for _, mat, _ in objects})
    with open(out / "architecture.mtl", "w") as f:
        f.write("# scripts/architecture.py\n")
        for name in used:
            r, gg, b = kd[name]
            f.write(f"newmtl {name}\nKd {r} {gg} {b}\n\n")
    tris = 0
    with open(out / "architecture.obj", "w") as f:
        f.write(f"# scripts/architecture.py: {len(objects)} objects\nmtllib architecture.mtl\n")
        nv = 0
        for name, mat, faces in objects:
            f.write(f"o {name}\nusemtl {mat}\n")
            for face in faces:
                for p in face:
                    f.write("v {:.5f} {:.5f} {:.5f}\n".format(*p))
                f.write("f " + " ".join(str(nv + 1 + i) for i in range(len(face))) + "\n")
                nv += len(face)
                tris += len(face) - 2
    elevation, azimuth = math.radians(28.0), math.radians(35.0)
    d = (
        -math.cos(elevation) * math.sin(azimuth),
        -math.sin(elevation),
        -math.cos(elevation) * math.cos(azimuth),
    )
    sun = '{"type": "directional", "direction": [%.6f, %.6f, %.6f], "irradiance": [1000, 1000, 1000]}' % d
    with open(out / "sun.json", "w") as f:
        f.write('{"lights": [%s]}\n' % sun)
    with open(out / "sun_sky.json", "w") as f:
        f.write('{"lights": [%s, {"type": "sky", "radiance": [30, 30, 30]}]}\n' % sun)
    print(f"{len(objects)} objects, {tris} triangles, {len(used)} materials", file=sys.stderr)


if __name__ == "__main__":
    main()
