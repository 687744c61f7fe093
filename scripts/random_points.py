#!/usr/bin/env python3
"""A points file for `solve --points` and `pathtrace --points`: points drawn uniformly over a
scene's bounds, each with a normal drawn uniformly over the sphere, points inside objects
dropped.

    scripts/random_points.py SCENE.obj COUNT SEED > points.json

The bounds are the OBJ's bounding box, inset by 1% of its size on every side (a point on a
wall answers for the wall, not for the room). A point is inside an object by the rule of
`solve --points` (docs/contract.md, "The points file"): of 32 rays from it, in directions of a
golden-angle spiral over the sphere, more than half whose first hit is a triangle's back face.
Such points are dropped and drawing goes on until COUNT remain, so the same SEED gives the
same file. The README's "points anywhere in the box" figures come from
`random_points.py scenes/cornell-box/CornellBox-Original.obj 140 1` and
`random_points.py scenes/cornell-original/cornell_box_data.obj 40 2`. Only the Python
standard library.
"""

import json
import math
import random
import sys


def read_obj(path):
    positions, triangles = [], []
    with open(path, errors="replace") as f:
        for line in f:
            words = line.split()
            if words[:1] == ["v"]:
                positions.append(tuple(float(x) for x in words[1:4]))
            elif words[:1] == ["f"]:
                idx = [int(c.split("/")[0]) for c in words[1:]]
                idx = [i - 1 if i > 0 else len(positions) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    triangles.append(
                        (positions[idx[0]], positions[idx[k]], positions[idx[k + 1]])
                    )
    return positions, triangles


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def first_hit_is_back_face(origin, direction, triangles):
    """Whether the nearest triangle along the ray faces away from it; None when nothing is hit."""
    nearest, back = math.inf, None
    for a, b, c in triangles:
        e1, e2 = sub(b, a), sub(c, a)
        p = cross(direction, e2)
        det = dot(e1, p)
        if abs(det) < 1e-12:
            continue
        s = sub(origin, a)
        u = dot(s, p) / det
        if u < 0.0 or u > 1.0:
            continue
        q = cross(s, e1)
        v = dot(direction, q) / det
        if v < 0.0 or u + v > 1.0:
            continue
        t = dot(e2, q) / det
        if 1e-9 < t < nearest:
            nearest = t
            back = dot(cross(e1, e2), direction) > 0.0
    return back


def spiral(count):
    """`count` directions spread over the sphere (a golden-angle spiral)."""
    golden = math.pi * (3.0 - math.sqrt(5.0))
    out = []
    for i in range(count):
        y = 1.0 - 2.0 * (i + 0.5) / count
        r = math.sqrt(max(0.0, 1.0 - y * y))
        out.append((r * math.cos(golden * i), y, r * math.sin(golden * i)))
    return out


def inside(point, triangles, directions):
    back = sum(1 for d in directions if first_hit_is_back_face(point, d, triangles))
    return 2 * back > len(directions)


def unit_vector(rng):
    while True:
        v = (rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1))
        n = math.sqrt(dot(v, v))
        if 1e-3 < n <= 1.0:
            return tuple(x / n for x in v)


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: random_points.py SCENE.obj COUNT SEED > points.json")
    positions, triangles = read_obj(sys.argv[1])
    count, seed = int(sys.argv[2]), int(sys.argv[3])
    if not triangles:
        sys.exit(f"error: {sys.argv[1]} has no faces")
    lo = [min(p[k] for p in positions) for k in range(3)]
    hi = [max(p[k] for p in positions) for k in range(3)]
    inset = [0.01 * (hi[k] - lo[k]) for k in range(3)]
    rng = random.Random(seed)
    directions = spiral(32)
    points = []
    while len(points) < count:
        p = tuple(rng.uniform(lo[k] + inset[k], hi[k] - inset[k]) for k in range(3))
        n = unit_vector(rng)
        if inside(p, triangles, directions):
            continue
        points.append(
            {"position": [round(x, 4) for x in p], "normal": [round(x, 4) for x in n]}
        )
    json.dump({"points": points}, sys.stdout, indent=None)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
