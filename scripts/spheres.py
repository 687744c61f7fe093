#!/usr/bin/env python3
"""Sphere scenes with closed-form radiosity: inside a sphere every F_ij = A_j / A; nested
spheres exchange light by their areas alone.

    scripts/spheres.py inside  LEVEL RHO OUT.obj   # icosphere seen from inside, split at y = 0:
                                                   # "top" emits E = 1, "bottom" does not
    scripts/spheres.py nested  LEVEL RHO OUT.obj   # emitting icosphere of radius 0.5, facing out,
                                                   # in one of radius 1 facing in
    scripts/spheres.py uv      SEGMENTS RHO OUT.obj  # UV sphere (SEGMENTS x SEGMENTS/2) seen
                                                   # from inside, every facet emitting E = 1

LEVEL is the number of 4-way splits of the icosahedron (20 * 4^LEVEL facets). RHO is every
surface's reflectance. The MTL file is written beside the OBJ; Ke = 1/pi is an exitance of 1.
The README's sphere timings and closed-form checks come from these scenes.
"""

import math
import sys
from pathlib import Path


def icosphere(level):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [unit(p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        mids = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in mids:
                v.append(unit([(v[a][i] + v[b][i]) / 2 for i in range(3)]))
                mids[key] = len(v) - 1
            return mids[key]

        split = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = split
    return v, f


def uv_sphere(segments):
    rings = segments // 2
    v = [(0.0, 1.0, 0.0)]
    for j in range(1, rings):
        th = math.pi * j / rings
        for i in range(segments):
            ph = 2 * math.pi * i / segments
            v.append((math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)))
    v.append((0.0, -1.0, 0.0))

    def at(j, i):
        return 1 + (j - 1) * segments + i % segments

    f = [(0, at(1, i + 1), at(1, i)) for i in range(segments)]
    for j in range(1, rings - 1):
        for i in range(segments):
            a, b, c, d = at(j, i), at(j, i + 1), at(j + 1, i + 1), at(j + 1, i)
            f += [(a, b, c), (a, c, d)]
    f += [(len(v) - 1, at(rings - 1, i), at(rings - 1, i + 1)) for i in range(segments)]
    return v, f


def unit(p):
    n = math.sqrt(sum(x * x for x in p))
    return tuple(x / n for x in p)


def facing(v, tri, inward):
    """The triangle wound so that its front faces the centre (inward) or away from it."""
    p = [v[k] for k in tri]
    e1 = [p[1][i] - p[0][i] for i in range(3)]
    e2 = [p[2][i] - p[0][i] for i in range(3)]
    n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    out = sum(n[i] * (p[0][i] + p[1][i] + p[2][i]) for i in range(3)) > 0
    return tri if out != inward else (tri[0], tri[2], tri[1])


def write(out, objects, materials):
    """objects: (name, material, vertices, triangles), vertices None to index the previous
    object's; materials: name -> (rho, emits)."""
    out = Path(out)
    mtl = out.with_suffix(".mtl")
    with open(mtl, "w") as m:
        for name, (rho, emits) in materials.items():
            m.write(f"newmtl {name}\nKd {rho} {rho} {rho}\n")
            if emits:
                e = 1 / math.pi
                m.write(f"Ke {e} {e} {e}\n")
    with open(out, "w") as o:
        o.write(f"mtllib {mtl.name}\n")
        base, written = 1, 0
        for name, material, v, f in objects:
            o.write(f"o {name}\nusemtl {material}\n")
            if v is not None:
                base += written
                written = len(v)
                for p in v:
                    o.write("v %.9f %.9f %.9f\n" % tuple(p))
            for t in f:
                o.write("f %d %d %d\n" % tuple(k + base for k in t))


def main():
    if len(sys.argv) != 5 or sys.argv[1] not in ("inside", "nested", "uv"):
        sys.exit(__doc__)
    kind, size, rho, out = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
    if kind == "inside":
        v, f = icosphere(size)
        f = [facing(v, t, True) for t in f]
        top = [t for t in f if sum(v[k][1] for k in t) > 0]
        bottom = [t for t in f if sum(v[k][1] for k in t) <= 0]
        write(out, [("top", "lamp", v, top), ("bottom", "wall", None, bottom)],
              {"lamp": (rho, True), "wall": (rho, False)})
    elif kind == "nested":
        v, f = icosphere(size)
        inner = [tuple(0.5 * x for x in p) for p in v]
        write(out, [("inner", "lamp", inner, [facing(v, t, False) for t in f]),
                    ("outer", "wall", v, [facing(v, t, True) for t in f])],
              {"lamp": (rho, True), "wall": (rho, False)})
    else:
        v, f = uv_sphere(size)
        write(out, [("sphere", "lamp", v, [facing(v, t, True) for t in f])],
              {"lamp": (rho, True)})


if __name__ == "__main__":
    main()
