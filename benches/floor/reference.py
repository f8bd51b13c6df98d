#!/usr/bin/env python3
"""Path-traced reference for the panel floor (benches/floor/make_scene.py), with Mitsuba 3.

Usage: reference.py SCENE_DIR OUT_DIR [--points N] [--passes P] [--spp S] [--width W --height H]
                    [--views ID,ID] [--no-surfaces] [--no-views] [--groups-rgb A,B,C]

Environment: MI_VARIANT (default llvm_ad_rgb; cuda_ad_rgb on a GPU). A JIT variant is
needed: the surface estimates are wavefronts of Dr.Jit arrays.

Writes to OUT_DIR:
- surfaces.json: per surface (OBJ object) its area and the mean incident irradiance H
  (lux, RGB) over its front, with the standard error from P independent passes.
  Estimator per pass, at N uniform area samples of each surface (1e-4 m above it):
  direct light = one shadow-tested sample on every emissive panel (exact in expectation,
  Le cos cos' A / d²), plus indirect light = the `path` integrator's radiance along one
  cosine-distributed ray, minus the emission of its first hit (counted in the direct
  part), times π.
- <view>.npy: float32 H x W x 3 radiance images of the cameras in cameras.json (pinhole,
  vertical fov, box filter), the mean of P passes; <view>_stderr.npy (float16) the
  per-pixel standard error of that mean.

--groups-rgb A,B,C: only the panels of light groups A, B and C emit (surfaces
"A_panels", ...), A in red, B in green, C in blue, each at the panel's exitance; every
other panel is a black blocker. On a scene written with make_scene.py --grey the three
channels are then the three groups' own irradiances (each group alone, at full output):
compare_groups.py reads them.

Conventions (as relight): diffuse BSDFs (one-sided, black behind), one-sided area
emitters with radiance = exitance / π, face normals, path integrator max_depth 100.
"""
import argparse
import json
import math
import os
import time

import numpy as np
import mitsuba as mi
import drjit as dr

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("out")
ap.add_argument("--points", type=int, default=1 << 16, help="points per surface and pass")
ap.add_argument("--passes", type=int, default=4)
ap.add_argument("--spp", type=int, default=4096, help="samples per pixel of each view")
ap.add_argument("--pass-spp", type=int, default=256)
ap.add_argument("--width", type=int, default=512)
ap.add_argument("--height", type=int, default=384)
ap.add_argument("--views", default="")
ap.add_argument("--no-surfaces", action="store_true")
ap.add_argument("--no-views", action="store_true")
ap.add_argument("--brute", default="", help="surfaces to check with a second estimator: "
                "pi x the path integrator's radiance along cosine rays (emission included)")
ap.add_argument("--brute-points", type=int, default=1 << 22)
ap.add_argument("--ply-dir", default="/tmp/floor-reference-ply", help="where the meshes are written")
ap.add_argument("--groups-rgb", default="", help="A,B,C: only these groups emit, in R, G, B")
ap.add_argument("--chunk", type=int, default=1 << 22, help="most points per wavefront")
args = ap.parse_args()

mi.set_variant(os.environ.get("MI_VARIANT", "llvm_ad_rgb"))
os.makedirs(args.out, exist_ok=True)
t_start = time.time()

# ----------------------------------------------------------------- read the OBJ and MTL
mtl, cur = {}, None
for line in open(os.path.join(args.scene, "floor.mtl")):
    t = line.split()
    if not t or t[0].startswith("#"):
        continue
    if t[0] == "newmtl":
        cur = t[1]
        mtl[cur] = {"Kd": (0.0, 0.0, 0.0), "Ke": (0.0, 0.0, 0.0)}
    elif t[0] in ("Kd", "Ke"):
        v = [float(x) for x in t[1:4]]
        mtl[cur][t[0]] = tuple(v * 3 if len(v) == 1 else v)

verts, tris = [], {}          # tris[(surface, material)] = [(i, j, k), ...]
surf, mat = None, None
for line in open(os.path.join(args.scene, "floor.obj")):
    t = line.split()
    if not t or t[0].startswith("#"):
        continue
    if t[0] == "v":
        verts.append([float(x) for x in t[1:4]])
    elif t[0] == "o":
        surf = t[1]
    elif t[0] == "usemtl":
        mat = t[1]
    elif t[0] == "f":
        idx = [int(x.split("/")[0]) - 1 for x in t[1:]]
        for k in range(1, len(idx) - 1):
            tris.setdefault((surf, mat), []).append((idx[0], idx[k], idx[k + 1]))
verts = np.array(verts, dtype=np.float64)

# --------------------------------------------------------------------- the Mitsuba scene
scene_dict = {"type": "scene", "integrator": {"type": "path", "max_depth": 100, "rr_depth": 100000}}
ply_dir = args.ply_dir
os.makedirs(ply_dir, exist_ok=True)
panels = []                   # triangles of the emitters: (p0, p1, p2, Le RGB)
for n, ((s, m), tl) in enumerate(tris.items()):
    tl = np.array(tl, dtype=np.int64)
    used, inv = np.unique(tl.ravel(), return_inverse=True)
    # Each (surface, material) as a PLY without vertex normals, loaded with face_normals.
    mesh = mi.Mesh(f"{s}.{m}", vertex_count=len(used), face_count=len(tl))
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(verts[used].astype(np.float32).ravel())
    params["faces"] = mi.UInt32(inv.astype(np.uint32).ravel())
    params.update()
    ply = os.path.join(ply_dir, f"{n}.ply")
    mesh.write_ply(ply)
    kd, ke = mtl[m]["Kd"], mtl[m]["Ke"]
    if args.groups_rgb and max(ke) > 0:
        chans = [f"{g}_panels" for g in args.groups_rgb.split(",")]
        ke = tuple(max(ke) if s == name else 0.0 for name in (chans + ["", "", ""])[:3])
    shape = {"type": "ply", "filename": ply, "face_normals": True,
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(kd)}}}
    if max(ke) > 0:
        le = [c / math.pi for c in ke]
        shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": le}}
        for f in tl:
            panels.append((verts[f[0]], verts[f[1]], verts[f[2]], le))
    scene_dict[f"shape{n}"] = shape

cameras = json.load(open(os.path.join(args.scene, "cameras.json")))
if args.views:
    keep = args.views.split(",")
    cameras = [c for c in cameras if c["id"] in keep]
for c in cameras:
    scene_dict["sensor_" + c["id"]] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": c["fov_deg"],
        "to_world": mi.ScalarTransform4f().look_at(origin=c["position"], target=c["target"], up=c["up"]),
        "sampler": {"type": "independent"},
        "film": {"type": "hdrfilm", "width": args.width, "height": args.height,
                 "rfilter": {"type": "box"}, "pixel_format": "rgb"},
    }
scene = mi.load_dict(scene_dict)
print(f"scene: {len(tris)} meshes, {sum(len(v) for v in tris.values())} triangles, "
      f"{len(panels)} emitting triangles ({time.time() - t_start:.1f} s)", flush=True)

# ------------------------------------------------------------- per-surface irradiance
if not args.no_surfaces:
    # Each surface's triangles with their area and front normal.
    names = sorted({s for s, _ in tris})
    s_tris = {s: [] for s in names}
    for (s, m), tl in tris.items():
        s_tris[s].extend(tl)
    P = [np.array(verts[np.array(s_tris[s])]) for s in names]        # (T, 3, 3)
    areas = []
    for p in P:
        cr = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        areas.append(0.5 * np.linalg.norm(cr, axis=1))
    pe = np.array([[*p[0], *p[1], *p[2]] for p in panels], dtype=np.float32)    # (K, 9)
    le_np = np.array([p[3] for p in panels], dtype=np.float32)
    K = len(panels)
    pan_p0 = mi.Point3f(*[mi.Float(pe[:, i]) for i in range(3)])
    pan_e1 = mi.Vector3f(*[mi.Float(pe[:, 3 + i] - pe[:, i]) for i in range(3)])
    pan_e2 = mi.Vector3f(*[mi.Float(pe[:, 6 + i] - pe[:, i]) for i in range(3)])
    pan_le = mi.Color3f(*[mi.Float(le_np[:, i]) for i in range(3)])
    integrator = scene.integrator()
    sampler = mi.load_dict({"type": "independent"})

    def sample_points(rng, si, n):
        """n uniform area samples of surface si: positions and the front normal."""
        p, a = P[si], areas[si]
        t = rng.choice(len(a), size=n, p=a / a.sum())
        u, v = rng.random(n), rng.random(n)
        su = np.sqrt(u)
        b0, b1, b2 = 1 - su, su * (1 - v), su * v
        x = b0[:, None] * p[t, 0] + b1[:, None] * p[t, 1] + b2[:, None] * p[t, 2]
        nrm = np.cross(p[t, 1] - p[t, 0], p[t, 2] - p[t, 0])
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        return x + 1e-4 * nrm, nrm

    def irradiance(x, nrm, seed):
        """Per point (x, n): direct + indirect irradiance, RGB numpy (n, 3)."""
        m = len(x)
        X = mi.Point3f(*[mi.Float(x[:, i].astype(np.float32)) for i in range(3)])
        N = mi.Vector3f(*[mi.Float(nrm[:, i].astype(np.float32)) for i in range(3)])
        sampler.seed(seed, m)
        # Direct: one sample on every emitting triangle.
        direct = mi.Color3f(0.0)
        for k in range(K):
            kk = dr.opaque(mi.UInt32, k, m)
            p0 = dr.gather(mi.Point3f, pan_p0, kk)
            e1 = dr.gather(mi.Vector3f, pan_e1, kk)
            e2 = dr.gather(mi.Vector3f, pan_e2, kk)
            le = dr.gather(mi.Color3f, pan_le, kk)
            uv = sampler.next_2d()
            su = dr.sqrt(uv.x)
            y = p0 + e1 * (su * (1 - uv.y)) + e2 * (su * uv.y)
            ne = dr.cross(e1, e2)
            area = 0.5 * dr.norm(ne)
            ne = dr.normalize(ne)
            d = y - X
            dist2 = dr.squared_norm(d)
            dist = dr.sqrt(dist2)
            w = d / dist
            cr = dr.dot(N, w)
            ce = -dr.dot(ne, w)
            ok = (cr > 0) & (ce > 0)
            ray = mi.Ray3f(X, w, dist * (1 - 1e-4), 0.0, mi.Color0f())
            vis = ok & ~scene.ray_test(ray, ok)
            direct += dr.select(vis, le * (cr * ce * area / dist2), 0.0)
            sampler.schedule_state()
            dr.eval(direct)          # one small kernel per emitter (k is opaque: compiled once)
        # Indirect: the path integrator along one cosine ray, less its first hit's emission.
        frame = mi.Frame3f(N)
        wd = frame.to_world(mi.warp.square_to_cosine_hemisphere(sampler.next_2d()))
        ray = mi.RayDifferential3f(mi.Ray3f(X, wd, 0.0, mi.Color0f()))
        L, _, _ = integrator.sample(scene, sampler, ray)
        si = scene.ray_intersect(mi.Ray3f(X, wd, 0.0, mi.Color0f()))
        em = si.emitter(scene)
        le0 = dr.select(si.is_valid(), em.eval(si, si.is_valid()), 0.0)
        total = direct + (L - le0) * math.pi
        dr.eval(total)
        return np.stack([np.array(total[i]) for i in range(3)], axis=1)

    t0 = time.time()
    n_pts = args.points
    means = np.zeros((args.passes, len(names), 3))
    rng = np.random.default_rng(20261126)
    seed = 0
    for ps in range(args.passes):
        # All surfaces' points of this pass, in chunks of at most `chunk` points.
        order = [(si, j) for si in range(len(names)) for j in range(0, n_pts, args.chunk)]
        batch_x, batch_n, batch_s = [], [], []
        pending = 0

        def flush():
            global seed
            if not batch_x:
                return
            x, nrm, sidx = np.concatenate(batch_x), np.concatenate(batch_n), np.concatenate(batch_s)
            e = irradiance(x, nrm, seed)
            seed += 1
            for c in range(3):
                means[ps, :, c] += np.bincount(sidx, weights=e[:, c], minlength=len(names)) / n_pts
            batch_x.clear(), batch_n.clear(), batch_s.clear()

        for si, j in order:
            cnt = min(args.chunk, n_pts - j)
            if pending + cnt > args.chunk:
                flush()
                pending = 0
            x, nrm = sample_points(rng, si, cnt)
            batch_x.append(x), batch_n.append(nrm), batch_s.append(np.full(cnt, si))
            pending += cnt
        flush()
        print(f"surfaces: pass {ps + 1}/{args.passes} ({time.time() - t0:.1f} s)", flush=True)
    mean = means.mean(axis=0)
    brute = {}
    for sname in [b for b in args.brute.split(",") if b]:
        si = names.index(sname)
        vals = []
        for j in range(0, args.brute_points, args.chunk):
            cnt = min(args.chunk, args.brute_points - j)
            x, nrm = sample_points(rng, si, cnt)
            m = len(x)
            X = mi.Point3f(*[mi.Float(x[:, i].astype(np.float32)) for i in range(3)])
            N = mi.Vector3f(*[mi.Float(nrm[:, i].astype(np.float32)) for i in range(3)])
            sampler.seed(seed, m)
            seed += 1
            wd = mi.Frame3f(N).to_world(mi.warp.square_to_cosine_hemisphere(sampler.next_2d()))
            L, _, _ = integrator.sample(scene, sampler, mi.RayDifferential3f(mi.Ray3f(X, wd, 0.0, mi.Color0f())))
            L = L * math.pi
            dr.eval(L)
            vals.append(np.stack([np.array(L[i]) for i in range(3)], axis=1))
        v = np.concatenate(vals)
        bm, bs = v.mean(axis=0), v.std(axis=0) / math.sqrt(len(v))
        brute[sname] = {"irradiance": bm.tolist(), "stderr": bs.tolist()}
        print(f"check {sname}: brute {bm.round(2)} ± {bs.round(2)}; estimator {mean[si].round(2)} ± "
              f"{(means[:, si].std(axis=0, ddof=1) / math.sqrt(args.passes)).round(2)}", flush=True)
    se = means.std(axis=0, ddof=1) / math.sqrt(args.passes) if args.passes > 1 else np.zeros_like(mean)
    out = {"estimator": "direct: one sample per emitting triangle; indirect: path integrator along "
                        "one cosine ray less the first hit's emission",
           "groups_rgb": args.groups_rgb.split(",") if args.groups_rgb else None,
           "points_per_pass": n_pts, "passes": args.passes, "variant": mi.variant(),
           "seconds": time.time() - t0,
           "surfaces": {s: {"area": float(areas[i].sum()), "irradiance": mean[i].tolist(),
                            "stderr": se[i].tolist()} for i, s in enumerate(names)},
           "brute_force_check": brute}
    json.dump(out, open(os.path.join(args.out, "surfaces.json"), "w"), indent=1)
    print(f"surfaces: {len(names)} in {time.time() - t0:.1f} s", flush=True)

# --------------------------------------------------------------------------- views
if not args.no_views:
    sensors = scene.sensors()
    for ci, c in enumerate(cameras):
        t0 = time.time()
        passes = max(1, args.spp // args.pass_spp)
        acc = np.zeros((args.height, args.width, 3))
        acc2 = np.zeros_like(acc)
        for k in range(passes):
            img = np.array(mi.render(scene, sensor=sensors[ci], spp=args.pass_spp, seed=1000 * ci + k))
            acc += img
            acc2 += img.astype(np.float64) ** 2
        mean = acc / passes
        var = np.maximum(acc2 / passes - mean ** 2, 0.0) / max(passes - 1, 1)
        np.save(os.path.join(args.out, f"{c['id']}.npy"), mean.astype(np.float32))
        np.save(os.path.join(args.out, f"{c['id']}_stderr.npy"), np.sqrt(var).astype(np.float16))
        rel = np.sqrt(var).sum() / max(mean.sum(), 1e-30)
        print(f"view {c['id']}: {passes} x {args.pass_spp} spp in {time.time() - t0:.1f} s, "
              f"mean relative standard error {rel:.4f}", flush=True)
    json.dump({"convention": "pinhole; fov_deg is the vertical field of view; position, target, up "
                             "in scene metres (y up); images are linear radiance (cd/m², RGB), "
                             "row 0 at the top",
               "width": args.width, "height": args.height, "spp": args.spp,
               "cameras": cameras}, open(os.path.join(args.out, "cameras.json"), "w"), indent=1)
print(f"done in {time.time() - t_start:.1f} s", flush=True)
