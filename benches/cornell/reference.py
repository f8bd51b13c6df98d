#!/usr/bin/env python3
"""A low-noise path-traced Cornell box image, to tell relight's own error in `final` images
from the noise of the 4,096-spp reference in tests/data.

Usage: reference.py SCENE_DIR OUT_DIR [--spp S] [--pass-spp P] [--side N]

SCENE_DIR is scenes/cornell-box (cornell_box.obj and .mtl, camera as in scene.toml and in
shared/reference/cornell-box/scene.json). Writes OUT_DIR/white.npy (float32 N x N x 3
linear radiance, W/(m² sr), row 0 at the top, the mean of S/P independent passes) and
white_stderr.npy (the per-pixel standard error of that mean). The warm state is the white
image times (1, 0.6, 0.3) per channel: one light, linear.

Conventions as in tests/data and benches/floor/reference.py: diffuse one-sided BSDFs,
a one-sided area emitter with radiance = exitance / π, face normals, a pinhole camera with
a vertical field of view, box pixel filter, the `path` integrator with max_depth 65.
Environment: MI_VARIANT (cuda_ad_rgb on a GPU, llvm_ad_rgb or scalar_rgb on a CPU).
"""
import argparse
import math
import os
import time

import numpy as np
import mitsuba as mi

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("out")
ap.add_argument("--spp", type=int, default=1 << 16)
ap.add_argument("--pass-spp", type=int, default=4096)
ap.add_argument("--side", type=int, default=256)
args = ap.parse_args()
mi.set_variant(os.environ.get("MI_VARIANT", "cuda_ad_rgb"))
os.makedirs(args.out, exist_ok=True)
t0 = time.time()

mtl, cur = {}, None
for line in open(os.path.join(args.scene, "cornell_box.mtl")):
    t = line.split()
    if not t or t[0].startswith("#"):
        continue
    if t[0] == "newmtl":
        cur = t[1]
        mtl[cur] = {"Kd": (0.0,) * 3, "Ke": (0.0,) * 3}
    elif t[0] in ("Kd", "Ke"):
        v = [float(x) for x in t[1:4]]
        mtl[cur][t[0]] = tuple(v * 3 if len(v) == 1 else v)
verts, tris, mat = [], {}, None
for line in open(os.path.join(args.scene, "cornell_box.obj")):
    t = line.split()
    if not t or t[0].startswith("#"):
        continue
    if t[0] == "v":
        verts.append([float(x) for x in t[1:4]])
    elif t[0] == "usemtl":
        mat = t[1]
    elif t[0] == "f":
        idx = [int(x.split("/")[0]) - 1 for x in t[1:]]
        for k in range(1, len(idx) - 1):
            tris.setdefault(mat, []).append((idx[0], idx[k], idx[k + 1]))
verts = np.array(verts, dtype=np.float64)

scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 65}}
for n, (m, tl) in enumerate(tris.items()):
    tl = np.array(tl, dtype=np.int64)
    used, inv = np.unique(tl.ravel(), return_inverse=True)
    mesh = mi.Mesh(m, vertex_count=len(used), face_count=len(tl))
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(verts[used].astype(np.float32).ravel())
    params["faces"] = mi.UInt32(inv.astype(np.uint32).ravel())
    params.update()
    ply = f"/tmp/cornell-{n}.ply"
    mesh.write_ply(ply)
    shape = {"type": "ply", "filename": ply, "face_normals": True,
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(mtl[m]["Kd"])}}}
    if max(mtl[m]["Ke"]) > 0:
        shape["emitter"] = {"type": "area",
                            "radiance": {"type": "rgb", "value": [c / math.pi for c in mtl[m]["Ke"]]}}
    scene[f"shape{n}"] = shape
scene["sensor"] = {
    "type": "perspective", "fov_axis": "y", "fov": 39.3077,
    "to_world": mi.ScalarTransform4f().look_at(origin=[0.278, 0.273, -0.8], target=[0.278, 0.273, 0.0],
                                               up=[0.0, 1.0, 0.0]),
    "sampler": {"type": "independent"},
    "film": {"type": "hdrfilm", "width": args.side, "height": args.side, "rfilter": {"type": "box"},
             "pixel_format": "rgb"},
}
scene = mi.load_dict(scene)
passes = max(1, args.spp // args.pass_spp)
acc = np.zeros((args.side, args.side, 3))
acc2 = np.zeros_like(acc)
for p in range(passes):
    img = np.array(mi.render(scene, spp=args.pass_spp, seed=p), dtype=np.float64)[:, :, :3]
    acc += img
    acc2 += img * img
    # Saved after every pass, so a run cut short still leaves its passes so far.
    k = p + 1
    mean = acc / k
    var = np.maximum(acc2 / k - mean * mean, 0.0) / max(k - 1, 1)
    np.save(os.path.join(args.out, "white.npy"), mean.astype(np.float32))
    np.save(os.path.join(args.out, "white_stderr.npy"), np.sqrt(var).astype(np.float32))
    rel = math.sqrt(var.sum() / (mean * mean).sum())
    print(f"pass {k}/{passes} of {args.pass_spp} spp at {time.time() - t0:.1f} s: relative noise {rel:.5f}",
          flush=True)
