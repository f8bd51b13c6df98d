#!/usr/bin/env python3
"""Compare relight's daylight answers with Radiance (rtrace -I), point by point.

Cases (see README.md in this folder):
  office-overcast        CIE overcast, 10,000 lx, daylight factors on the workplane grid
  office-black-overcast  the same with every Kd = 0 (direct sky + ground only)
  office-clear-180       CIE clear sky + sun at altitude 40°, azimuth 180° (south)
  office-clear-250       the same with the sun at azimuth 250°
  rooflight-overcast     CIE overcast on the rooflight hall's reference plane
  rooflight-clear        CIE clear sky + sun at altitude 55°, azimuth 200°, on the same points
  rooflight-black-clear  the same hall black (the sky's and the sun's direct light only)
  obstructed             a side-lit room behind a 30 × 10 m facade, three skies (obstructed.py;
                         needs --relight)
  office-transfer        relight's factored / columns / hierarchical transfers (no Radiance run)

The relight scenes are copied into a private folder (--work), with variants (black room,
transfer modes), and served by `relight serve` on a loopback port (or use --url for a server
that already serves such a folder). The OBJ geometry is converted to Radiance polygons with
the site's frame: Radiance X = east = north × up, Y = north, Z = up (relight's +y), a proper
rotation. Materials are `plastic` with Kd as RGB, no specularity (Radiance surfaces are
two-sided; these scenes are closed but for their openings, so no ray from inside can reach a
surface's back).

Two Radiance skies are used:
  stock    gensky exactly as shipped: `gensky -ang 45 0 -c -B H/179 -g ρg` (overcast),
           `gensky -ang ALT AZ-180 +s -B Hd/179 -R DNI·sin(ALT)/179 -g ρg` (clear), with
           `skyfunc glow` sources for sky and ground. Its skybright.cal blends sky and ground
           over about ±10° around the horizon, its sun is a 0.5° disc and its clear-sky
           normalisation is a polynomial fit.
  matched  relight's semantics exactly (sharp horizon, 0.533° sun, clear sky normalised to Hd
           by quadrature, ground luminance ρg·E_global/π), via sharp.cal written here.
Illuminance = 179 · (0.2126 R + 0.7152 G + 0.0722 B), the luma relight uses.

Usage:
  python3 compare.py --relight /work/main/target/debug/relight           # everything
  python3 compare.py --relight BIN --cases office-overcast --quick       # fast settings
  python3 compare.py --url http://127.0.0.1:18090 --work DIR ...         # a running server
Writes the tables to stdout and everything to WORK/results.json.
"""
import argparse
import json
import math
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import time
import urllib.error
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
LUMA = (0.2126, 0.7152, 0.0722)
EFFICACY = 179.0  # Radiance's white-light efficacy, lm/W
SUN_DEG = 0.533

# rtrace ambient settings: the reference, a finer check, and a quick one.
AMB = {
    "quick": "-ab 5 -ad 2048 -as 512 -aa 0.05 -ar 512 -lw 1e-4",
    "mid": "-ab 8 -ad 4096 -as 1024 -aa 0.05 -ar 512 -lw 1e-5",
    "ref": "-ab 7 -ad 8192 -as 2048 -aa 0.02 -ar 1024 -lw 1e-5",
    "fine": "-ab 8 -ad 16384 -as 4096 -aa 0.01 -ar 2048 -lw 2e-6",
}
# The black room: one bounce (sky and ground seen directly), no cache, many rays.
AMB_BLACK = "-ab 1 -aa 0 -ad 1048576 -as 0 -lw 1e-7"


# ----------------------------------------------------------------------------------------
# Radiance tools
# ----------------------------------------------------------------------------------------

def radiance_env(bindir):
    env = dict(os.environ)
    if bindir is None:
        try:
            import pyradiance  # noqa: F401

            root = os.path.dirname(pyradiance.__file__)
        except ImportError:
            import glob

            hits = glob.glob("/tmp/rad/lib/python3*/site-packages/pyradiance")
            root = hits[0] if hits else None
        if root:
            bindir = os.path.join(root, "bin")
            env["RAYPATH"] = ".:" + os.path.join(root, "lib")
    if bindir:
        env["PATH"] = bindir + os.pathsep + env["PATH"]
    return env


def run(cmd, env, inp=None, cwd=None):
    r = subprocess.run(cmd, input=inp, capture_output=True, text=True, env=env, cwd=cwd,
                       shell=isinstance(cmd, str))
    if r.returncode != 0:
        raise RuntimeError(f"{cmd}: {r.stderr.strip()}")
    return r.stdout


# ----------------------------------------------------------------------------------------
# Scene conversion: OBJ + MTL -> Radiance, in the site's frame
# ----------------------------------------------------------------------------------------

def read_toml(path):
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    with open(path, "rb") as f:
        return tomllib.load(f)


def site_frame(cfg):
    site = cfg.get("site", {})
    n = site.get("north", [0.0, 0.0, -1.0])
    ln = math.hypot(n[0], n[2])
    n = (n[0] / ln, 0.0, n[2] / ln)
    east = (-n[2], 0.0, n[0])  # north × up, up = +y
    return east, n, site.get("ground_reflectance", 0.2)


def to_rad(p, frame):
    east, north = frame
    return (p[0] * east[0] + p[2] * east[2], p[0] * north[0] + p[2] * north[2], p[1])


def read_mtl(path):
    mats, cur = {}, None
    for line in open(path):
        t = line.split()
        if not t or t[0].startswith("#"):
            continue
        if t[0] == "newmtl":
            cur = " ".join(t[1:])
            mats[cur] = (0.5, 0.5, 0.5)
        elif t[0] == "Kd" and cur is not None:
            kd = [float(x) for x in t[1:4]]
            m = max(kd)
            if m >= 1.0:
                kd = [x * 0.95 / m for x in kd]
            mats[cur] = tuple(kd)
    return mats


def obj_to_rad(scene_dir, frame, black=False):
    obj = [f for f in os.listdir(scene_dir) if f.endswith(".obj")][0]
    verts, mats, out, cur, nface = [], {}, [], "default", 0
    used = {}
    for line in open(os.path.join(scene_dir, obj)):
        t = line.split()
        if not t or t[0].startswith("#"):
            continue
        if t[0] == "mtllib":
            for m in t[1:]:
                mats.update(read_mtl(os.path.join(scene_dir, m)))
        elif t[0] == "v":
            verts.append(tuple(float(x) for x in t[1:4]))
        elif t[0] == "usemtl":
            cur = " ".join(t[1:])
        elif t[0] == "f":
            idx = []
            for s in t[1:]:
                i = int(s.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)
            name = "m_" + re.sub(r"[^A-Za-z0-9_]", "_", cur)
            used[name] = (0.0, 0.0, 0.0) if black else mats.get(cur, (0.5, 0.5, 0.5))
            pts = [to_rad(verts[i], frame) for i in idx]
            out.append(f"{name} polygon f{nface}\n0\n0\n{3 * len(pts)}\n" +
                       "\n".join(f"  {x:.6f} {y:.6f} {z:.6f}" for x, y, z in pts) + "\n")
            nface += 1
    head = "".join(f"void plastic {n}\n0\n0\n5 {r:.6g} {g:.6g} {b:.6g} 0 0\n"
                   for n, (r, g, b) in used.items())
    return head + "".join(out)


# ----------------------------------------------------------------------------------------
# Skies
# ----------------------------------------------------------------------------------------

SHARP_CAL = """{ relight's skies with a sharp horizon.
  A1: 1 CIE clear, 2 CIE overcast; A2: scale (W/sr/m2); A3: ground luminance;
  A4..A6: sun direction (clear sky) }
cosg = Dx*A4 + Dy*A5 + Dz*A6;
chi = Acos(max(-1, min(1, cosg)));
clr = A2 * (.91 + 10*exp(-3*chi) + .45*cosg*cosg) * (1 - exp(-.32/max(Dz, 1e-9)));
ovc = A2 * (1 + 2*Dz) / 3;
skyb = if(Dz, select(A1, clr, ovc), A3);
"""

GLOWS = """
skyfunc glow skyglow
0
0
4 1 1 1 0
skyglow source sky
0
0
4 0 0 1 180
skyfunc glow groundglow
0
0
4 1 1 1 0
groundglow source ground
0
0
4 0 0 -1 180
"""


def sun_dir(alt, az_north_cw):
    a, z = math.radians(alt), math.radians(az_north_cw)
    return (math.cos(a) * math.sin(z), math.cos(a) * math.cos(z), math.sin(a))


def clear_unit_integral(alt, az, na=360, nz=720):
    """∫ f(χ) φ(γ) sin γ dω for the clear sky with A2 = 1 (midpoint rule)."""
    s = sun_dir(alt, az)
    da, dz = (math.pi / 2) / na, 2 * math.pi / nz
    cz = [(math.cos((j + 0.5) * dz), math.sin((j + 0.5) * dz)) for j in range(nz)]
    total = 0.0
    for i in range(na):
        g = (i + 0.5) * da
        cg, sg = math.cos(g), math.sin(g)
        phi = 1 - math.exp(-0.32 / sg)
        ring = 0.0
        for cb, sb in cz:  # azimuth from north clockwise: east = sin, north = cos
            c = cg * sb * s[0] + cg * cb * s[1] + sg * s[2]
            c = max(-1.0, min(1.0, c))
            ring += 0.91 + 10 * math.exp(-3 * math.acos(c)) + 0.45 * c * c
        total += phi * sg * cg * da * dz * ring
    return total


def sky_rad(sky, variant, rho_g, env):
    """Radiance sky description for a relight sky (dict as in the API)."""
    if sky["type"] == "cie_overcast":
        h = sky["horizontal_illuminance"] / EFFICACY
        if variant == "stock":
            return run(f"gensky -ang 45 0 -c -B {h:.6g} -g {rho_g}", env) + GLOWS
        zen = h * 9 / (7 * math.pi)
        ground = rho_g * h / math.pi
        return (f"void brightfunc skyfunc\n2 skyb sharp.cal\n0\n6 2 {zen:.8g} {ground:.8g} 0 0 1\n"
                + GLOWS)
    if sky["type"] == "cie_clear":
        alt, az = sky["sun"]["altitude"], sky["sun"]["azimuth"]
        hd = sky["horizontal_illuminance"] / EFFICACY
        dn = sky["direct_normal_illuminance"] / EFFICACY
        dh = dn * math.sin(math.radians(alt))
        if variant == "stock":
            return run(f"gensky -ang {alt} {az - 180} +s -B {hd:.6g} -R {dh:.6g} -g {rho_g}",
                       env) + GLOWS
        s = sun_dir(alt, az)
        omega = 2 * math.pi * (1 - math.cos(math.radians(SUN_DEG / 2)))
        lsun = dn / omega
        a2 = hd / clear_unit_integral(alt, az)
        ground = rho_g * (hd + dh) / math.pi
        return (f"void light solar\n0\n0\n3 {lsun:.8g} {lsun:.8g} {lsun:.8g}\n"
                f"solar source sun\n0\n0\n4 {s[0]:.8f} {s[1]:.8f} {s[2]:.8f} {SUN_DEG}\n"
                f"void brightfunc skyfunc\n2 skyb sharp.cal\n0\n"
                f"6 1 {a2:.8g} {ground:.8g} {s[0]:.8f} {s[1]:.8f} {s[2]:.8f}\n" + GLOWS)
    raise ValueError(sky["type"])


RAD_INPUTS = {}  # octree -> the Radiance files it was built from (for the result cache)


def oconv(octree, inputs, env, cwd):
    run(f"oconv {' '.join(inputs)} > {octree}", env, cwd=cwd)
    RAD_INPUTS[octree] = list(inputs) + ["sharp.cal"]


def rtrace_lux(octree, pts, opts, env, cwd, cache=True):
    """pts: [(X, Y, Z, nx, ny, nz)] in Radiance coordinates -> lux. Results are kept in
    CWD/rtrace-cache, keyed by the octree's inputs, the options and the points."""
    import hashlib

    inp = "".join(" ".join(f"{v:.6f}" for v in p) + "\n" for p in pts)
    h = hashlib.sha256()
    for f in sorted(RAD_INPUTS.get(octree, [])):
        h.update(open(os.path.join(cwd, f), "rb").read())
    h.update(octree.encode() + opts.encode() + inp.encode())
    cdir = os.path.join(cwd, "rtrace-cache")
    cfile = os.path.join(cdir, h.hexdigest()[:24] + ".txt")
    if cache and RAD_INPUTS.get(octree) and os.path.exists(cfile):
        out = open(cfile).read()
    else:
        out = run(f"rtrace -n 1 -h -I {opts} {octree}", env, inp=inp, cwd=cwd)
        os.makedirs(cdir, exist_ok=True)
        open(cfile, "w").write(out)
    vals = []
    for line in out.strip().splitlines():
        r, g, b = (float(x) for x in line.split()[:3])
        vals.append(EFFICACY * (LUMA[0] * r + LUMA[1] * g + LUMA[2] * b))
    assert len(vals) == len(pts), (len(vals), len(pts))
    return vals


# ----------------------------------------------------------------------------------------
# relight
# ----------------------------------------------------------------------------------------

class Relight:
    def __init__(self, url):
        self.url = url.rstrip("/")

    def req(self, method, path, body=None, timeout=600):
        data = None if body is None else json.dumps(body).encode()
        r = urllib.request.Request(self.url + path, data=data, method=method,
                                   headers={"content-type": "application/json"} if data else {})
        with urllib.request.urlopen(r, timeout=timeout) as resp:
            return json.loads(resp.read())

    def wait_ready(self, ids, timeout=3600):
        t0 = time.time()
        while True:
            try:
                scenes = self.req("GET", "/api/scenes")
                if isinstance(scenes, dict):
                    scenes = scenes.get("scenes", scenes)
                st = {s["id"]: s.get("status") for s in scenes}
                if all(st.get(i) == "ready" for i in ids):
                    return
                bad = [i for i in ids if st.get(i) == "failed"]
                if bad:
                    raise RuntimeError(f"scenes failed: {bad}: {scenes}")
            except (urllib.error.URLError, ConnectionError):
                pass
            if time.time() - t0 > timeout:
                raise TimeoutError("relight scenes not ready")
            time.sleep(2)

    def daylight(self, scene, body):
        for _ in range(100):
            try:
                return self.req("POST", f"/api/scenes/{scene}/daylight", body)
            except urllib.error.HTTPError as e:
                if e.code == 503:
                    time.sleep(2)
                    continue
                raise RuntimeError(f"{e.code}: {e.read().decode()[:500]}")
        raise RuntimeError("server busy")


def prepare_scenes(src_root, dst):
    """Copies of office and rooflight, black variants of both and transfer-mode variants."""
    os.makedirs(dst, exist_ok=True)
    made = {}
    for name in ("office", "rooflight"):
        d = os.path.join(dst, name)
        if not os.path.isdir(d):
            shutil.copytree(os.path.join(src_root, name), d)
        made[name] = d
    # the black office and hall: every Kd = 0
    for name in ("office", "rooflight"):
        d = os.path.join(dst, f"{name}-black")
        if not os.path.isdir(d):
            shutil.copytree(os.path.join(src_root, name), d)
            for mtl in [f for f in os.listdir(d) if f.endswith(".mtl")]:
                mtl = os.path.join(d, mtl)
                txt = re.sub(r"^Kd .*$", "Kd 0 0 0", open(mtl).read(), flags=re.M)
                open(mtl, "w").write(txt)
        made[f"{name}-black"] = d
    for mode in ("factored", "hierarchical"):
        d = os.path.join(dst, f"office-{mode}")
        if not os.path.isdir(d):
            shutil.copytree(os.path.join(src_root, "office"), d)
            toml = os.path.join(d, "scene.toml")
            txt = re.sub(r'^transfer = .*$', f'transfer = "{mode}"', open(toml).read(),
                         flags=re.M)
            open(toml, "w").write(txt)
        made[f"office-{mode}"] = d
    return made


def grid_positions(rl, scene, grid, lights, scene_dir):
    """The grid's points: cell centres of [min, max] in the answer's layout, at `height`
    above the floor (the model's lowest point), as relight places them."""
    ans = rl.daylight(scene, {"sky": {"type": "cie_overcast", "horizontal_illuminance": 10000},
                              "grids": [grid], "lights": lights})
    nx, nz = ans["grids"][grid]["illuminance"]["layout"]
    g = [x for x in read_toml(os.path.join(scene_dir, "scene.toml"))["grids"] if x["id"] == grid][0]
    obj = [f for f in os.listdir(scene_dir) if f.endswith(".obj")][0]
    floor = min(float(l.split()[2]) for l in open(os.path.join(scene_dir, obj)) if l.startswith("v "))
    (x0, z0), (x1, z1) = g["min"], g["max"]
    y = floor + g["height"]
    pts = [(x0 + (i + 0.5) * (x1 - x0) / nx, y, z0 + (j + 0.5) * (z1 - z0) / nz)
           for j in range(nz) for i in range(nx)]
    return pts, ans["grids"][grid]["daylight_factor"]["values"]


def pick(points, nx, nz):
    """About nx × nz points spread over a rectangular grid of points (x, y, z)."""
    xs = sorted({round(p[0], 6) for p in points})
    zs = sorted({round(p[2], 6) for p in points})

    def spread(v, n):
        if len(v) <= n:
            return v
        return [v[round(i * (len(v) - 1) / (n - 1))] for i in range(n)]

    keep = {(x, z) for x in spread(xs, nx) for z in spread(zs, nz)}
    return [p for p in points if (round(p[0], 6), round(p[2], 6)) in keep]


def relight_points(rl, scene, sky, pts, lights):
    ans = rl.daylight(scene, {"sky": sky, "lights": lights,
                              "points": [{"position": list(p), "normal": [0, 1, 0]} for p in pts]})
    return [(q["lux"], q.get("daylight_factor")) for q in ans["points"]], ans


# ----------------------------------------------------------------------------------------

def table(title, rows, df):
    unit = "DF %" if df else "lux"
    print(f"\n### {title}\n")
    cols = [k for k in rows[0] if k not in ("x", "y", "z")]
    print("| x | z | " + " | ".join(cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    for r in rows:
        cells = []
        for k in cols:
            v = r[k]
            cells.append(f"{v:+.2f}" if k.startswith("Δ") else (f"{v:.3f}" if df else f"{v:.0f}"))
        print(f"| {r['x']:.3f} | {r['z']:.3f} | " + " | ".join(cells) + " |")
    summ = {}
    for k in cols:
        if k.startswith("Δ"):
            a = [abs(r[k]) for r in rows]
            s = [r[k] for r in rows]
            summ[k] = {"mean_abs": statistics.mean(a), "max_abs": max(a), "mean": statistics.mean(s)}
            print(f"\n{k}: mean {statistics.mean(s):+.2f} %, mean |Δ| {statistics.mean(a):.2f} %,"
                  f" max |Δ| {max(a):.2f} %  ({unit})")
    return summ


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--relight", help="relight binary: start `relight serve` on --port")
    ap.add_argument("--url", help="a running relight server serving WORK/scenes")
    ap.add_argument("--port", type=int, default=18090)
    ap.add_argument("--work", default="/tmp/radcmp")
    ap.add_argument("--radiance-bin", help="folder of Radiance binaries (default: pyradiance's)")
    ap.add_argument("--cases", default="office-overcast,office-black-overcast,office-clear-180,"
                    "office-clear-250,rooflight-overcast,rooflight-clear,rooflight-black-clear,"
                    "office-transfer")
    ap.add_argument("--quality", default="ref", choices=list(AMB))
    ap.add_argument("--check", action="store_true",
                    help="also run the 'fine' settings on the overcast cases (stability)")
    ap.add_argument("--variants", default="stock,matched")
    ap.add_argument("--office-grid", default="6x5", help="points picked from the workplane, NXxNZ")
    ap.add_argument("--rooflight-grid", default="5x5")
    args = ap.parse_args()

    env = radiance_env(args.radiance_bin)
    work = os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    open(os.path.join(work, "sharp.cal"), "w").write(SHARP_CAL)
    dirs = prepare_scenes(os.path.join(REPO, "scenes"), os.path.join(work, "scenes"))
    cases = args.cases.split(",")
    variants = args.variants.split(",")

    server = None
    if args.relight:
        log = open(os.path.join(work, "relight.log"), "w")
        server = subprocess.Popen(
            [args.relight, "serve", "--addr", f"127.0.0.1:{args.port}",
             "--scenes", os.path.join(work, "scenes"), "--cache", os.path.join(work, "cache")],
            stdout=log, stderr=subprocess.STDOUT)
        url = f"http://127.0.0.1:{args.port}"
    else:
        url = args.url
    rl = Relight(url)
    rfile = os.path.join(work, "results.json")
    results = {"radiance": {"settings": AMB, "black": AMB_BLACK}, "cases": {}}
    if os.path.exists(rfile):  # results of earlier runs are kept, cases rerun replaced
        results["cases"] = json.load(open(rfile)).get("cases", {})
    try:
        need = ["office", "rooflight"]
        if "office-black-overcast" in cases:
            need.append("office-black")
        if "rooflight-black-clear" in cases:
            need.append("rooflight-black")
        if "office-transfer" in cases:
            need += ["office-factored", "office-hierarchical"]
        rl.wait_ready(need)

        off_lights = {"window_row": 0, "corridor_row": 0}
        nx, nz = (int(v) for v in args.office_grid.split("x"))
        wp, _ = grid_positions(rl, "office", "workplane", off_lights, dirs["office"])
        office_pts = pick(wp, nx, nz)
        nx, nz = (int(v) for v in args.rooflight_grid.split("x"))
        fl, fl_df = grid_positions(rl, "rooflight", "floor", {}, dirs["rooflight"])
        # leave out points inside solids (the counter): relight answers null there
        roof_pts = [p for p in pick(fl, nx, nz) if (fl_df[fl.index(p)] or 0) > 0]

        overcast = {"type": "cie_overcast", "horizontal_illuminance": 10000}

        def clear(az, alt=40):
            return {"type": "cie_clear", "horizontal_illuminance": 15000,
                    "direct_normal_illuminance": 70000, "sun": {"altitude": alt, "azimuth": az}}

        specs = {
            "office-overcast": ("office", "office", False, overcast, office_pts, off_lights),
            "office-black-overcast": ("office-black", "office", True, overcast, office_pts,
                                      off_lights),
            "office-clear-180": ("office", "office", False, clear(180), office_pts, off_lights),
            "office-clear-250": ("office", "office", False, clear(250), office_pts, off_lights),
            "rooflight-overcast": ("rooflight", "rooflight", False, overcast, roof_pts, {}),
            "rooflight-clear": ("rooflight", "rooflight", False, clear(200, 55), roof_pts, {}),
            "rooflight-black-clear": ("rooflight-black", "rooflight", True, clear(200, 55),
                                      roof_pts, {}),
        }
        octs = {}
        for case in cases:
            if case == "office-transfer":
                continue
            if case == "obstructed":
                if not args.relight:
                    sys.exit("the obstructed case starts its own server: give --relight")
                import obstructed  # its own scenes, server and table
                obstructed.main(["--relight", args.relight, "--quality", args.quality,
                                 "--work", os.path.join(work, "obstructed")])
                continue
            scene, geo, black, sky, pts, lights = specs[case]
            df = sky["type"] == "cie_overcast"
            cfg = read_toml(os.path.join(dirs[geo], "scene.toml"))
            east, north, rho_g = site_frame(cfg)
            t0 = time.time()
            rel, ans = relight_points(rl, scene, sky, pts, lights)
            t_rel = time.time() - t0
            key = (geo, black)
            if key not in octs:
                path = os.path.join(work, f"{geo}{'-black' if black else ''}.rad")
                open(path, "w").write(obj_to_rad(dirs[geo], (east, north), black))
                octs[key] = path
            rpts = [to_rad(p, (east, north)) + (0.0, 0.0, 1.0) for p in pts]
            rows = [{"x": p[0], "y": p[1], "z": p[2],
                     "relight": (r[1] if df else r[0])} for p, r in zip(pts, rel)]
            timing = {"relight_s": t_rel}
            for v in variants:
                skyf = os.path.join(work, f"sky-{case}-{v}.rad")
                open(skyf, "w").write(sky_rad(sky, v, rho_g, env))
                octf = os.path.join(work, f"{case}-{v}.oct")
                oconv(octf, [skyf, octs[key]], env, work)
                quals = ["black"] if black else [args.quality] + (
                    ["fine"] if args.check and df else [])
                for q in quals:
                    opts = AMB_BLACK if q == "black" else AMB[q]
                    t0 = time.time()
                    lux = rtrace_lux(octf, rpts, opts, env, work)
                    timing[f"radiance_{v}_{q}_s"] = time.time() - t0
                    col = f"rad_{v}" + ("" if q in (args.quality, "black") else f"_{q}")
                    for row, e in zip(rows, lux):
                        row[col] = 100 * e / sky["horizontal_illuminance"] if df else e
            for row in rows:
                for k in [k for k in row if k.startswith("rad_")]:
                    row[f"Δ {k[4:]} %"] = 100 * (row["relight"] / row[k] - 1)
            # unobstructed check of the sky model: E on an upward and a downward receiver
            sanity = {}
            for v in variants:
                skyf = os.path.join(work, f"sky-{case}-{v}.rad")
                octf = os.path.join(work, f"sky-{case}-{v}.oct")
                oconv(octf, [skyf], env, work)
                up, down = rtrace_lux(octf, [(0, 0, 0, 0, 0, 1), (0, 0, 0, 0, 0, -1)],
                                      "-ab 1 -aa 0 -ad 65536 -as 0 -lw 1e-7", env, work)
                sanity[v] = {"up": up, "down": down}
            res = ans.get("sky") or ans.get("resolved_sky")
            summ = table(f"{case} ({'daylight factor %' if df else 'lux'})", rows, df)
            print(f"\nsky check, unobstructed E up / down (lx): " + ", ".join(
                f"{v}: {s['up']:.0f} / {s['down']:.0f}" for v, s in sanity.items()) +
                f"; relight's sky: {json.dumps(res)}")
            print("timing: " + ", ".join(f"{k} {v:.1f}" for k, v in timing.items()))
            results["cases"][case] = {"rows": rows, "summary": summ, "sky": sky,
                                      "quality": "black" if black else args.quality,
                                      "sanity": sanity, "relight_sky": res, "timing": timing}
            json.dump(results, open(rfile, "w"), indent=1)

        if "office-transfer" in cases:
            rows = []
            vals = {}
            for scene in ("office", "office-factored", "office-hierarchical"):
                rel, ans = relight_points(rl, scene, overcast, office_pts, off_lights)
                vals[scene] = [r[1] for r in rel]
            for i, p in enumerate(office_pts):
                row = {"x": p[0], "y": p[1], "z": p[2]}
                row["columns"] = vals["office"][i]
                row["factored"] = vals["office-factored"][i]
                row["hierarchical"] = vals["office-hierarchical"][i]
                row["Δ factored %"] = 100 * (row["factored"] / row["columns"] - 1)
                row["Δ hierarchical %"] = 100 * (row["hierarchical"] / row["columns"] - 1)
                oc = results["cases"].get("office-overcast")
                if oc:
                    for k in [k for k in oc["rows"][i] if k.startswith("rad_")]:
                        row[f"Δ fact-{k[4:]} %"] = 100 * (row["factored"] / oc["rows"][i][k] - 1)
                        row[f"Δ hier-{k[4:]} %"] = 100 * (row["hierarchical"] / oc["rows"][i][k] - 1)
                rows.append(row)
            summ = table("office-transfer (daylight factor %, relight transfer modes)", rows, True)
            results["cases"]["office-transfer"] = {"rows": rows, "summary": summ}
            json.dump(results, open(rfile, "w"), indent=1)
    finally:
        if server is not None:
            server.send_signal(signal.SIGTERM)
            try:
                server.wait(timeout=20)
            except subprocess.TimeoutExpired:
                server.kill()


if __name__ == "__main__":
    main()
