#!/usr/bin/env python3
"""Compares `relight ugr-table` with eulumdat-ugr (PyPI, MIT), an independent
implementation of the CIE 190:2010 table, on the same EULUMDAT files.

    python3 -m venv /tmp/ldt && /tmp/ldt/bin/pip install eulumdat-ugr
    cargo build --release
    /tmp/ldt/bin/python benches/ugr/compare.py [--relight PATH] [--spacing 1 0.25] [FILE.ldt ...]

Without files it takes tests/data/ugr/*.ldt and tests/data/photometry/*.ldt. It prints,
per file and spacing, the largest |relight − eulumdat-ugr| crosswise and endwise, the cell
where it occurs, and the largest over everything; it exits 1 above --tolerance (0.5).
"""
import argparse
import glob
import json
import os
import subprocess
import sys

import numpy as np
from eulumdat_ugr import UgrCalculator
from pyldt import LdtReader

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
REFL = ["70/50/20", "70/30/20", "50/50/20", "50/30/20", "30/30/20"]


def default_relight():
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    for profile in ("release", "debug"):
        path = os.path.join(target, profile, "relight")
        if os.path.exists(path):
            return path
    sys.exit("no relight binary: build it (cargo build --release) or pass --relight")


def relight_table(binary, path, spacing):
    out = subprocess.run([binary, "ugr-table", path, "--format", "json", "--spacing", str(spacing)],
                         check=True, capture_output=True, text=True).stdout
    rooms = json.loads(out)["rooms"]
    return np.array([[np.nan if v is None else v for v in r["crosswise"] + r["endwise"]]
                     for r in rooms]), rooms


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--relight", default=None)
    ap.add_argument("--spacing", nargs="+", type=float, default=[1.0, 0.25])
    ap.add_argument("--tolerance", type=float, default=0.5)
    a = ap.parse_args()
    binary = a.relight or default_relight()
    files = a.files or sorted(glob.glob(os.path.join(ROOT, "tests/data/ugr/*.ldt"))
                              + glob.glob(os.path.join(ROOT, "tests/data/photometry/*.ldt")))
    worst = 0.0
    print(f"{'file':<28} {'S/H':>5} {'max |Δ| cross':>14} {'max |Δ| end':>12}  worst cell")
    for f in files:
        ldt = LdtReader.read(f)
        for s in a.spacing:
            theirs = UgrCalculator.compute(ldt, _shr=s).values
            ours, rooms = relight_table(binary, f, s)
            d = np.abs(ours - theirs)
            i, j = np.unravel_index(np.nanargmax(d), d.shape)
            where = (f"{rooms[i]['x']:g}Hx{rooms[i]['y']:g}H "
                     f"{'crosswise' if j < 5 else 'endwise'} {REFL[j % 5]}: "
                     f"relight {ours[i, j]:.2f}, eulumdat-ugr {theirs[i, j]:.2f}")
            print(f"{os.path.basename(f):<28} {s:>5g} {np.nanmax(d[:, :5]):>14.3f} "
                  f"{np.nanmax(d[:, 5:]):>12.3f}  {where}")
            worst = max(worst, float(np.nanmax(d)))
    print(f"largest difference: {worst:.3f} UGR units (tolerance {a.tolerance})")
    sys.exit(0 if worst <= a.tolerance else 1)


if __name__ == "__main__":
    main()
