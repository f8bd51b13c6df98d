#!/usr/bin/env python3
"""relight's images of the panel floor's three views against the path-traced reference
(benches/floor/reference/<view>.npy, 4,096 spp): relative RMSE of `fast` and `final`.

Usage: views.py SCENE_DIR [--relight BIN] [--cache DIR] [--quality fast,final] [--views ID,..]

SCENE_DIR is made by make_scene.py (baked into --cache first: `relight bake SCENE_DIR
--cache DIR`). Renders each view at the reference's size as PFM (linear radiance) and
prints, per view and quality, the relative RMSE over every pixel, the reference's own noise
on those pixels where its standard error is stored, the mean ratio, and the build time.
"""
import argparse
import json
import os
import sys
import subprocess
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pfm import read_pfm  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REF = os.path.join(HERE, "reference")


ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--relight", default="target/release/relight")
ap.add_argument("--cache", default=None)
ap.add_argument("--quality", default="fast,final")
ap.add_argument("--transfer", default="hierarchical", help="as the bake's (the floor fits no dense mode)")
ap.add_argument("--views", default="")
ap.add_argument("--out", default="/tmp/floor-views")
args = ap.parse_args()
os.makedirs(args.out, exist_ok=True)
cams = json.load(open(os.path.join(REF, "cameras.json")))
w, h = cams["width"], cams["height"]
views = [c["id"] for c in cams["cameras"]]
if args.views:
    views = [v for v in views if v in args.views.split(",")]
print(f"| view | quality | rel. RMSE | reference noise | mean ratio | time |")
print("|---|---|---|---|---|---|")
for v in views:
    ref = np.load(os.path.join(REF, f"{v}.npy")).astype(np.float64)
    se_path = os.path.join(REF, f"{v}_stderr.npy")
    se = np.load(se_path).astype(np.float64) if os.path.exists(se_path) else None
    for q in args.quality.split(","):
        out = os.path.join(args.out, f"{v}_{q}.pfm")
        cmd = [args.relight, "render", args.scene, "--camera", v, "--width", str(w), "--height", str(h),
               "--quality", q, "-o", out]
        if args.cache:
            cmd += ["--cache", args.cache]
        if args.transfer:
            cmd += ["--transfer", args.transfer]
        t0 = time.time()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        dt = time.time() - t0
        img = read_pfm(out)
        den = (ref ** 2).sum()
        rmse = np.sqrt(((img - ref) ** 2).sum() / den)
        noise = f"{np.sqrt((se ** 2).sum() / den):.2%}" if se is not None else "–"
        ratio = img.mean() / ref.mean()
        print(f"| {v} | {q} | {rmse:.2%} | {noise} | {ratio:.4f} | {dt:.1f} s |", flush=True)
