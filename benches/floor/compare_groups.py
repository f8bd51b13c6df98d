#!/usr/bin/env python3
"""Compares relight's per-surface illuminance with the path-traced reference for every light
group of the grey panel floor on its own, and for mixed states (docs/accuracy.md, "Light
through openings: every group on its own").

Usage: compare_groups.py REFERENCE_DIR ANSWERS_DIR NAME [--min-area 1.0] [--show 8]
                         [--json FILE]

REFERENCE_DIR holds reference.py --groups-rgb runs (groups-A-B-C.json: group A in red, B in
green, C in blue, on a make_scene.py --grey floor). ANSWERS_DIR holds NAME.GROUP.json, the
`relight radiosity --json` answer of each group alone (that group at 1, every other at 0);
benches/floor/device_groups.sh writes both. Mixed states are weighted sums of the groups'
answers and references: both sides are linear in the groups' intensities.

For each state: every non-emitting surface of at least --min-area m², its luminous
illuminance (Y) against the reference's, the worst error, how many surfaces are off by 2 %
or more, and how many of those are also off by more than three of the reference's standard
errors (the ones the reference's noise cannot explain). The last columns split those by how
brightly the state lights the surface, against the state's area-mean illuminance M: lit
(>= 0.1 M), dim (0.001 M to 0.1 M: a room lit through one opening) and dark (< 0.001 M:
through two openings or more).
"""
import argparse
import glob
import json
import math
import os
import sys

ap = argparse.ArgumentParser()
ap.add_argument("reference")
ap.add_argument("answers")
ap.add_argument("name")
ap.add_argument("--min-area", type=float, default=1.0)
ap.add_argument("--show", type=int, default=8)
ap.add_argument("--json", default=None)
args = ap.parse_args()


def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


# ref[group][surface] = (area, irradiance, standard error): the run's channel of the group.
ref = {}
for path in sorted(glob.glob(os.path.join(args.reference, "groups-*.json"))):
    run = json.load(open(path))
    for ch, g in enumerate(run["groups_rgb"]):
        if g:
            ref[g] = {s: (r["area"], r["irradiance"][ch], r["stderr"][ch]) for s, r in run["surfaces"].items()}
groups = list(ref)
ans = {}
for g in groups:
    path = os.path.join(args.answers, f"{args.name}.{g}.json")
    if not os.path.exists(path):
        sys.exit(f"no answer {path}")
    ans[g] = json.load(open(path))

STATES = [(f"{g} alone", {g: 1.0}) for g in groups]
STATES += [
    ("all on", {g: 1.0 for g in groups}),
    ("south rooms off, corridor at 50 %", {**{g: 1.0 for g in groups if not g.startswith("s")}, "corridor": 0.5}),
    ("corridor off, n3 at 50 %", {**{g: 1.0 for g in groups if g != "corridor"}, "n3": 0.5}),
    ("only the corridor at 20 %", {"corridor": 0.2}),
]

report, total_over, total_real = {}, 0, 0
print(f"{args.name}: {len(groups)} groups; surfaces of >= {args.min_area:g} m² (panels left out)")
print(f"  {'state':36s} {'worst %':>8s} {'surface':24s} {'>=2 %':>6s} {'>3 se':>6s} {'mean |e| %':>10s} {'balance':>9s}"
      f"   past 2 % and 3 se: {'lit':>4s} {'dim':>4s} {'dark':>4s}   worst lit/dim")
for label, w in STATES:
    rows = []
    for s, (area, _, _) in ref[groups[0]].items():
        if area < args.min_area or "panel" in s:
            continue
        e_ref = sum(w[g] * ref[g][s][1] for g in w)
        se = math.sqrt(sum((w[g] * ref[g][s][2]) ** 2 for g in w))
        e = sum(w[g] * lum(ans[g]["surfaces"][s]["illuminance"]) for g in w)
        if e_ref <= 0:
            continue
        err = 100 * (e / e_ref - 1)
        rows.append((s, area, e, e_ref, err, 100 * se / e_ref))
    emitted = sum(w[g] * ans[g]["power"]["emitted_lm"] for g in w)
    gap = sum(w[g] * (ans[g]["power"]["emitted_lm"] - ans[g]["power"]["absorbed_lm"] - ans[g]["power"]["escaped_lm"])
              for g in w) / emitted
    area = sum(x[1] for x in rows)
    mean = sum(x[1] * abs(x[4]) for x in rows) / area
    worst = max(rows, key=lambda x: abs(x[4]))
    over = [x for x in rows if abs(x[4]) >= 2.0]
    real = [x for x in over if abs(x[4]) > 3 * x[5]]
    m = sum(x[1] * x[3] for x in rows) / area
    tier = lambda x: "lit" if x[3] >= 0.1 * m else "dim" if x[3] >= 1e-3 * m else "dark"
    tiers = {t: sum(1 for x in real if tier(x) == t) for t in ("lit", "dim", "dark")}
    lit_dim = [x for x in rows if tier(x) != "dark"]
    worst_ld = max(lit_dim, key=lambda x: abs(x[4]))
    total_over += len(over)
    total_real += len(real)
    print(f"  {label:36s} {worst[4]:+8.2f} {worst[0]:24s} {len(over):6d} {len(real):6d} {mean:10.2f} {gap:+9.1e}"
          f"   {'':18s} {tiers['lit']:4d} {tiers['dim']:4d} {tiers['dark']:4d}   {worst_ld[4]:+6.2f} {worst_ld[0]}")
    report[label] = {"worst_pct": worst[4], "worst": worst[0], "over_2pct": len(over),
                     "over_2pct_beyond_noise": len(real), "beyond_noise_by_tier": tiers, "mean_abs_pct": mean, "balance": gap,
                     "surfaces": {x[0]: {"area": x[1], "relight": x[2], "reference": x[3],
                                         "error_pct": x[4], "ref_se_pct": x[5]} for x in rows}}
print(f"  in all: {total_over} surface-states off by >= 2 %, {total_real} of them beyond 3 standard errors")
for label in [l for l, _ in STATES]:
    r = report[label]
    bad = sorted(r["surfaces"].items(), key=lambda kv: -abs(kv[1]["error_pct"]))[:args.show]
    if r["over_2pct"]:
        print(f"  {label}: " + ", ".join(f"{s} {v['error_pct']:+.1f}±{v['ref_se_pct']:.1f} % ({v['reference']:.3g} lx)"
                                         for s, v in bad if abs(v["error_pct"]) >= 2))
if args.json:
    json.dump(report, open(args.json, "w"), indent=1)
