#!/usr/bin/env python3
"""Writes the three-room scene of the dark-room checks: rooms A, B and C in a row
(4 x 3 m each, 2.7 m high, 0.1 m walls), A and B joined by a door (0.9 x 2.1 m), B and C
by a glazed internal window (1.2 x 1.0 m, sill at 1.0 m). Each room has a desk and one
ceiling panel, its own light group (a, b, c), so a group alone lights the other rooms
only through the door and the window.

    python3 benches/doors/make_scene.py OUT_DIR [MAX_EDGE]

tests/data/three-rooms is this script's output at max_edge 0.5. The scene sets
`per_group_accuracy = true` (links dropped as hidden only where a wall proves it, in the
hierarchical mode); without that line it bakes as any scene does.
"""
import os
import sys

H = 2.7          # room height, m
D = 3.0          # room depth (z), m
W = 4.0          # room width (x), m
T = 0.1          # wall thickness, m
ROOMS = "abc"
DOOR = (1.0, 1.9, 0.0, 2.1)      # z0, z1, y0, y1 of the door in the A|B wall
WINDOW = (0.9, 2.1, 1.0, 2.0)    # z0, z1, y0, y1 of the window in the B|C wall

out = []          # OBJ lines
nv = [0]


def quad(name, mat, p):
    """A planar quad p[0..4] (counter-clockwise seen from its front)."""
    out.append(f"o {name}\nusemtl {mat}")
    for v in p:
        out.append("v %.4f %.4f %.4f" % v)
    k = nv[0]
    out.append(f"f {k + 1} {k + 2} {k + 3} {k + 4}")
    nv[0] += 4


def x_wall(name, mat, x, z0, z1, y0, y1, facing):
    """A wall in the plane x = const between z0..z1, y0..y1, facing +x (1) or -x (-1)."""
    if facing > 0:
        quad(name, mat, [(x, y0, z1), (x, y0, z0), (x, y1, z0), (x, y1, z1)])
    else:
        quad(name, mat, [(x, y0, z0), (x, y0, z1), (x, y1, z1), (x, y1, z0)])


def x_wall_with_hole(name, mat, x, hole, facing):
    """A full wall (z 0..D, y 0..H) at x with a rectangular hole (z0, z1, y0, y1)."""
    z0, z1, y0, y1 = hole
    x_wall(name, mat, x, 0.0, z0, 0.0, H, facing)
    x_wall(name, mat, x, z1, D, 0.0, H, facing)
    if y0 > 0.0:
        x_wall(name, mat, x, z0, z1, 0.0, y0, facing)
    x_wall(name, mat, x, z0, z1, y1, H, facing)


def reveal(name, mat, xa, xb, hole):
    """The faces inside a hole through a wall from x = xa to xb."""
    z0, z1, y0, y1 = hole
    # jambs: at z0 facing +z, at z1 facing -z
    quad(name, mat, [(xa, y0, z0), (xa, y1, z0), (xb, y1, z0), (xb, y0, z0)])
    quad(name, mat, [(xb, y0, z1), (xb, y1, z1), (xa, y1, z1), (xa, y0, z1)])
    # head, facing down
    quad(name, mat, [(xa, y1, z0), (xa, y1, z1), (xb, y1, z1), (xb, y1, z0)])
    # sill or threshold, facing up
    quad(name, mat, [(xa, y0, z0), (xb, y0, z0), (xb, y0, z1), (xa, y0, z1)])


def box(name, mat, lo, hi):
    """The five faces of a box standing on the floor, facing out (no underside)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    quad(name + "_top", mat, [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)])
    s = name + "_sides"
    quad(s, mat, [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)])
    quad(s, mat, [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)])
    quad(s, mat, [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)])
    quad(s, mat, [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)])


def room(i, r):
    x0 = i * (W + T)
    x1 = x0 + W
    quad(f"{r}_floor", "floor", [(x0, 0, 0), (x0, 0, D), (x1, 0, D), (x1, 0, 0)])
    quad(f"{r}_ceiling", "ceiling", [(x0, H, 0), (x1, H, 0), (x1, H, D), (x0, H, D)])
    quad(f"{r}_north", "wall", [(x0, 0, 0), (x1, 0, 0), (x1, H, 0), (x0, H, 0)])
    quad(f"{r}_south", "wall", [(x1, 0, D), (x0, 0, D), (x0, H, D), (x1, H, D)])
    holes = {"a": (None, DOOR), "b": (DOOR, WINDOW), "c": (WINDOW, None)}[r]
    west, east = holes
    if west is None:
        x_wall(f"{r}_west", "wall", x0, 0.0, D, 0.0, H, 1)
    else:
        x_wall_with_hole(f"{r}_west", "wall", x0, west, 1)
    if east is None:
        x_wall(f"{r}_east", "wall", x1, 0.0, D, 0.0, H, -1)
    else:
        x_wall_with_hole(f"{r}_east", "wall", x1, east, -1)
    box(f"{r}_desk", "desk", (x0 + 1.2, 0.0, 0.4), (x0 + 2.8, 0.75, 1.2))
    cx, cz = x0 + W / 2, D / 2 + 0.3
    y = H - 0.01
    quad(f"{r}_lamp", f"lamp_{r}",
         [(cx - 0.6, y, cz - 0.3), (cx + 0.6, y, cz - 0.3), (cx + 0.6, y, cz + 0.3), (cx - 0.6, y, cz + 0.3)])


def main():
    outdir = sys.argv[1]
    max_edge = float(sys.argv[2]) if len(sys.argv) > 2 else 0.3
    os.makedirs(outdir, exist_ok=True)
    for i, r in enumerate(ROOMS):
        room(i, r)
    reveal("door_reveal", "wall", W, W + T, DOOR)
    reveal("window_reveal", "wall", 2 * W + T, 2 * W + 2 * T, WINDOW)
    z0, z1, y0, y1 = WINDOW
    x_wall("window_pane", "glass", 2 * W + 1.5 * T, z0, z1, y0, y1, 1)
    with open(os.path.join(outdir, "scene.obj"), "w") as f:
        f.write("# three rooms joined by a door and a glazed window (benches/doors/make_scene.py)\n")
        f.write("mtllib scene.mtl\n" + "\n".join(out) + "\n")
    with open(os.path.join(outdir, "scene.mtl"), "w") as f:
        f.write("newmtl wall\nKd 0.7 0.7 0.7\nnewmtl ceiling\nKd 0.8 0.8 0.8\n"
                "newmtl floor\nKd 0.3 0.25 0.2\nnewmtl desk\nKd 0.5 0.4 0.3\n"
                "newmtl glass\nKd 0 0 0\n")
        for r in ROOMS:
            f.write(f"newmtl lamp_{r}\nKd 0 0 0\nKe 1000 1000 1000\n")
    with open(os.path.join(outdir, "scene.toml"), "w") as f:
        f.write('name = "Three rooms: a door and a glazed window"\n')
        # Each group right on its own (hierarchical mode); remove it to bake without.
        f.write("per_group_accuracy = true\n")
        f.write(f"[mesh]\nmax_edge = {max_edge}\n\n")
        f.write("[material.glass]\ntransmittance = 0.8\n\n")
        for r in ROOMS:
            f.write(f'[[lights]]\nid = "{r}"\nmaterials = ["lamp_{r}"]\nlumens = 3000\n\n')


main()
