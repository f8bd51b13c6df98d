#!/usr/bin/env python3
"""Writes office-floor.obj/.mtl, scene.toml, panel.ies and downlight.ies: one floor of an
office building, 30 m x 15 m, 3 m high, for a large (hierarchical) bake.

- A 2 m corridor runs along the floor's length (x); five rooms on each side open onto it
  through 0.9 m x 2.1 m door openings (holes in 0.1 m thick walls, with reveals and a
  threshold): eight offices (four desks, or two in the 4.4 m rooms, a sideboard and a tall
  cabinet each) and, on the north side, a 9 m meeting room with a long table, a credenza,
  a whiteboard and a terracotta accent wall.
- Structural columns (0.4 m, concrete) stand against the facade on a 7.5 m grid, and
  pilasters of the same grid stand out of both corridor walls.
- The floor is closed: floor and ceiling, exterior walls without windows. Every bit of
  light ends up absorbed, so the power balance can be checked (lumens in = absorbed).
- 74 point luminaires with IES distributions in 11 light groups: one per room, the
  corridor, and the meeting room with warm (3000 K) downlights.
- Work-plane grids at 0.8 m in three rooms (an office, the meeting room, a small office),
  two cameras (the corridor and the meeting room).

Metres, y up. Surfaces are one-sided: the front of every quad (counter-clockwise seen
from it) faces where light is received: room boxes face inward, furniture boxes outward.
A face that rests on another (a box's bottom on the floor, a cabinet's back on a wall, a
column's top at the ceiling, a desk panel's top under the desk top) is left out, and its
footprint is cut out of the face it rests on, which is built from rectangles around it
(as walls are around door openings). So no patch lies hidden inside a solid, no two
faces are coplanar and overlapping, and no box reaches into another or into a doorway;
the script checks all of this before writing.

Standard library only, deterministic. Run it from anywhere; it writes next to itself.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))

L, D, H = 30.0, 15.0, 3.0      # floor length (x), depth (z), storey height (y)
T = 0.1                        # interior wall thickness
CZ0, CZ1 = 6.5, 8.5            # corridor (clear), between its walls
SOUTH_Z = (0.0, CZ0 - T)       # clear depth of the south rooms (facade at z = 0)
NORTH_Z = (CZ1 + T, D)         # ... and of the north rooms (facade at z = 15)
DOOR_W, DOOR_H = 0.9, 2.1
MAX_EDGE = 0.34                # [mesh] max_edge: 177,222 patches (relight info)
LUM_Y = H - 0.05               # luminaires 5 cm below the ceiling
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


def box(surface, mat, x, y, z, omit=()):
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
                rect(surface, mat, axis, rng[axis][end], sign, rng[others[0]], rng[others[1]])


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
    walls = f"{rid}_walls"
    facade_z, corr_z = (z0, z1) if r["side"] == "S" else (z1, z0)
    wall(walls, "wall", "z", facade_z, +1 if r["side"] == "S" else -1, (x0, x1))
    wall(walls, "wall", "z", corr_z, -1 if r["side"] == "S" else +1, (x0, x1))
    door_cut(corr_z, r["door"])
    door_x = x1 if r["door_end"] == "E" else x0
    far_x = x0 if r["door_end"] == "E" else x1
    for xw in (far_x, door_x):
        which = "door_side" if xw == door_x else "far_side"
        mat = accent_walls.get((rid, which), "wall")
        wall(walls, mat, "x", xw, +1 if xw == x0 else -1, (z0, z1))

# Corridor: floor, ceiling, end walls (the east one a teal accent), both long walls with
# five door openings each.
rect("corridor_floor", "corridor_floor", "y", 0.0, +1, (0.0, L), (CZ0, CZ1))
rect("corridor_ceiling", "ceiling", "y", H, -1, (0.0, L), (CZ0, CZ1))
wall("corridor_walls", "wall", "x", 0.0, +1, (CZ0, CZ1))
wall("corridor_walls", "accent_teal", "x", L, -1, (CZ0, CZ1))
wall("corridor_walls", "wall", "z", CZ0, +1, (0.0, L))
wall("corridor_walls", "wall", "z", CZ1, -1, (0.0, L))
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
    box(surface, top_mat, xs, (h - t, h), zs)
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
        for sc in centres:
            for v in ((1.5, 2.3), (2.4, 3.2)):
                desk(f"{rid}_desks", r, (sc - 0.8, sc + 0.8), v)
        # A sideboard on the far wall, a tall cabinet on the corridor wall.
        side_len = 1.6 if r["kind"] == "office" else 1.2
        cabinet(f"{rid}_cabinets", r, (0.0, 0.45), (4.0, 4.0 + side_len), 1.2, "far")
        cabinet(f"{rid}_cabinets", r, (0.7, 1.7), (d - 0.45, d), 2.0, "corridor")
    else:
        # Meeting room: a 4.8 m x 1.4 m table (darker wood), a credenza and a whiteboard
        # on the far wall (the whiteboard hangs above the credenza, not touching it).
        desk(f"{rid}_table", r, (w / 2 - 2.4, w / 2 + 2.4), (2.5, 3.9), top_mat="table",
             t=0.04)
        cabinet(f"{rid}_cabinets", r, (0.0, 0.45), (2.0, 4.4), 0.8, "far")
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

PANEL_LM, SMALL_LM, MEETING_LM, CORRIDOR_LM = 4000, 3000, 3000, 2500
luminaires = []        # (id, group, position, ies, lumens, cct, efficacy)
groups = []            # (id, name)
for r in ROOMS:
    rid, w, d = r["id"], r["w"], r["d"]
    if r["kind"] == "meeting":
        cols, ies, lm, cct, eff = 4, "downlight.ies", MEETING_LM, 3000, 105.0
    elif r["kind"] == "small":
        cols, ies, lm, cct, eff = 2, "panel.ies", SMALL_LM, 4000, 125.0
    else:
        cols, ies, lm, cct, eff = 2, "panel.ies", PANEL_LM, 4000, 125.0
    rows = 3
    k = 0
    for j in range(rows):
        for i in range(cols):
            k += 1
            x = to_x(r, w * (2 * i + 1) / (2 * cols))
            z = to_z(r, d * (2 * j + 1) / (2 * rows))
            luminaires.append((f"{rid}_{k}", rid, (x, LUM_Y, z), ies, lm, cct, eff))
    label = {"meeting": "Meeting room", "small": "Office", "office": "Office"}[r["kind"]]
    what = "warm downlights" if r["kind"] == "meeting" else "LED panels"
    groups.append((rid, f"{label} {rid.upper()} ({k} × {lm} lm {what}, {cct} K)"))
n_corr = 8
for i in range(n_corr):
    x = L * (2 * i + 1) / (2 * n_corr)
    luminaires.append((f"corridor_{i + 1}", "corridor", (x, LUM_Y, (CZ0 + CZ1) / 2),
                       "downlight.ies", CORRIDOR_LM, 4000, 113.6))
groups.append(("corridor", f"Corridor ({n_corr} × {CORRIDOR_LM} lm downlights, 4000 K)"))

# Luminaires hang in a room's air, clear of every solid.
for lid, _, p, *_ in luminaires:
    for s in solids:
        if all(s[k][0] - 0.1 < p[k - 1] < s[k][1] + 0.1 for k in (1, 2, 3)):
            raise SystemExit(f"luminaire {lid} in or next to {s}")

# Work planes at 0.8 m, 0.5 m in from the walls, in three rooms.
grids = []
for rid, label in (("s2", "Office S2"), ("n3", "Meeting room N3"), ("n4", "Office N4")):
    r = next(r for r in ROOMS if r["id"] == rid)
    lo = (r["x"][0] + 0.5, r["z"][0] + 0.5)
    hi = (r["x"][1] - 0.5, r["z"][1] - 0.5)
    grids.append((rid, f"{label}: work plane at {GRID_H} m", lo, hi))
    # No grid point inside a solid taller than the work plane.
    for s in solids:
        if s[2][1] > GRID_H and overlap(s[1], (lo[0], hi[0])) and overlap(s[3], (lo[1], hi[1])):
            raise SystemExit(f"grid {rid} reaches into {s}")

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
used = {f[1] for f in faces}
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


with open(os.path.join(HERE, "office-floor.obj"), "w", newline="\n") as out:
    out.write("# Generated by make_scene.py: an office floor, 30 m x 15 m x 3 m, metres, y up.\n")
    out.write("# One-sided quads, counter-clockwise seen from the front (the lit side).\n")
    out.write("mtllib office-floor.mtl\n")
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

with open(os.path.join(HERE, "office-floor.mtl"), "w", newline="\n") as out:
    out.write("# Generated by make_scene.py. Kd = diffuse reflectance (linear RGB); no emitters:\n")
    out.write("# the light comes from the IES luminaires in scene.toml.\n")
    for name, kd, note in MATERIALS:
        out.write(f"# {note}\nnewmtl {name}\nKd {kd[0]:g} {kd[1]:g} {kd[2]:g}\n")


# IES LM-63 files. downlight.ies is the office scene's (rotationally symmetric cos^1.5,
# cut off between 80 and 90 degrees); panel.ies is a 600 x 600 LED panel with a
# microprismatic diffuser: quadrant-symmetric, cos^1.2 across (C0) to cos^1.6 along the
# prisms (C90), cut off between 75 and 90 degrees.
def write_ies(path, header, lumens, watts, size, h_angles, v_angles, cd):
    with open(path, "w", newline="\n") as out:
        out.write(header)
        out.write("TILT=NONE\n")
        out.write(f"1 {lumens:.0f} 1 {len(v_angles)} {len(h_angles)} 1 2 "
                  f"{size[0]:g} {size[1]:g} {size[2]:g}\n")
        out.write(f"1 1 {watts:g}\n")
        out.write(" ".join(f"{a:g}" for a in v_angles) + "\n")
        out.write(" ".join(f"{a:g}" for a in h_angles) + "\n")
        for h in h_angles:
            out.write(" ".join(f"{cd(v, h):.1f}" for v in v_angles) + "\n")


m, dl_lumens = 1.5, 2500.0
dl_i0 = dl_lumens * (m + 1) / (2 * math.pi)


def downlight_cd(g, _h):
    c = math.cos(math.radians(g)) ** m
    if g > 80:
        c *= (90 - g) / 10
    return dl_i0 * c


write_ies(os.path.join(HERE, "downlight.ies"),
          "IESNA:LM-63-2002\n[TEST] relight office scene\n[MANUFAC] relight (synthetic)\n"
          "[LUMCAT] DL-2500-840\n[LUMINAIRE] Recessed LED downlight, wide beam\n"
          "[LAMP] LED module 2500 lm, 4000 K\n",
          dl_lumens, 22, (0.2, 0.2, 0), [0], list(range(0, 91, 5)), downlight_cd)


def panel_shape(g, h):
    e = 1.2 + 0.4 * math.sin(math.radians(h)) ** 2
    c = math.cos(math.radians(g)) ** e
    if g > 75:
        c *= max(0.0, (90 - g) / 15)
    return c


# Normalise to 3600 lm: the flux of the shape, integrated finely over the sphere.
N = 360
flux_unit = 0.0
for i in range(N):
    g = (i + 0.5) * 90.0 / N
    for j in range(N):
        h = (j + 0.5) * 360.0 / N
        flux_unit += panel_shape(g, h) * math.sin(math.radians(g)) \
            * math.radians(90.0 / N) * math.radians(360.0 / N)
panel_lumens = 3600.0
panel_i0 = panel_lumens / flux_unit
write_ies(os.path.join(HERE, "panel.ies"),
          "IESNA:LM-63-2002\n[TEST] relight office-floor scene\n[MANUFAC] relight (synthetic)\n"
          "[LUMCAT] PNL-600-3600-840\n[LUMINAIRE] Recessed LED panel 600 x 600, microprismatic\n"
          "[LAMP] LED module 3600 lm, 4000 K\n",
          panel_lumens, 29, (0.6, 0.6, 0), [0, 22.5, 45, 67.5, 90], list(range(0, 91, 5)),
          lambda g, h: panel_i0 * panel_shape(g, h))

# scene.toml
total_lm = sum(l[4] for l in luminaires)
with open(os.path.join(HERE, "scene.toml"), "w", newline="\n") as out:
    w = out.write
    w("# One floor of an office building, 30 m x 15 m x 3 m: a corridor along its length,\n")
    w("# ten rooms (eight offices and a meeting room) opening onto it through door openings,\n")
    w("# desks, cabinets and structural columns. Closed: no windows, so all light is absorbed.\n")
    w(f"# {len(luminaires)} IES luminaires ({total_lm:,} lm) in {len(groups)} light groups:\n")
    w("# one per room, the corridor, and the meeting room with warm (3000 K) downlights.\n")
    w("# Generated by make_scene.py (with office-floor.obj/.mtl, panel.ies, downlight.ies);\n")
    w("# edit the script, not these files.\n")
    w('name = "Office floor"\n')
    w('units = "m"\n')
    w('transfer = "hierarchical"\n\n')
    w("[mesh]\n")
    w(f"max_edge = {MAX_EDGE}           # 177,222 patches (relight info)\n\n")
    for gid, gname in groups:
        w(f'[[lights]]\nid = "{gid}"\nname = "{gname}"\n\n')
    for lid, group, p, ies, lm, cct, eff in luminaires:
        w(f'[[luminaires]]\nid = "{lid}"\ngroup = "{group}"\n')
        w(f"position = [{p[0]:.3f}, {p[1]:.2f}, {p[2]:.3f}]\n")
        w(f'ies = "{ies}"\nlumens = {lm}\ncct = {cct}\nefficacy = {eff}\n\n')
    w(f"# Work planes at {GRID_H} m, 0.5 m in from the walls, 0.25 m grid.\n")
    for gid, gname, lo, hi in grids:
        w(f'[[grids]]\nid = "{gid}"\nname = "{gname}"\n')
        w(f"min = [{lo[0]:.2f}, {lo[1]:.2f}]\nmax = [{hi[0]:.2f}, {hi[1]:.2f}]\n")
        w(f"height = {GRID_H}\nspacing = 0.25\n\n")
    w("# Down the corridor from its west end, and the meeting room from beside its door.\n")
    w('[[cameras]]\nid = "corridor"\nposition = [0.6, 1.6, 7.5]\n'
      "target = [29.0, 1.2, 7.5]\nfov_deg = 55\n\n")
    n3 = next(r for r in ROOMS if r["id"] == "n3")
    w('[[cameras]]\nid = "meeting"\n'
      f"position = [{n3['x'][0] + 0.4:.2f}, 1.7, {n3['z'][0] + 0.4:.2f}]\n"
      f"target = [{(n3['x'][0] + n3['x'][1]) / 2 + 1.0:.2f}, 0.75, {to_z(n3, 3.2):.2f}]\n"
      "fov_deg = 65\n")

print(f"{len(faces)} quads in {len(order)} surfaces, {len(luminaires)} luminaires "
      f"({total_lm} lm) in {len(groups)} groups, {len(solids)} solids checked")
area = sum((f[5][1] - f[5][0]) * (f[6][1] - f[6][0]) for f in faces)
print(f"{area:.1f} m² of surface; max_edge {MAX_EDGE}")
