#!/usr/bin/env python3
"""Independent check of the alpha-coverage model (docs/decisions/alpha-coverage.md) with
Mitsuba 3 (`pip install mitsuba`): the scene of tests/tests/alpha_coverage.rs's BLEND case,
a 2 x 2 m floor (reflectance 0.5, facing up) under a 3 x 3 m sheet 0.5 m above it (reflectance
0.8, facing down, Mitsuba's `mask` BSDF at opacity 0.5), a sun straight down of irradiance 1.

Mitsuba's `irradiancemeter` cannot see a delta light from its own surface, so the sun's direct
term is added here: 0.5 on the floor (half passes the sheet), 0 on the sheet (its back faces
the sun). `volpath` is the integrator: its shadow rays pass null (masked) interactions, where
`path` stops at them.

    python3 scripts/mitsuba_alpha.py [samples]
"""
import sys

import mitsuba as mi

mi.set_variant("scalar_rgb")
from mitsuba import ScalarTransform4f as T  # noqa: E402

SPP = int(sys.argv[1]) if len(sys.argv) > 1 else 1 << 16


def meter():
    return {
        "type": "irradiancemeter",
        "film": {"type": "hdrfilm", "width": 1, "height": 1,
                 "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": SPP},
    }


def scene(measured):
    floor = {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90),
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5] * 3}}}
    sheet = {"type": "rectangle",
             "to_world": T().translate([0, 0.5, 0]) @ T().rotate([1, 0, 0], 90)
             @ T().scale([1.5, 1.5, 1]),
             "bsdf": {"type": "mask", "opacity": {"type": "rgb", "value": [0.5] * 3},
                      "bsdf": {"type": "diffuse",
                               "reflectance": {"type": "rgb", "value": [0.8] * 3}}}}
    (floor if measured == "floor" else sheet)["sensor"] = meter()
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 64},
        "sun": {"type": "directional", "direction": [0, -1, 0],
                "irradiance": {"type": "rgb", "value": [1.0] * 3}},
        "floor": floor,
        "sheet": sheet,
    })


for name, direct in [("floor", 0.5), ("sheet", 0.0)]:
    img = mi.render(scene(name), sensor=0)
    indirect = float(img.array[0])
    print(f"{name}: irradiance {direct + indirect:.4f} (bounced {indirect:.4f})")
