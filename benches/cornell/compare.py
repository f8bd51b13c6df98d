#!/usr/bin/env python3
"""A relight Cornell box image against the path-traced references: the 4,096-spp one in
tests/data (relative noise 1.2 %) and the 262,144-spp one in benches/cornell/reference
(0.15 %), so the error that is relight's own shows without the reference's noise.

Usage: compare.py IMAGE.pfm [--map OUT.png]

IMAGE: 256 × 256 linear radiance (`cargo run --release --example final_quality 512
OUT.pfm` writes one). Prints the relative RMSE (light left out) against both references,
the clean reference's own noise, the mean ratio per channel, and the share of the squared
difference in each region of the image. --map writes |relative difference| as a grey image
(white = 10 %), for looking at where the error sits.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pfm import read_pfm  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


ap = argparse.ArgumentParser()
ap.add_argument("image")
ap.add_argument("--map")
args = ap.parse_args()
img = read_pfm(args.image)
old = read_pfm(os.path.join(HERE, "..", "..", "tests", "data", "cornell_ref_white.pfm"))
new = np.load(os.path.join(HERE, "reference", "white.npy")).astype(np.float64)
se = np.load(os.path.join(HERE, "reference", "white_stderr.npy")).astype(np.float64)
keep = ~(old > 1.0).any(axis=2)


def rel_rmse(a, r, m):
    return float(np.sqrt(((a - r)[m] ** 2).sum() / (r[m] ** 2).sum()))


print(f"against tests/data (4,096 spp): {rel_rmse(img, old, keep):.4f}")
print(f"against the 262,144-spp reference: {rel_rmse(img, new, keep):.4f} "
      f"(its own noise {float(np.sqrt((se[keep] ** 2).sum() / (new[keep] ** 2).sum())):.4f})")
print("mean ratio per channel:", np.round(img[keep].mean(axis=0) / new[keep].mean(axis=0), 4))
sq = ((img - new) ** 2).sum(axis=2) * keep
total = sq.sum()
h, w = sq.shape
for name, (y0, y1, x0, x1) in {"top quarter": (0, h // 4, 0, w), "middle half": (h // 4, 3 * h // 4, 0, w),
                               "bottom quarter": (3 * h // 4, h, 0, w)}.items():
    print(f"  {name}: {sq[y0:y1, x0:x1].sum() / total:.1%} of the squared difference")
if args.map:
    from PIL import Image
    rel = np.abs(img - new).sum(axis=2) / np.maximum(new.sum(axis=2), 1e-6) * keep
    Image.fromarray((np.clip(rel / 0.1, 0, 1) * 255).astype(np.uint8)).save(args.map)
    print("map:", args.map)
