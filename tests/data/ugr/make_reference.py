#!/usr/bin/env python3
"""Writes the UGR-table test luminaires and their reference tables (tests/data/ugr).

The EULUMDAT files are written here from analytic distributions, with LORL equal to the
flux their intensities integrate to (so no reader has to choose between the two); the IES
twin is made by `eulumdat-ies`. The reference tables come from an independent
implementation of CIE 190:2010, `eulumdat-ugr` (PyPI, MIT), at spacing 1 H (CIE 190) and
0.25 H (CIE 117 catalogues):

    python3 -m venv /tmp/ldt && /tmp/ldt/bin/pip install eulumdat-ugr eulumdat-ies
    /tmp/ldt/bin/python tests/data/ugr/make_reference.py

tests/it/ugr_table.rs compares `relight ugr-table` with the JSON written here.
"""
import json
import math
from pathlib import Path

from eulumdat_ies import ldt_to_ies
from eulumdat_ugr import UgrCalculator
from pyldt import LdtReader

HERE = Path(__file__).parent


def disk(c, g):
    """cd/klm of a Lambertian disk: I = I0 cos γ, Φ = π I0 = 1000 lm per klm."""
    return 1000.0 / math.pi * max(math.cos(math.radians(g)), 0.0)


def panel(c, g):
    """cd/klm (before normalising) of a linear panel: narrower across (C0) than along
    (C90), with a little uplight."""
    sc2 = math.sin(math.radians(c)) ** 2
    if g < 90:
        cg = math.cos(math.radians(g))
        return cg ** (2.0 - sc2) * (1.0 + 0.6 * sc2 * math.sin(math.radians(g)))
    return 0.08 * max(-math.cos(math.radians(g)), 0.0)


def flux(f, mc, ng):
    """∫ f dΩ in the file's units, fine midpoint rule."""
    n_g, n_c = 1800, 360
    total = 0.0
    for i in range(n_g):
        g = (i + 0.5) * 180.0 / n_g
        ring = sum(f((j + 0.5) * 360.0 / n_c, g) for j in range(n_c)) / n_c
        total += ring * 2 * math.pi * math.sin(math.radians(g)) * math.radians(180.0 / n_g)
    return total


def write_ldt(name, f, isym, mc, ng, lum_area, lamp_flux, lorl):
    dc, dg = 360.0 / mc, 180.0 / (ng - 1)
    c_all = [k * dc for k in range(mc)]
    g_all = [k * dg for k in range(ng)]
    stored = {1: range(1), 4: range(mc // 4 + 1)}[isym]
    lines = ["relight test", "1" if isym == 1 else "2", str(isym), str(mc), f"{dc:g}",
             str(ng), f"{dg:g}", "T-UGR", f"{name}", name, f"{name}.ldt", "2026-12-01",
             str(max(lum_area[0], 100) + 10), str(max(lum_area[1], 100) + 10), "60",
             str(lum_area[0]), str(lum_area[1]), "0", "0", "0", "0",
             f"{lorl['down']:.1f}", f"{lorl['total']:.1f}", "1", "0", "1", "1", "LED",
             f"{lamp_flux:g}", "4000", "80", "25"]
    lines += ["0.5"] * 10
    lines += [f"{c:g}" for c in c_all] + [f"{g:g}" for g in g_all]
    for k in stored:
        lines += [f"{f(c_all[k], g):.3f}" for g in g_all]
    path = HERE / f"{name}.ldt"
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")
    return path


def reference(path):
    ldt = LdtReader.read(path)
    out = {"source": "eulumdat-ugr 1.0.2 (CIE 190:2010), values[room][crosswise 5, endwise 5]"}
    for key, shr in (("spacing_1", 1.0), ("spacing_0.25", 0.25)):
        out[key] = [[float(v) for v in row] for row in UgrCalculator.compute(ldt, _shr=shr).values]
    (HERE / f"{path.stem}.eulumdat-ugr.json").write_text(json.dumps(out, indent=1) + "\n")


# A 200 mm Lambertian disk downlight, 2000 lm, all light downward (LORL 100 %).
reference(write_ldt("lambertian-disk", disk, 1, 1, 37, (200, 0), 2000, {"down": 100, "total": 100}))

# A 1190 × 290 mm linear panel, 3600 lm lamp, LOR 80 %, ~5 % of it upward: normalised so
# that its intensities integrate to exactly LORL.
raw = flux(panel, 24, 37)
up = flux(lambda c, g: panel(c, g) if g > 90 else 0.0, 24, 37)
scale = 800.0 / raw
norm = lambda c, g: panel(c, g) * scale
p = write_ldt("linear-panel", norm, 4, 24, 37, (1190, 290), 3600,
              {"down": 100 * (1 - up / raw), "total": 80})
reference(p)
ldt_to_ies(LdtReader.read(p), HERE / "linear-panel.ies")
