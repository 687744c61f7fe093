#!/usr/bin/env python3
"""The conference room's lights file, from the room's geometry: the model has no emitters and
no light fittings, only its ceiling, so this finds the ceiling and hangs a grid of downlights
under it.

    scripts/conference_lights.py conference.obj > lights.json [--rows 3 --columns 4]

The ceiling is the largest surface of down-facing triangles at the top of the model (within
1% of its height of the highest vertex). Over that surface's bounding rectangle the script
places ROWS × COLUMNS spot lights (one per cell of an even grid, at the cell centres), 1% of
the room's height below the ceiling, pointing straight down with a 60° half-angle: recessed
downlights. Each has intensity I = E·h², so that the floor under it receives about E from it
alone (E = 10 W/m² with `h` the ceiling's height above the lowest vertex, in scene units; the
model's unit is 1/0.003 m, see copyright.txt). Only the Python standard library.
"""

import json
import sys


def main():
    args = sys.argv[1:]
    rows, columns = 3, 4
    if "--rows" in args:
        rows = int(args[args.index("--rows") + 1])
    if "--columns" in args:
        columns = int(args[args.index("--columns") + 1])
    path = args[0]
    positions, faces = [], []
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                positions.append(tuple(float(x) for x in line.split()[1:4]))
            elif line.startswith("f "):
                idx = [int(c.split("/")[0]) for c in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(positions) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    faces.append((idx[0], idx[k], idx[k + 1]))
    lo_y = min(p[1] for p in positions)
    hi_y = max(p[1] for p in positions)
    tol = 0.01 * (hi_y - lo_y)
    ceiling = []
    for a, b, c in faces:
        pa, pb, pc = positions[a], positions[b], positions[c]
        u = [pb[i] - pa[i] for i in range(3)]
        v = [pc[i] - pa[i] for i in range(3)]
        ny = u[2] * v[0] - u[0] * v[2]
        area2 = sum(
            x * x
            for x in (u[1] * v[2] - u[2] * v[1], ny, u[0] * v[1] - u[1] * v[0])
        ) ** 0.5
        # Down-facing (the normal's y below -0.99 of its length) and at the top.
        if area2 > 0 and ny < -0.99 * area2 and min(pa[1], pb[1], pc[1]) > hi_y - tol:
            ceiling.append((pa, pb, pc))
    if not ceiling:
        sys.exit(f"error: {path}: no down-facing surface at the top of the model")
    xs = [p[0] for t in ceiling for p in t]
    zs = [p[2] for t in ceiling for p in t]
    y = min(p[1] for t in ceiling for p in t)
    height = y - lo_y
    x0, x1, z0, z1 = min(xs), max(xs), min(zs), max(zs)
    intensity = 10.0 * height * height
    lights = []
    for r in range(rows):
        for c in range(columns):
            lights.append(
                {
                    "type": "spot",
                    "position": [
                        round(x0 + (c + 0.5) * (x1 - x0) / columns, 3),
                        round(y - 0.01 * height, 3),
                        round(z0 + (r + 0.5) * (z1 - z0) / rows, 3),
                    ],
                    "direction": [0, -1, 0],
                    "cone_deg": 60,
                    "intensity": [round(intensity, 1)] * 3,
                }
            )
    body = ",\n".join("  " + json.dumps(light) for light in lights)
    sys.stdout.write('{"lights": [\n' + body + "\n]}\n")


if __name__ == "__main__":
    main()
