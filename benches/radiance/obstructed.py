#!/usr/bin/env python3
"""A side-lit room behind an exterior obstruction, relight against Radiance (rtrace -I).

The room: 6 m wide, 6 m deep, 3 m high; a 4 m × 1.5 m window (sill 0.9 m) in its south
wall; walls 0.5, ceiling 0.7, floor 0.2. Its outside is black (relight's walls are
one-sided; Radiance's are not, so the shell makes both see the same building). In front
of the window, 8 m away, a one-sided facade 30 m wide and 10 m high, ρ = 0.3, facing it.
Points at 0.85 m on the room's axis, 1.5 to 5.5 m from the window. Skies: CIE clear with
the sun at 40° due south (behind the facade) and at 25°, azimuth 135°, and CIE overcast,
with relight's sky semantics in Radiance (compare.py's `matched` variant).

Usage:
  python3 obstructed.py --relight target/release/relight [--quality mid] [--modes factored,columns,hierarchical]
Writes the table to stdout; WORK (default /tmp/relight-obstructed) keeps the scenes, the
Radiance files, the rtrace results and the relight cache.
"""
import argparse
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare as C  # noqa: E402

W, D, H = 6.0, 6.0, 3.0
DEPTHS = (1.5, 2.5, 3.5, 4.5, 5.5)
SKIES = {
    "clear, sun 40° S": {"type": "cie_clear", "horizontal_illuminance": 15000,
                         "direct_normal_illuminance": 70000,
                         "sun": {"altitude": 40, "azimuth": 180}},
    "clear, sun 25° SE": {"type": "cie_clear", "horizontal_illuminance": 15000,
                          "direct_normal_illuminance": 70000,
                          "sun": {"altitude": 25, "azimuth": 135}},
    "overcast": {"type": "cie_overcast", "horizontal_illuminance": 10000},
}


def quad(out, name, mat, p):
    out.append(f"o {name}\nusemtl {mat}\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in p)
               + "f -4 -3 -2 -1\n")


def write_scene(d, mode, facade=True):
    os.makedirs(d, exist_ok=True)
    o = ["mtllib s.mtl\n"]
    quad(o, "floor", "floor", [(0, 0, 0), (0, 0, D), (W, 0, D), (W, 0, 0)])
    quad(o, "ceiling", "ceiling", [(0, H, 0), (W, H, 0), (W, H, D), (0, H, D)])
    quad(o, "wall_west", "wall", [(0, 0, 0), (0, H, 0), (0, H, D), (0, 0, D)])
    quad(o, "wall_east", "wall", [(W, 0, 0), (W, 0, D), (W, H, D), (W, H, 0)])
    quad(o, "wall_north", "wall", [(0, 0, D), (0, H, D), (W, H, D), (W, 0, D)])
    for x0, x1, y0, y1 in [(0, W, 0, 0.9), (0, W, 2.4, H), (0, 1, 0.9, 2.4), (5, W, 0.9, 2.4)]:
        quad(o, "wall_south", "wall", [(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)])
    # The black outside, 1 cm off the room: roof, sides, back and the window wall's face.
    e = 0.01
    quad(o, "out_roof", "black", [(-e, H + e, -e), (-e, H + e, D + e), (W + e, H + e, D + e), (W + e, H + e, -e)])
    quad(o, "out_west", "black", [(-e, 0, -e), (-e, 0, D + e), (-e, H + e, D + e), (-e, H + e, -e)])
    quad(o, "out_east", "black", [(W + e, 0, -e), (W + e, H + e, -e), (W + e, H + e, D + e), (W + e, 0, D + e)])
    quad(o, "out_north", "black", [(-e, 0, D + e), (W + e, 0, D + e), (W + e, H + e, D + e), (-e, H + e, D + e)])
    for x0, x1, y0, y1 in [(-e, W + e, 0, 0.9), (-e, W + e, 2.4, H + e), (-e, 1, 0.9, 2.4), (5, W + e, 0.9, 2.4)]:
        quad(o, "out_south", "black", [(x0, y0, -e), (x0, y1, -e), (x1, y1, -e), (x1, y0, -e)])
    if facade:
        quad(o, "facade", "facade", [(-12, 0, -8), (18, 0, -8), (18, 10, -8), (-12, 10, -8)])
    open(os.path.join(d, "s.obj"), "w").write("".join(o))
    open(os.path.join(d, "s.mtl"), "w").write(
        "newmtl floor\nKd 0.2 0.2 0.2\nnewmtl ceiling\nKd 0.7 0.7 0.7\nnewmtl wall\nKd 0.5 0.5 0.5\n"
        "newmtl facade\nKd 0.3 0.3 0.3\nnewmtl black\nKd 0 0 0\n")
    open(os.path.join(d, "scene.toml"), "w").write(
        f'name = "Room behind a facade"\ntransfer = "{mode}"\n'
        "[site]\nlatitude = 49.49\nlongitude = 8.47\ntimezone = 1\nnorth = [0, 0, 1]\n"
        "ground_reflectance = 0.2\n[mesh]\nmax_edge = 0.35\n")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--relight", required=True)
    ap.add_argument("--work", default="/tmp/relight-obstructed")
    ap.add_argument("--quality", default="mid", choices=sorted(C.AMB))
    ap.add_argument("--modes", default="factored,columns,hierarchical")
    ap.add_argument("--port", type=int, default=18131)
    ap.add_argument("--no-facade", action="store_true")
    a = ap.parse_args(argv)
    env = C.radiance_env(None)
    modes = a.modes.split(",")
    tag = "open" if a.no_facade else "obstructed"
    scenes = os.path.join(a.work, "scenes")
    for m in modes:
        write_scene(os.path.join(scenes, f"{tag}-{m}"), m, facade=not a.no_facade)
    srv = subprocess.Popen([a.relight, "serve", "--scenes", scenes, "--cache",
                            os.path.join(a.work, "cache"), "--addr", f"127.0.0.1:{a.port}"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        rl = C.Relight(f"http://127.0.0.1:{a.port}")
        rl.wait_ready([f"{tag}-{m}" for m in modes])
        rad = os.path.join(a.work, "rad-" + tag)
        os.makedirs(rad, exist_ok=True)
        d0 = os.path.join(scenes, f"{tag}-{modes[0]}")
        frame = C.site_frame(C.read_toml(os.path.join(d0, "scene.toml")))
        open(os.path.join(rad, "scene.rad"), "w").write(C.obj_to_rad(d0, frame[:2]))
        open(os.path.join(rad, "sharp.cal"), "w").write(C.SHARP_CAL)
        pts = [(3.0, 0.85, z) for z in DEPTHS]
        rpts = [C.to_rad(p, frame[:2]) + (0.0, 0.0, 1.0) for p in pts]
        print(f"| sky | mode | " + " | ".join(f"{z} m" for z in DEPTHS) + " |")
        print("|---|---|" + "---|" * len(DEPTHS))
        for name, sky in SKIES.items():
            key = name.split(",")[0].replace(" ", "") + str(sky.get("sun", {}).get("altitude", ""))
            open(os.path.join(rad, f"sky-{key}.rad"), "w").write(C.sky_rad(sky, "matched", frame[2], env))
            C.oconv(f"{key}.oct", ["scene.rad", f"sky-{key}.rad"], env, rad)
            t0 = time.time()
            ref = C.rtrace_lux(f"{key}.oct", rpts, C.AMB[a.quality], env, rad)
            print(f"| {name} | Radiance ({a.quality}, {time.time() - t0:.0f} s) | "
                  + " | ".join(f"{v:.0f} lx" for v in ref) + " |")
            for m in modes:
                got, _ = C.relight_points(rl, f"{tag}-{m}", sky, pts, {})
                print(f"| {name} | relight {m} | "
                      + " | ".join(f"{100 * (g[0] / r - 1):+.1f} %" for g, r in zip(got, ref)) + " |")
            sys.stdout.flush()
    finally:
        srv.terminate()


if __name__ == "__main__":
    main()
