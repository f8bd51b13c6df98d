#!/usr/bin/env python3
"""Writes a building-scale accuracy bench for the hierarchical mode (issue #27): one office
floor, 30 m x 14 m x 3 m, ten rooms off a 2 m corridor, lit by one-sided emissive 0.6 m
square ceiling panels (facing down, 5 cm below the ceiling, 2.2 m above the 0.75 m desk
tops) instead of IES luminaires.

Usage: make_scene.py OUT_DIR [MAX_EDGE] [--grey]   (default 0.25 m: about 244k patches)

--grey writes every material as the grey of its luminance (Y = 0.2126 R + 0.7152 G +
0.0722 B): then light of any colour is carried alike, and one path-traced run can carry
three light groups at once, one per colour channel (reference.py --groups-rgb).

Writes OUT_DIR/floor.obj, floor.mtl and scene.toml (and cameras.json, the three reference
views). Adapted from scenes/office-floor/make_scene.py (same construction rules: one-sided
quads, faces that rest on others cut out of them, checks before writing). Surfaces are
finer than there: every wall of a room, every desk top and every cabinet is its own
surface, so the per-surface comparison with the path tracer resolves them.

Metres, y up. Standard library only, deterministic.
"""
import json
import os
import sys

ARGS = [a for a in sys.argv[1:] if not a.startswith("--")]
GREY = "--grey" in sys.argv[1:]
if not ARGS:
    raise SystemExit(__doc__)
OUT = ARGS[0]
MAX_EDGE = float(ARGS[1]) if len(ARGS) > 1 else 0.25

L, D, H = 30.0, 14.0, 3.0      # floor length (x), depth (z), storey height (y)
T = 0.1                        # interior wall thickness
CZ0, CZ1 = 6.0, 8.0            # corridor (clear), between its walls
SOUTH_Z = (0.0, CZ0 - T)       # clear depth of the south rooms (facade at z = 0)
NORTH_Z = (CZ1 + T, D)         # ... and of the north rooms (facade at z = 15)
DOOR_W, DOOR_H = 0.9, 2.1
PANEL_Y = H - 0.05             # emissive panels 5 cm below the ceiling, facing down
PANEL = 0.6                    # panel side
PANEL_M = 10000.0              # panel exitance, lm/m² (3,600 lm per panel)
GRID_H = 0.8

# --------------------------------------------------------------------------- geometry
# Every face is an axis-aligned rectangle: (surface, material, axis, coordinate, sign,
# range along the first other axis, range along the second), the other axes in x, y, z
# order, the front facing `sign` along `axis`. Faces a box leaves out (its bottom on the
# floor, its back on a wall, ...) become cuts: the floor, wall or ceiling face behind them
# is built around them, so no patch lies hidden inside a solid (every ray from a front
# face meets a front face: the scene is closed, and no patch is wasted out of sight).

AX = {"x": 0, "y": 1, "z": 2}
faces = []
cuts = []                      # (axis, coordinate, sign of the left-out face or 0, r0, r1)


def rnd(r):
    return (round(r[0], 6), round(r[1], 6))


def rect(surface, mat, axis, c, sign, r0, r1):
    """An axis-aligned rectangle in the plane `axis` = c, front facing `sign` along the
    axis; r0, r1 are its ranges along the two other axes (in x, y, z order)."""
    assert r0[1] - r0[0] > 1e-9 and r1[1] - r1[0] > 1e-9, (surface, axis, c, r0, r1)
    faces.append((surface, mat, axis, round(c, 6), sign, rnd(r0), rnd(r1)))


def corners(axis, c, sign, r0, r1):
    """The four corners, counter-clockwise seen from the front."""
    a = AX[axis]
    others = [k for k in range(3) if k != a]
    pts = []
    for u, v in ((r0[0], r1[0]), (r0[1], r1[0]), (r0[1], r1[1]), (r0[0], r1[1])):
        p = [0.0, 0.0, 0.0]
        p[a], p[others[0]], p[others[1]] = c, u, v
        pts.append(p)
    e1 = [pts[1][i] - pts[0][i] for i in range(3)]
    e2 = [pts[2][i] - pts[0][i] for i in range(3)]
    n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
    if n[a] * sign < 0:
        pts.reverse()
    return pts


def box(surface, mat, x, y, z, omit=(), top=None):
    """An axis-aligned box x, y, z = (lo, hi), faces outward. `omit` names the faces that
    rest on the floor, a wall, the ceiling or another box ("-x", "+x", "-y", "+y", "-z",
    "+z"); each becomes a cut in the face it rests on."""
    rng = {"x": x, "y": y, "z": z}
    for axis in "xyz":
        others = [k for k in "xyz" if k != axis]
        for end, side in ((0, "-"), (1, "+")):
            sign = -1 if side == "-" else 1
            if side + axis in omit:
                cuts.append((axis, round(rng[axis][end], 6), sign, rnd(rng[others[0]]),
                             rnd(rng[others[1]])))
            else:
                name = top if (top and side + axis == "+y") else surface
                rect(name, mat, axis, rng[axis][end], sign, rng[others[0]], rng[others[1]])


def wall(surface, mat, axis, c, sign, span):
    """A full-height wall in the plane `axis` = c (x or z) over `span` along the other
    horizontal axis, facing `sign`. Door openings and the backs of cabinets and columns
    are cut out of it later."""
    if axis == "x":                      # plane x = c: ranges along y, z
        rect(surface, mat, "x", c, sign, (0.0, H), span)
    else:                                # plane z = c: ranges along x, y
        rect(surface, mat, "z", c, sign, span, (0.0, H))


def door_cut(z, x):
    """A door opening, 0.9 m x 2.1 m, in the wall plane z (both faces of the wall)."""
    cuts.append(("z", round(z, 6), 0, rnd(x), (0.0, DOOR_H)))


def subtract(r0, r1, holes, first):
    """The rectangle r0 x r1 minus the rectangles `holes`, as rectangles: the plane is cut
    into cells along every hole edge; free cells are joined into runs along axis `first`
    (0 or 1), and equal runs of neighbouring bands into rectangles."""
    rs = [r0, r1]
    hs = [((max(h[0][0], r0[0]), min(h[0][1], r0[1])), (max(h[1][0], r1[0]), min(h[1][1], r1[1])))
          for h in holes]
    hs = [h for h in hs if h[0][1] - h[0][0] > 1e-9 and h[1][1] - h[1][0] > 1e-9]
    coords = []
    for k in (0, 1):
        cs = {rs[k][0], rs[k][1]}
        for h in hs:
            cs.update(h[k])
        coords.append(sorted(cs))
    run_axis, band_axis = first, 1 - first

    def free(cell):
        mid = [(coords[k][cell[k]] + coords[k][cell[k] + 1]) / 2 for k in (0, 1)]
        return not any(h[0][0] < mid[0] < h[0][1] and h[1][0] < mid[1] < h[1][1] for h in hs)

    out, open_runs = [], {}
    nb = len(coords[band_axis]) - 1
    for b in range(nb + 1):
        runs = set()
        if b < nb:
            i, n = 0, len(coords[run_axis]) - 1
            while i < n:
                cell = [0, 0]
                cell[run_axis], cell[band_axis] = i, b
                if free(cell):
                    j = i
                    while j + 1 < n:
                        nxt = [0, 0]
                        nxt[run_axis], nxt[band_axis] = j + 1, b
                        if not free(nxt):
                            break
                        j += 1
                    runs.add((i, j + 1))
                    i = j + 1
                else:
                    i += 1
        for run in sorted(open_runs):
            if run not in runs:             # the run ends below band b: emit it
                r = [None, None]
                r[run_axis] = (coords[run_axis][run[0]], coords[run_axis][run[1]])
                r[band_axis] = (coords[band_axis][open_runs[run]], coords[band_axis][b])
                out.append((r[0], r[1]))
                del open_runs[run]
        for run in sorted(runs):
            open_runs.setdefault(run, b)
    return out


def apply_cuts():
    """Cut every cut out of the faces in its plane that face against it (or of all faces
    in its plane, for door openings); check that each left-out box face lies wholly on a
    face facing it, so that no box is open."""
    global faces
    for cut in cuts:
        if cut[2] == 0:
            continue
        area = (cut[3][1] - cut[3][0]) * (cut[4][1] - cut[4][0])
        covered = sum(max(0.0, min(f[5][1], cut[3][1]) - max(f[5][0], cut[3][0]))
                      * max(0.0, min(f[6][1], cut[4][1]) - max(f[6][0], cut[4][0]))
                      for f in faces if (f[2], f[3], f[4]) == (cut[0], cut[1], -cut[2]))
        if abs(covered - area) > 1e-9:
            raise SystemExit(f"left-out face not resting on a face: {cut} ({covered} of {area})")
    out = []
    for f in faces:
        holes = [(c[3], c[4]) for c in cuts
                 if (c[0], c[1]) == (f[2], f[3]) and c[2] in (0, -f[4])]
        if not holes:
            out.append(f)
            continue
        # Walls: vertical strips (runs along y); floors and ceilings: runs along x.
        first = {"x": 0, "z": 1, "y": 0}[f[2]]
        for r0, r1 in subtract(f[5], f[6], holes, first):
            out.append(f[:5] + (rnd(r0), rnd(r1)))
    faces = out


# ------------------------------------------------------------------------------ plan
# Partitions: centre lines of the walls between rooms, per side.
SOUTH_PARTS = [6.0, 12.0, 18.0, 24.0]
NORTH_PARTS = [6.0, 12.0, 21.0, 25.5]
COLUMNS_X = [7.5, 15.0, 22.5]           # the 7.5 m structural grid


def spans(parts):
    edges = [0.0] + parts + [L]
    out = []
    for i in range(len(edges) - 1):
        lo = edges[i] + (T / 2 if i > 0 else 0.0)
        hi = edges[i + 1] - (T / 2 if i + 1 < len(edges) - 1 else 0.0)
        out.append((round(lo, 6), round(hi, 6)))
    return out


# id, side, kind, door end ("E": door 1 m from the east partition, "W": from the west)
ROOMS = []
for i, ((x0, x1), door_end) in enumerate(zip(spans(SOUTH_PARTS), "EEEWW")):
    ROOMS.append(dict(id=f"s{i + 1}", side="S", x=(x0, x1), z=SOUTH_Z, door_end=door_end,
                      kind="office"))
for i, ((x0, x1), door_end) in enumerate(zip(spans(NORTH_PARTS), "EEWEW")):
    kind = {2: "meeting"}.get(i, "office")
    ROOMS.append(dict(id=f"n{i + 1}", side="N", x=(x0, x1), z=NORTH_Z, door_end=door_end,
                      kind=kind))
for r in ROOMS:
    r["w"] = r["x"][1] - r["x"][0]
    r["d"] = r["z"][1] - r["z"][0]
    if r["kind"] == "office" and r["w"] < 5.0:
        r["kind"] = "small"


def to_x(r, s):
    """Room-local s (metres from the wall away from the door) → world x."""
    return r["x"][0] + s if r["door_end"] == "E" else r["x"][1] - s


def to_z(r, v):
    """Room-local v (metres from the facade) → world z."""
    return r["z"][0] + v if r["side"] == "S" else r["z"][1] - v


def local_box(r, s, v):
    """World (x, z) ranges of a box given in room-local s, v ranges."""
    xs = sorted((to_x(r, s[0]), to_x(r, s[1])))
    zs = sorted((to_z(r, v[0]), to_z(r, v[1])))
    return (round(xs[0], 6), round(xs[1], 6)), (round(zs[0], 6), round(zs[1], 6))


def local_dir(r, axis, toward):
    """Face name ("-x", "+z", ...) of the side of a box toward the far wall (s = 0) or the
    facade (v = 0)."""
    if axis == "s":
        return "-x" if (r["door_end"] == "E") == (toward == 0) else "+x"
    return "-z" if (r["side"] == "S") == (toward == 0) else "+z"


solids = []        # (label, (x), (y), (z)) for overlap checks
for r in ROOMS:
    ds = r["w"] - 1.0                      # door centre, 1 m from the door-side partition
    cx = to_x(r, ds)
    r["door"] = (round(cx - DOOR_W / 2, 6), round(cx + DOOR_W / 2, 6))

# Rooms: floor, ceiling and walls facing inward; the corridor wall has the door opening.
accent_walls = {("n3", "door_side"): "accent_terracotta"}
for r in ROOMS:
    rid, (x0, x1), (z0, z1) = r["id"], r["x"], r["z"]
    rect(f"{rid}_floor", "carpet", "y", 0.0, +1, (x0, x1), (z0, z1))
    rect(f"{rid}_ceiling", "ceiling", "y", H, -1, (x0, x1), (z0, z1))
    facade_z, corr_z = (z0, z1) if r["side"] == "S" else (z1, z0)
    wall(f"{rid}_wall_facade", "wall", "z", facade_z, +1 if r["side"] == "S" else -1, (x0, x1))
    wall(f"{rid}_wall_corridor", "wall", "z", corr_z, -1 if r["side"] == "S" else +1, (x0, x1))
    door_cut(corr_z, r["door"])
    door_x = x1 if r["door_end"] == "E" else x0
    far_x = x0 if r["door_end"] == "E" else x1
    for xw in (far_x, door_x):
        which = "door_side" if xw == door_x else "far_side"
        mat = accent_walls.get((rid, which), "wall")
        wall(f"{rid}_wall_{which}", mat, "x", xw, +1 if xw == x0 else -1, (z0, z1))

# Corridor: floor, ceiling, end walls (the east one a teal accent), both long walls with
# five door openings each.
rect("corridor_floor", "corridor_floor", "y", 0.0, +1, (0.0, L), (CZ0, CZ1))
rect("corridor_ceiling", "ceiling", "y", H, -1, (0.0, L), (CZ0, CZ1))
wall("corridor_wall_west", "wall", "x", 0.0, +1, (CZ0, CZ1))
wall("corridor_wall_east", "accent_teal", "x", L, -1, (CZ0, CZ1))
wall("corridor_wall_south", "wall", "z", CZ0, +1, (0.0, L))
wall("corridor_wall_north", "wall", "z", CZ1, -1, (0.0, L))
for r in ROOMS:
    door_cut(CZ0 if r["side"] == "S" else CZ1, r["door"])

# Door openings through the 0.1 m walls: jambs and head (wall), threshold (corridor floor).
for r in ROOMS:
    d0, d1 = r["door"]
    wz = (CZ0 - T, CZ0) if r["side"] == "S" else (CZ1, CZ1 + T)
    rect("doors", "corridor_floor", "y", 0.0, +1, (d0, d1), wz)
    rect("doors", "wall", "y", DOOR_H, -1, (d0, d1), wz)
    rect("doors", "wall", "x", d0, +1, (0.0, DOOR_H), wz)
    rect("doors", "wall", "x", d1, -1, (0.0, DOOR_H), wz)

# Structural columns, 0.4 m: against the facades (back on the exterior wall) and as
# pilasters standing 0.3 m out of both corridor walls. Floor to ceiling.
for c in COLUMNS_X:
    xs = (c - 0.2, c + 0.2)
    for zs, back in (((0.0, 0.4), "-z"), ((D - 0.4, D), "+z"),
                     ((CZ0, CZ0 + 0.3), "-z"), ((CZ1 - 0.3, CZ1), "+z")):
        box("columns", "concrete", xs, (0.0, H), zs, omit=("-y", "+y", back))
        solids.append((f"column {c} {zs}", xs, (0.0, H), zs))


def desk(surface, r, s, v, top_mat="desk", h=0.75, t=0.03):
    """A desk: a top slab on two 3 cm end panels flush with its ends. The panels' tops are
    cut out of the slab's underside, their bottoms out of the floor."""
    (xs, zs) = local_box(r, s, v)
    box(surface, top_mat, xs, (h - t, h), zs, top=surface + "_top")
    solids.append((f"{surface} top", xs, (h - t, h), zs))
    long_x = (xs[1] - xs[0]) >= (zs[1] - zs[0])
    for end in (0, 1):
        if long_x:
            px, pz = ((xs[0], xs[0] + 0.03) if end == 0 else (xs[1] - 0.03, xs[1])), zs
        else:
            px, pz = xs, ((zs[0], zs[0] + 0.03) if end == 0 else (zs[1] - 0.03, zs[1]))
        px, pz = rnd(px), rnd(pz)
        box(surface, "desk_frame", px, (0.0, h - t), pz, omit=("-y", "+y"))
        solids.append((f"{surface} panel", px, (0.0, h - t), pz))


def cabinet(surface, r, s, v, h, against, mat="cabinet", y0=0.0):
    """A cabinet standing on the floor (or hung at y0) with its back on a wall: its back
    (and on the floor its bottom) is cut out of the wall (and the floor). `against` is
    "far" for the far wall (s = 0) or "corridor" for the corridor wall."""
    xs, zs = local_box(r, s, v)
    back = local_dir(r, "s", 0) if against == "far" else ("+z" if r["side"] == "S" else "-z")
    omit = (back,) + (("-y",) if y0 == 0.0 else ())
    box(surface, mat, xs, (y0, h), zs, omit=omit)
    solids.append((f"{surface} {mat}", xs, (y0, h), zs))


for r in ROOMS:
    rid, w, d = r["id"], r["w"], r["d"]
    if r["kind"] in ("office", "small"):
        # Desks 1.6 m x 0.8 m in facing pairs, 0.1 m apart, 1.5 m from the facade.
        centres = [w / 2 - 0.85, w / 2 + 0.85] if r["kind"] == "office" else [w / 2]
        k = 0
        for sc in centres:
            for v in ((1.5, 2.3), (2.4, 3.2)):
                k += 1
                desk(f"{rid}_desk{k}", r, (sc - 0.8, sc + 0.8), v)
        # A sideboard on the far wall, a tall cabinet on the corridor wall.
        side_len = 1.6 if r["kind"] == "office" else 1.2
        cabinet(f"{rid}_sideboard", r, (0.0, 0.45), (4.0, 4.0 + side_len), 1.2, "far")
        cabinet(f"{rid}_cabinet", r, (0.7, 1.7), (d - 0.45, d), 2.0, "corridor")
    else:
        # Meeting room: a 4.8 m x 1.4 m table (darker wood), a credenza and a whiteboard
        # on the far wall (the whiteboard hangs above the credenza, not touching it).
        desk(f"{rid}_table", r, (w / 2 - 2.4, w / 2 + 2.4), (2.5, 3.9), top_mat="table",
             t=0.04)
        cabinet(f"{rid}_credenza", r, (0.0, 0.45), (2.0, 4.4), 0.8, "far")
        cabinet(f"{rid}_whiteboard", r, (0.0, 0.02), (2.0, 4.4), 2.15, "far",
                mat="whiteboard", y0=0.95)

apply_cuts()

# ----------------------------------------------------------------------------- checks


def overlap(a, b, eps=1e-9):
    return a[0] < b[1] - eps and b[0] < a[1] - eps


# 1. No two coplanar faces overlap (whichever way they face).
planes = {}
for f in faces:
    planes.setdefault((f[2], f[3]), []).append(f)
for key, fs in planes.items():
    for i in range(len(fs)):
        for j in range(i + 1, len(fs)):
            if overlap(fs[i][5], fs[j][5]) and overlap(fs[i][6], fs[j][6]):
                raise SystemExit(f"coplanar overlap in plane {key}: {fs[i]} / {fs[j]}")

# 2. Solids (furniture, columns) do not reach into each other, stay inside their room or
#    the corridor, and keep doorways clear.
for i in range(len(solids)):
    for j in range(i + 1, len(solids)):
        a, b = solids[i], solids[j]
        if all(overlap(a[k], b[k]) for k in (1, 2, 3)):
            raise SystemExit(f"solids overlap: {a} / {b}")
spaces = [(r["x"], r["z"]) for r in ROOMS] + [((0.0, L), (CZ0, CZ1))]
for s in solids:
    inside = [sp for sp in spaces if sp[0][0] - 1e-9 <= s[1][0] and s[1][1] <= sp[0][1] + 1e-9
              and sp[1][0] - 1e-9 <= s[3][0] and s[3][1] <= sp[1][1] + 1e-9]
    assert inside, f"solid outside every room: {s}"
for r in ROOMS:
    # 1.2 m of clear floor behind each door opening, and the corridor in front of it.
    d0, d1 = r["door"]
    zc = (CZ0 - T - 1.2, CZ1) if r["side"] == "S" else (CZ0, CZ1 + T + 1.2)
    for s in solids:
        if overlap(s[1], (d0, d1)) and overlap(s[3], zc):
            raise SystemExit(f"door of {r['id']} blocked by {s}")

# --------------------------------------------------------------------------- lights

# Emissive panels: 0.6 m squares 5 cm below the ceiling, one-sided, facing down, in a
# grid per room (2 x 3 in offices, 4 x 3 in the meeting room) and 8 along the corridor.
# One surface and light group per room. They hang free: the ceiling above a panel sees
# its (black, blocking) back.
panels = []            # (surface, cx, cz)
groups = []            # (id, name, surface)
for r in ROOMS:
    rid, w, d = r["id"], r["w"], r["d"]
    cols = 4 if r["kind"] == "meeting" else 2
    rows = 3
    for j in range(rows):
        for i in range(cols):
            panels.append((f"{rid}_panels", to_x(r, w * (2 * i + 1) / (2 * cols)),
                           to_z(r, d * (2 * j + 1) / (2 * rows))))
    label = {"meeting": "Meeting room", "small": "Office", "office": "Office"}[r["kind"]]
    groups.append((rid, f"{label} {rid.upper()} ({cols * rows} panels)", f"{rid}_panels"))
n_corr = 8
for i in range(n_corr):
    panels.append(("corridor_panels", L * (2 * i + 1) / (2 * n_corr), (CZ0 + CZ1) / 2))
groups.append(("corridor", f"Corridor ({n_corr} panels)", "corridor_panels"))
for surface, cx, cz in panels:
    xs = (round(cx - PANEL / 2, 6), round(cx + PANEL / 2, 6))
    zs = (round(cz - PANEL / 2, 6), round(cz + PANEL / 2, 6))
    for s in solids:
        if s[2][1] > PANEL_Y - 0.1 and overlap(s[1], xs) and overlap(s[3], zs):
            raise SystemExit(f"panel at {cx}, {cz} in or next to {s}")
    rect(surface, "panel", "y", PANEL_Y, -1, xs, zs)

# ----------------------------------------------------------------------------- write

MATERIALS = [
    ("ceiling", (0.8, 0.8, 0.8), "ceiling tiles 0.8"),
    ("wall", (0.6, 0.6, 0.6), "painted walls 0.6"),
    ("carpet", (0.23, 0.25, 0.28), "blue-grey carpet 0.25"),
    ("corridor_floor", (0.32, 0.30, 0.27), "light stone 0.30"),
    ("desk", (0.55, 0.43, 0.30), "light oak 0.45"),
    ("desk_frame", (0.35, 0.35, 0.35), "grey desk panels 0.35"),
    ("table", (0.42, 0.28, 0.18), "walnut meeting table 0.30"),
    ("cabinet", (0.5, 0.5, 0.5), "cabinets 0.5"),
    ("concrete", (0.55, 0.55, 0.55), "concrete columns 0.55"),
    ("whiteboard", (0.85, 0.85, 0.85), "whiteboard 0.85"),
    ("accent_terracotta", (0.60, 0.30, 0.20), "accent wall, terracotta (Y 0.36)"),
    ("accent_teal", (0.25, 0.45, 0.45), "accent wall, teal (Y 0.41)"),
]
used = {f[1] for f in faces} - {"panel"}
assert used <= {m[0] for m in MATERIALS}, used

# Faces grouped by surface, surfaces in order of first appearance.
order, by_surface = [], {}
for f in faces:
    if f[0] not in by_surface:
        order.append(f[0])
        by_surface[f[0]] = []
    by_surface[f[0]].append(f)


def fmt(x):
    s = "%.4f" % x
    return "0.0000" if s == "-0.0000" else s


os.makedirs(OUT, exist_ok=True)
with open(os.path.join(OUT, "floor.obj"), "w", newline="\n") as out:
    out.write("# Generated by benches/floor/make_scene.py: an office floor, 30 m x 14 m x 3 m.\n")
    out.write("# One-sided quads, counter-clockwise seen from the front (the lit side).\n")
    out.write("mtllib floor.mtl\n")
    vi = 1
    for name in order:
        out.write(f"o {name}\n")
        mat = None
        for f in by_surface[name]:
            if f[1] != mat:
                out.write(f"usemtl {f[1]}\n")
                mat = f[1]
            for p in corners(f[2], f[3], f[4], f[5], f[6]):
                out.write("v %s %s %s\n" % tuple(fmt(c) for c in p))
            out.write(f"f {vi} {vi + 1} {vi + 2} {vi + 3}\n")
            vi += 4

with open(os.path.join(OUT, "floor.mtl"), "w", newline="\n") as out:
    out.write("# Generated by benches/floor/make_scene.py. Kd = diffuse reflectance (linear RGB),\n")
    out.write("# Ke = emitted exitance of the front (lm/m²).\n")
    for name, kd, note in MATERIALS:
        if GREY:
            y = round(0.2126 * kd[0] + 0.7152 * kd[1] + 0.0722 * kd[2], 4)
            kd, note = (y, y, y), f"{note}, as grey {y:g}"
        out.write(f"# {note}\nnewmtl {name}\nKd {kd[0]:g} {kd[1]:g} {kd[2]:g}\n")
    out.write(f"# 0.6 m LED panel, black diffuser, {PANEL_M * PANEL * PANEL:.0f} lm\n")
    out.write(f"newmtl panel\nKd 0 0 0\nKe {PANEL_M:g} {PANEL_M:g} {PANEL_M:g}\n")

# The three reference views (relight's convention: pinhole, vertical fov).
n3 = next(r for r in ROOMS if r["id"] == "n3")
s2 = next(r for r in ROOMS if r["id"] == "s2")
cameras = [
    dict(id="corridor", position=[0.6, 1.6, (CZ0 + CZ1) / 2], target=[29.0, 1.2, (CZ0 + CZ1) / 2],
         up=[0.0, 1.0, 0.0], fov_deg=55.0),
    dict(id="meeting", position=[round(n3["x"][0] + 0.4, 3), 1.7, round(n3["z"][0] + 0.4, 3)],
         target=[round((n3["x"][0] + n3["x"][1]) / 2 + 1.0, 3), 0.75, round(to_z(n3, 3.2), 3)],
         up=[0.0, 1.0, 0.0], fov_deg=65.0),
    dict(id="office", position=[round(to_x(s2, s2["w"] - 0.4), 3), 1.6, round(to_z(s2, s2["d"] - 0.4), 3)],
         target=[round(to_x(s2, s2["w"] / 2), 3), 0.75, round(to_z(s2, 2.35), 3)],
         up=[0.0, 1.0, 0.0], fov_deg=60.0),
]
with open(os.path.join(OUT, "scene.toml"), "w", newline="\n") as out:
    w = out.write
    w("# Generated by benches/floor/make_scene.py: a 30 m x 14 m office floor lit by\n")
    w(f"# {len(panels)} one-sided emissive 0.6 m panels in {len(groups)} light groups.\n")
    w('name = "Panel floor"\nunits = "m"\n\n')
    w(f"[mesh]\nmax_edge = {MAX_EDGE}\n\n")
    for gid, gname, surf in groups:
        w(f'[[lights]]\nid = "{gid}"\nname = "{gname}"\nsurfaces = ["{surf}"]\n\n')
    for c in cameras:
        w(f'[[cameras]]\nid = "{c["id"]}"\nposition = {c["position"]}\ntarget = {c["target"]}\n'
          f'up = {c["up"]}\nfov_deg = {c["fov_deg"]}\n\n')
with open(os.path.join(OUT, "cameras.json"), "w", newline="\n") as out:
    json.dump(cameras, out, indent=1)

print(f"{len(faces)} quads in {len(order)} surfaces, {len(panels)} panels "
      f"({len(panels) * PANEL_M * PANEL * PANEL:.0f} lm) in {len(groups)} groups, {len(solids)} solids checked")
area = sum((f[5][1] - f[5][0]) * (f[6][1] - f[6][0]) for f in faces)
print(f"{area:.1f} m² of surface; max_edge {MAX_EDGE}")
