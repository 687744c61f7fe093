#!/usr/bin/env python3
"""Per-object error of `radiosity solve --json` against `radiosity pathtrace --json`.

    scripts/compare_objects.py SOLVE.json PATHTRACE.json [--worst N] [--sunlit-fraction F]
                               [--leave-out NAME ...]

Both files are the JSON those commands print for the same scene and lights file (see
docs/contract.md, `solve --json` and `pathtrace --json`). For each object the figure is the
relative error of its mean irradiance over the three channels, (H − H_pt) / H_pt; objects the
reference sees no light on (H_pt = 0) or with no exposed area are left out and counted. Printed:

- the area-weighted mean |relative error|, Σ A·|e| / Σ A, A the exposed area (the issue's
  "per object, area-weighted" figure), and the area-weighted relative L2 of docs/figures.md,
  √(Σ A·‖H − H_pt‖² / Σ A·‖H_pt‖²);
- the same mean split into sunlit and shaded objects: an object counts as sunlit when the
  reference's irradiance is above F (default 0.5) times the area-weighted median irradiance,
  so the split needs no knowledge of the lights;
- the reference's own noise: the area-weighted mean of stderr / H_pt per object, the floor
  under which no figure means anything;
- the N (default 15) objects with the largest area × |error|, and the N with the largest |error|.

With --json the figures are printed as one JSON object instead. Only the standard library.
"""

import argparse
import json
import math
import sys


def mean3(v):
    return (v[0] + v[1] + v[2]) / 3.0


def compare(solve, ref, sunlit_fraction=0.5, leave_out=()):
    by_name = {o["name"]: o for o in solve["objects"]}
    rows, skipped = [], []
    for o in ref["objects"]:
        s = by_name.get(o["name"])
        area = o.get("exposed_area", o["area"])
        h_pt = mean3(o["irradiance"])
        if s is None or area <= 0 or h_pt <= 0 or o["name"] in leave_out:
            skipped.append(o["name"])
            continue
        h = mean3(s["irradiance"])
        noise = mean3(o["stderr"]) / h_pt if "stderr" in o else float("nan")
        l2 = sum((a - b) ** 2 for a, b in zip(s["irradiance"], o["irradiance"]))
        ref2 = sum(b * b for b in o["irradiance"])
        rows.append(
            {"name": o["name"], "area": area, "h": h, "h_pt": h_pt, "err": (h - h_pt) / h_pt,
             "noise": noise, "l2": l2, "ref2": ref2}
        )
    if not rows:
        raise SystemExit("error: no object of the reference has light and exposed area")
    total = sum(r["area"] for r in rows)
    # The area-weighted median irradiance: the threshold between sunlit and shaded.
    acc, median = 0.0, rows[0]["h_pt"]
    for r in sorted(rows, key=lambda r: r["h_pt"]):
        acc += r["area"]
        if acc >= total / 2:
            median = r["h_pt"]
            break
    cut = sunlit_fraction * median

    def wmean(sel, key):
        a = sum(r["area"] for r in sel)
        return sum(r["area"] * abs(r[key]) for r in sel) / a if a > 0 else float("nan")

    sunlit = [r for r in rows if r["h_pt"] > cut]
    shaded = [r for r in rows if r["h_pt"] <= cut]
    return {
        "objects": len(rows),
        "skipped": len(skipped),
        "area_weighted_mean_abs_error": wmean(rows, "err"),
        "area_weighted_l2": math.sqrt(
            sum(r["area"] * r["l2"] for r in rows) / sum(r["area"] * r["ref2"] for r in rows)
        ),
        "sunlit": {"objects": len(sunlit), "area": sum(r["area"] for r in sunlit),
                   "mean_abs_error": wmean(sunlit, "err")},
        "shaded": {"objects": len(shaded), "area": sum(r["area"] for r in shaded),
                   "mean_abs_error": wmean(shaded, "err")},
        "reference_noise": wmean(rows, "noise"),
        "rows": rows,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("solve")
    ap.add_argument("pathtrace")
    ap.add_argument("--worst", type=int, default=15)
    ap.add_argument("--sunlit-fraction", type=float, default=0.5)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--leave-out", action="append", default=[], metavar="NAME",
                    help="an object to leave out (counted with the skipped), e.g. one the "
                         "reference all but never reaches; may be repeated")
    a = ap.parse_args()
    with open(a.solve) as f:
        solve = json.load(f)
    with open(a.pathtrace) as f:
        ref = json.load(f)
    c = compare(solve, ref, a.sunlit_fraction, set(a.leave_out))
    rows = c.pop("rows")
    if a.json:
        c["worst"] = [
            {k: r[k] for k in ("name", "area", "h", "h_pt", "err", "noise")}
            for r in sorted(rows, key=lambda r: -r["area"] * abs(r["err"]))[: a.worst]
        ]
        c["patches"] = solve.get("patches")
        json.dump(c, sys.stdout, indent=1)
        print()
        return
    print(f"patches {solve.get('patches')}: {c['objects']} objects ({c['skipped']} without light or asked left out)")
    print(f"area-weighted mean |error| {100 * c['area_weighted_mean_abs_error']:.2f}%, "
          f"area-weighted L2 {100 * c['area_weighted_l2']:.2f}%, "
          f"reference noise {100 * c['reference_noise']:.2f}%")
    for k in ("sunlit", "shaded"):
        s = c[k]
        print(f"  {k}: {s['objects']} objects, area {s['area']:.0f}, mean |error| {100 * s['mean_abs_error']:.2f}%")
    line = "    {:<28} area {:>10.2f}  H {:>10.3f}  ref {:>10.3f}  {:>+7.1f}%  (noise {:.1f}%)"
    print(f"  largest area x |error|:")
    for r in sorted(rows, key=lambda r: -r["area"] * abs(r["err"]))[: a.worst]:
        print(line.format(r["name"], r["area"], r["h"], r["h_pt"], 100 * r["err"], 100 * r["noise"]))
    print(f"  largest |error|:")
    for r in sorted(rows, key=lambda r: -abs(r["err"]))[: a.worst]:
        print(line.format(r["name"], r["area"], r["h"], r["h_pt"], 100 * r["err"], 100 * r["noise"]))


if __name__ == "__main__":
    main()
