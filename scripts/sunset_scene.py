#!/usr/bin/env python3
"""A small town square for `radiosity sunset`: writes scenes/sunset/square.obj and square.mtl.

    scripts/sunset_scene.py [OUT_DIR]      (default: scenes/sunset)

Metres, +Y up. A 100 m paved square; houses of plaster and brick along its east (+X) and
north (-Z) sides, their fronts facing the square; a bell tower and a low wall on its west
side, between the square and the setting sun (the sun goes down in the west, -X), so that
their shadows lengthen across the paving and climb the east houses' fronts; an arcade of
eight-sided columns under a roof slab on the south side; a fountain basin, benches and a
row of bollards. Every part is its own object. Only the Python standard library; every size
comes from this file (no randomness).
"""

import math
import sys
from pathlib import Path

MATERIALS = {
    "paving": (0.42, 0.39, 0.35),
    "plaster_white": (0.78, 0.76, 0.72),
    "plaster_ochre": (0.74, 0.56, 0.34),
    "plaster_rose": (0.72, 0.50, 0.46),
    "brick": (0.50, 0.27, 0.20),
    "stone": (0.58, 0.55, 0.50),
    "roof_tiles": (0.55, 0.28, 0.18),
    "dark_wood": (0.22, 0.15, 0.10),
}


class Obj:
    def __init__(self):
        self.v = []
        self.lines = []

    def poly(self, pts):
        base = len(self.v) + 1
        self.v.extend(pts)
        self.lines.append("f " + " ".join(str(base + i) for i in range(len(pts))))

    def start(self, name, material):
        self.lines.append(f"o {name}")
        self.lines.append(f"usemtl {material}")

    def box(self, name, material, lo, hi, bottom=False):
        """An axis-aligned box, faces counter-clockwise seen from outside; no bottom face
        unless asked (boxes stand on the ground)."""
        self.start(name, material)
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        self.poly([(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)])
        if bottom:
            self.poly([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)])
        self.poly([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)])
        self.poly([(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)])
        self.poly([(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)])
        self.poly([(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)])

    def gable_roof(self, name, lo, hi, rise, along_x):
        """A pitched roof over the box lo..hi (its top at hi.y), ridge along x or z."""
        self.start(name, "roof_tiles")
        (x0, _, z0), (x1, y, z1) = lo, hi
        top = y + rise
        if along_x:
            zm = (z0 + z1) / 2
            self.poly([(x0, y, z1), (x1, y, z1), (x1, top, zm), (x0, top, zm)])
            self.poly([(x1, y, z0), (x0, y, z0), (x0, top, zm), (x1, top, zm)])
            self.poly([(x0, y, z0), (x0, y, z1), (x0, top, zm)])
            self.poly([(x1, y, z1), (x1, y, z0), (x1, top, zm)])
        else:
            xm = (x0 + x1) / 2
            self.poly([(x1, y, z1), (x1, y, z0), (xm, top, z0), (xm, top, z1)])
            self.poly([(x0, y, z0), (x0, y, z1), (xm, top, z1), (xm, top, z0)])
            self.poly([(x0, y, z1), (x1, y, z1), (xm, top, z1)])
            self.poly([(x1, y, z0), (x0, y, z0), (xm, top, z0)])

    def prism(self, name, material, cx, cz, r, y0, y1, sides=8):
        """A vertical prism (a column), its top closed."""
        self.start(name, material)
        ring = [
            (cx + r * math.cos(2 * math.pi * k / sides), cz + r * math.sin(2 * math.pi * k / sides))
            for k in range(sides)
        ]
        for k in range(sides):
            (ax, az), (bx, bz) = ring[k], ring[(k + 1) % sides]
            self.poly([(bx, y0, bz), (ax, y0, az), (ax, y1, az), (bx, y1, bz)])
        self.poly([(x, y1, z) for (x, z) in reversed(ring)])

    def write(self, out: Path):
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "square.mtl", "w") as f:
            f.write("# scripts/sunset_scene.py\n")
            for name, kd in MATERIALS.items():
                f.write(f"newmtl {name}\nKd {kd[0]} {kd[1]} {kd[2]}\n\n")
        with open(out / "square.obj", "w") as f:
            f.write("# A town square for `radiosity sunset` (scripts/sunset_scene.py)\n")
            f.write("mtllib square.mtl\n")
            for x, y, z in self.v:
                f.write(f"v {x:.4f} {y:.4f} {z:.4f}\n")
            f.write("\n".join(self.lines) + "\n")


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent.parent / "scenes/sunset"
    o = Obj()
    # The paving, one quad 100 m across.
    o.start("paving", "paving")
    o.poly([(-50, 0, -50), (-50, 0, 50), (50, 0, 50), (50, 0, -50)])

    # East houses (fronts face -X, the square and the setting sun), a row of five.
    east = [(-22, -12, 11, "plaster_ochre"), (-12, -3, 14, "plaster_white"),
            (-3, 5, 9, "brick"), (5, 14, 12, "plaster_rose"), (14, 24, 10, "plaster_white")]
    for i, (z0, z1, h, mat) in enumerate(east):
        lo, hi = (16, 0, z0), (26, h, z1)
        o.box(f"east_house_{i}", mat, lo, hi)
        o.gable_roof(f"east_roof_{i}", lo, hi, 3.0, along_x=False)
        # A balcony slab and a door canopy on the front: thin parts in and out of the sun.
        o.box(f"east_balcony_{i}", "stone", (14.6, h * 0.55, z0 + 2.5), (16, h * 0.55 + 0.25, z1 - 2.5), bottom=True)
        o.box(f"east_canopy_{i}", "dark_wood", (15.0, 3.0, (z0 + z1) / 2 - 1.2), (16, 3.15, (z0 + z1) / 2 + 1.2), bottom=True)

    # North houses (fronts face +Z), the sun grazing their fronts.
    north = [(-20, -8, 13, "brick"), (-8, 4, 10, "plaster_ochre"), (4, 14, 15, "plaster_white")]
    for i, (x0, x1, h, mat) in enumerate(north):
        lo, hi = (x0, 0, -34), (x1, h, -24)
        o.box(f"north_house_{i}", mat, lo, hi)
        o.gable_roof(f"north_roof_{i}", lo, hi, 3.5, along_x=True)
        o.box(f"north_step_{i}", "stone", ((x0 + x1) / 2 - 1.5, 0, -24), ((x0 + x1) / 2 + 1.5, 0.3, -23))

    # The bell tower and a low wall on the west side, between the square and the sun.
    o.box("tower", "stone", (-24, 0, 2), (-18, 26, 8))
    o.box("tower_belfry_roof", "roof_tiles", (-24.6, 26, 1.4), (-17.4, 26.6, 8.6), bottom=True)
    o.start("tower_spire", "roof_tiles")
    (x0, z0), (x1, z1), y, apex = (-24.6, 1.4), (-17.4, 8.6), 26.6, (-21, 34, 5)
    for a, b in [((x0, z1), (x1, z1)), ((x1, z1), (x1, z0)), ((x1, z0), (x0, z0)), ((x0, z0), (x0, z1))]:
        o.poly([(a[0], y, a[1]), (b[0], y, b[1]), apex])
    o.box("west_wall", "stone", (-24, 0, -20), (-23, 2.2, 1))
    o.box("west_wall_south", "stone", (-24, 0, 9), (-23, 2.2, 26))

    # The arcade on the south side: eight columns, a beam and a roof slab, and its back wall.
    for k in range(8):
        o.prism(f"arcade_column_{k}", "plaster_white", -12 + 3.8 * k, 18, 0.35, 0, 4.5)
    o.box("arcade_beam", "stone", (-12.6, 4.5, 17.5), (15.0, 5.1, 18.5), bottom=True)
    o.box("arcade_roof", "roof_tiles", (-13, 5.1, 17), (15.4, 5.5, 24), bottom=True)
    o.box("arcade_back_wall", "plaster_ochre", (-13, 0, 23.5), (15.4, 5.1, 24))

    # The fountain: an eight-sided basin with a column in the middle.
    o.prism("fountain_basin", "stone", 0, 0, 3.2, 0, 0.7, sides=8)
    o.prism("fountain_column", "stone", 0, 0, 0.4, 0.7, 3.0, sides=8)
    # Benches and bollards.
    for k, z in enumerate([-10, -5, 6, 11]):
        o.box(f"bench_{k}", "dark_wood", (9, 0.45, z - 1.0), (9.6, 0.55, z + 1.0), bottom=True)
        o.box(f"bench_leg_{k}", "stone", (9.1, 0, z - 0.2), (9.5, 0.45, z + 0.2))
    for k in range(10):
        o.prism(f"bollard_{k}", "stone", -14 + 3.2 * k, 14.5, 0.18, 0, 0.9, sides=6)
    o.write(out)


if __name__ == "__main__":
    main()
