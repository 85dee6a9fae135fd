"""Mitsuba 3 rows of wavelux's speed-accuracy reproduction (issue 12 §1).

Run by `cargo xtask reproduce-figures --only speed-accuracy` when `import mitsuba`
works; never imported by anything else. Reads a job JSON written by
`xtask/src/repro/speed_accuracy/mitsuba.rs` (the scene as PLY meshes with per-side
diffuse reflectance and emitted exitance, the camera, the texel points) and writes a
result JSON: for each requested sample count, the wall time and the rendered image
(Mitsuba's `path` integrator, stratified sampler, box filter), and for each requested
path count the texel radiosities B = E + rho (H_direct + H_indirect), where H_direct
comes from Mitsuba's emitter sampling at the texel (with its visibility test) and
H_indirect from cosine-distributed rays whose incoming radiance is Mitsuba's `path`
integrator minus the emission of the first hit. Times are the CPU time of this
process (every thread, `time.process_time`) after one untimed warm-up of the same
kernel (JIT compilation is not counted), the wall time beside it.

Usage: python3 mitsuba.py JOB.json RESULT.json
"""

import json
import math
import os
import sys
import time

import drjit as dr
import mitsuba as mi


def bsdf(side):
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": side["rho"]}}


def load_scene(job):
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": -1, "rr_depth": 5}}
    for k, m in enumerate(job["meshes"]):
        b = bsdf(m["front"])
        if m.get("back") is not None:
            b = {"type": "twosided", "front": b, "back": bsdf(m["back"])}
        shape = {"type": "ply", "filename": m["ply"], "face_normals": False, "bsdf": b}
        e = m["front"]["e"]
        if max(e) > 0.0:
            shape["emitter"] = {
                "type": "area",
                "radiance": {"type": "rgb", "value": [v / math.pi for v in e]},
            }
        d["shape%d" % k] = shape
    cam = job["camera"]
    d["sensor"] = {
        "type": "perspective",
        "fov": cam["fov_y_deg"],
        "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(
            origin=cam["origin"], target=cam["target"], up=cam["up"]
        ),
        "film": {
            "type": "hdrfilm",
            "width": cam["width"],
            "height": cam["height"],
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
        },
        "sampler": {"type": "stratified", "sample_count": 4},
    }
    return mi.load_dict(d)


def render(scene, spp, seed):
    img = mi.render(scene, spp=spp, seed=seed)
    # Row-major, row 0 at the top, column 0 on the viewer's left: the same layout as
    # wavelux's images, with no mirroring (checked: with look_at, an emitter to the
    # right of the view axis lands in the film's right half). An earlier version
    # mirrored the columns and so compared a mirror image with the reference.
    arr = img.numpy()
    return [float(v) for v in arr.reshape(-1)]


def texels(scene, job, paths, seed):
    tx = job["texels"]
    n = len(tx["origin"]) // 3
    integ = scene.integrator()
    total = [0.0] * (3 * n)
    chunk = max(1, min(paths, (1 << 20) // max(n, 1)))
    done = 0
    rounds = 0
    while done < paths:
        k = min(chunk, paths - done)
        lanes = n * k
        idx = dr.arange(mi.UInt32, lanes) // k
        o = mi.Point3f(
            dr.gather(mi.Float, mi.Float(tx["origin"]), idx * 3 + 0),
            dr.gather(mi.Float, mi.Float(tx["origin"]), idx * 3 + 1),
            dr.gather(mi.Float, mi.Float(tx["origin"]), idx * 3 + 2),
        )
        nrm = mi.Vector3f(
            dr.gather(mi.Float, mi.Float(tx["normal"]), idx * 3 + 0),
            dr.gather(mi.Float, mi.Float(tx["normal"]), idx * 3 + 1),
            dr.gather(mi.Float, mi.Float(tx["normal"]), idx * 3 + 2),
        )
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(seed * 1000003 + rounds, lanes)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.p = o
        si.n = nrm
        si.sh_frame = mi.Frame3f(nrm)
        si.t = mi.Float(0.0)
        si.wi = mi.Vector3f(0.0, 0.0, 1.0)
        # Direct: one emitter sample with its visibility (radiance / pdf).
        ds, w = scene.sample_emitter_direction(si, sampler.next_2d(), True)
        cos_d = dr.maximum(dr.dot(nrm, ds.d), 0.0)
        h_dir = w * cos_d
        # Indirect: a cosine-distributed ray; the path integrator's radiance minus the
        # emission of its first hit (estimated by light sampling above).
        local = mi.warp.square_to_cosine_hemisphere(sampler.next_2d())
        d = si.sh_frame.to_world(local)
        ray = mi.Ray3f(o, d)
        li, _, _ = integ.sample(scene, sampler, ray)
        hit = scene.ray_intersect(ray)
        le = dr.select(hit.is_valid(), hit.emitter(scene).eval(hit), mi.Color3f(0.0))
        h_ind = (mi.Color3f(li) - le) * math.pi
        h = h_dir + h_ind
        sums = [dr.block_sum(h[c], k) for c in range(3)]
        dr.eval(sums)
        s = [x.numpy() for x in sums]
        for i in range(n):
            for c in range(3):
                total[3 * i + c] += float(s[c][i])
        done += k
        rounds += 1
    out = []
    for i in range(n):
        for c in range(3):
            h = total[3 * i + c] / paths
            out.append(tx["e"][3 * i + c] + tx["rho"][3 * i + c] * h)
    return out


def main():
    job = json.load(open(sys.argv[1]))
    mi.set_variant(job["variant"])
    scene = load_scene(job)
    res = {"version": mi.__version__, "variant": job["variant"], "images": [], "texels": []}
    if job["image_spp"]:
        render(scene, 1, 1)  # warm-up (kernel compilation)
    for spp in job["image_spp"]:
        t, c = time.perf_counter(), time.process_time()
        px = render(scene, spp * spp, 7 + spp)
        res["images"].append(
            {
                "spp": spp,
                "seconds": time.process_time() - c,
                "wall_seconds": time.perf_counter() - t,
                "pixels": px,
            }
        )
    if job["texel_paths"]:
        texels(scene, job, 1, 1)  # warm-up
    for p in job["texel_paths"]:
        t, c = time.perf_counter(), time.process_time()
        v = texels(scene, job, p, 11 + p)
        res["texels"].append(
            {
                "paths": p,
                "seconds": time.process_time() - c,
                "wall_seconds": time.perf_counter() - t,
                "values": v,
            }
        )
    with open(sys.argv[2] + ".tmp", "w") as f:
        json.dump(res, f)
    os.replace(sys.argv[2] + ".tmp", sys.argv[2])


if __name__ == "__main__":
    main()
