"""Embree 4 side of `accel_vs_embree` (benches/examples/accel_vs_embree.rs).

Reads the triangles and shadow segments that the Rust side wrote into DIR, builds an
Embree scene through the `embreex` binding (pip install embreex; a measurement tool
only, never part of CI), times `rtcOccluded1` over every segment on the calling
thread (embreex loops over the rays in Cython, one thread), and writes the answers
(1 = blocked) to DIR/embree.u8 and the times (seconds) to DIR/embree.json.

Usage: python3 embree_occlusion.py DIR
"""

import json
import sys
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def main(d):
    tris = np.fromfile(f"{d}/tris.f32", dtype=np.float32).reshape(-1, 3, 3)
    org = np.fromfile(f"{d}/org.f32", dtype=np.float32).reshape(-1, 3)
    dirs = np.fromfile(f"{d}/dir.f32", dtype=np.float32).reshape(-1, 3)
    dist = np.fromfile(f"{d}/dist.f32", dtype=np.float32)
    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tris)
    # The first query commits (builds) the scene: time it apart from the rays.
    scene.run(org[:1], dirs[:1], dists=dist[:1], query="OCCLUDED")
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = scene.run(org, dirs, dists=dist, query="OCCLUDED")
    trace = time.perf_counter() - t0
    (np.asarray(res) != -1).astype(np.uint8).tofile(f"{d}/embree.u8")
    with open(f"{d}/embree.json", "w") as f:
        json.dump({"build_s": build, "trace_s": trace, "rays": int(len(dist))}, f)


if __name__ == "__main__":
    main(sys.argv[1])
