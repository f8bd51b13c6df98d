#!/usr/bin/env python3
"""Writes the EULUMDAT test luminaires and their IES twins (tests/data/photometry).

The LDT files are written here from an analytic distribution; the IES twins are made by an
independent converter, `eulumdat-ies` (PyPI, reads with `eulumdat-py`), so the test
compares relight's two readers against a third party's idea of the same data:

    python3 -m venv /tmp/ldt && /tmp/ldt/bin/pip install eulumdat-py eulumdat-ies
    /tmp/ldt/bin/python tests/data/photometry/make_twins.py
"""
import math
from pathlib import Path

from eulumdat_ies import ldt_to_ies
from pyldt import LdtReader

HERE = Path(__file__).parent


def intensity(c, g):
    """cd/klm of a linear batwing-ish panel: wider across (C0) than along (C90), some
    asymmetry between C0 and C180, nothing above the horizon."""
    if g >= 90:
        return 0.0
    cg = math.cos(math.radians(g))
    sc = math.sin(math.radians(c))
    across = 1.0 - 0.35 * sc * sc * math.sin(math.radians(g))
    front = 1.0 + 0.15 * math.cos(math.radians(c)) * math.sin(math.radians(g))
    return 320.0 * cg ** 1.3 * across * front + 15.0 * math.sin(math.radians(2 * g))


def write_ldt(name, isym, mc, ng, lamps, flux, watts, dims):
    dc, dg = 360.0 / mc, 180.0 / (ng - 1)
    c_all = [k * dc for k in range(mc)]
    g_all = [k * dg for k in range(ng)]
    stored = {0: range(mc), 1: range(1), 2: range(mc // 2 + 1),
              3: range(mc // 4, mc // 4 + mc // 2 + 1), 4: range(mc // 4 + 1)}[isym]
    f = lambda c, g: intensity(c, g) if isym != 4 else intensity(min(c, 180 - c), g)
    lines = ["relight test", "1" if isym == 1 else "2", str(isym), str(mc), f"{dc:g}",
             str(ng), f"{dg:g}", "T-1", f"{name} panel", name, f"{name}.ldt", "2026-11-26",
             "1200", "300", "60", str(dims[0]), str(dims[1]), "0", "0", "0", "0",
             "100", "85", "1", "0", "1", str(lamps), "LED", f"{flux:g}", "4000", "80",
             f"{watts:g}"]
    lines += ["0.5"] * 10
    lines += [f"{c:g}" for c in c_all] + [f"{g:g}" for g in g_all]
    for k in stored:
        lines += [f"{f(c_all[k], g):.3f}".replace(".", ",") for g in g_all]
    path = HERE / f"{name}.ldt"
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")
    ldt_to_ies(LdtReader.read(path), HERE / f"{name}.ies")


# No symmetry, 15° planes, 5° steps: the general case, written with decimal commas.
write_ldt("panel-isym0", 0, 24, 37, 1, 4200, 36, (1190, 290))
# Symmetric to C0–C180 and to both planes; one lamp, so the twin's scaling matches.
write_ldt("panel-isym2", 2, 24, 37, 1, 3600, 30, (1190, 290))
write_ldt("panel-isym4", 4, 36, 19, 1, 3000, 25, (590, 590))
