#!/usr/bin/env python3
"""Compares relight's per-surface illuminance on the panel floor with the path-traced
reference (benches/floor/reference.py).

Usage: compare.py SCENE_DIR [--reference benches/floor/reference/surfaces.json]
                  [--modes hierarchical,factored] [--relight target/release/relight]
                  [--cache DIR] [--min-area 1.0] [--json FILE] [--show N]

For each mode, runs `relight radiosity SCENE_DIR --json --transfer MODE` (bakes into the
cache on first use) and compares the area-weighted mean illuminance H of every
non-emitting surface of at least --min-area m² with the reference's, as luminous values
(Y = 0.2126 R + 0.7152 G + 0.0722 B). Prints the area-weighted mean |error|, the worst
surfaces, how many surfaces are off by 2 % or more, and the reference's own standard
error. A saved `relight radiosity --json` answer can stand in for a run: --answers
MODE=FILE.
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--reference", default=os.path.join(HERE, "reference", "surfaces.json"))
ap.add_argument("--modes", default="hierarchical")
ap.add_argument("--relight", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"),
                                                  "release", "relight"))
ap.add_argument("--cache", default=None)
ap.add_argument("--min-area", type=float, default=1.0)
ap.add_argument("--show", type=int, default=10)
ap.add_argument("--answers", action="append", default=[], help="MODE=FILE: a saved --json answer")
ap.add_argument("--json", default=None, help="write the per-surface errors here")
args = ap.parse_args()


def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


ref = json.load(open(args.reference))["surfaces"]
saved = dict(a.split("=", 1) for a in args.answers)
report = {}
for mode in [m for m in args.modes.split(",") if m]:
    if mode in saved:
        ans = json.load(open(saved[mode]))
    else:
        cmd = [args.relight, "radiosity", args.scene, "--json", "--transfer", mode]
        if args.cache:
            cmd += ["--cache", args.cache]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        ans = json.loads(out)
    rows = []
    for name, r in sorted(ref.items()):
        s = ans["surfaces"].get(name)
        if s is None:
            sys.exit(f"{mode}: relight has no surface {name}")
        if r["area"] < args.min_area or "panel" in name:
            continue
        e_ref, e = lum(r["irradiance"]), lum(s["illuminance"])
        se = lum(r["stderr"])
        rows.append((name, r["area"], e, e_ref, 100 * (e / e_ref - 1), 100 * se / e_ref))
    area = sum(x[1] for x in rows)
    mean = sum(x[1] * abs(x[4]) for x in rows) / area
    bias = sum(x[1] * x[4] for x in rows) / area
    worst = sorted(rows, key=lambda x: -abs(x[4]))
    over = [x for x in rows if abs(x[4]) >= 2.0]
    noise = sum(x[1] * x[5] for x in rows) / area
    print(f"{mode}: {len(rows)} surfaces of >= {args.min_area:g} m² ({area:.0f} m²): area-weighted "
          f"mean |error| {mean:.2f} % (signed {bias:+.2f} %), worst {abs(worst[0][4]):.2f} % "
          f"({worst[0][0]}), {len(over)} off by 2 % or more; reference standard error "
          f"{noise:.2f} % (area mean), {max(x[5] for x in rows):.2f} % (largest)")
    print(f"  {'surface':28s} {'m²':>7s} {'relight lx':>11s} {'reference':>11s} {'error %':>8s} {'ref se %':>8s}")
    for x in worst[:args.show]:
        print(f"  {x[0]:28s} {x[1]:7.2f} {x[2]:11.2f} {x[3]:11.2f} {x[4]:+8.2f} {x[5]:8.2f}")
    report[mode] = {"mean_abs_pct": mean, "signed_pct": bias, "worst_pct": abs(worst[0][4]),
                    "worst": worst[0][0], "over_2pct": len(over),
                    "surfaces": {x[0]: {"area": x[1], "relight": x[2], "reference": x[3],
                                        "error_pct": x[4], "ref_se_pct": x[5]} for x in rows}}
if args.json:
    json.dump(report, open(args.json, "w"), indent=1)
