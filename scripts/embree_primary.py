"""Embree reference for `rqr bench`: primary rays through every pixel centre of the same pinhole
camera, closest hit, on 2 processes (one per core) that each trace half of the image.

usage: python embree_primary.py MESH.glb [SIZE] [EYE_Z] [FOV_DEG]
Prints one line: Mrays/s (sum of both halves' rates, median of 5 after a warm-up) and hits.
Needs `embreex` (Embree 2.17, rtcIntersect1 per ray), `trimesh`, `numpy`
(scripts/bench-vs-embree.sh installs them into target/embree-venv).
"""
import multiprocessing as mp
import sys
import time

import numpy as np


def rays(size, eye_z, fov):
    th = np.tan(np.radians(fov) / 2)
    ys, xs = np.mgrid[0:size, 0:size].astype(np.float64)
    u = (2 * (xs + 0.5) / size - 1) * th
    v = (1 - 2 * (ys + 0.5) / size) * th
    d = np.stack([u, v, -np.ones_like(u)], -1).reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile(np.array([0.0, 0.0, eye_z]), (size * size, 1))
    return o.astype(np.float32), d.astype(np.float32)


def worker(mesh, part, size, eye_z, fov, barrier, out):
    import trimesh
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    m = trimesh.load(mesh, force="mesh")
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, m.vertices[m.faces].astype(np.float32))
    o, d = rays(size, eye_z, fov)
    half = len(o) // 2
    o, d = (o[:half], d[:half]) if part == 0 else (o[half:], d[half:])
    scene.run(o, d)  # warm-up (builds the BVH)
    times = []
    for _ in range(5):
        barrier.wait()
        t = time.perf_counter()
        r = scene.run(o, d)
        times.append(time.perf_counter() - t)
    out.put((len(o) / np.median(times) / 1e6, int((r >= 0).sum())))


if __name__ == "__main__":
    mesh = sys.argv[1]
    size = int(sys.argv[2]) if len(sys.argv) > 2 else 512
    eye_z = float(sys.argv[3]) if len(sys.argv) > 3 else 2.5
    fov = float(sys.argv[4]) if len(sys.argv) > 4 else 45.0
    barrier, out = mp.Barrier(2), mp.Queue()
    procs = [mp.Process(target=worker, args=(mesh, p, size, eye_z, fov, barrier, out)) for p in (0, 1)]
    for p in procs:
        p.start()
    results = [out.get() for _ in procs]
    for p in procs:
        p.join()
    print("embree %.3f Mrays/s primary, %d hits" % (sum(r[0] for r in results), sum(r[1] for r in results)))
