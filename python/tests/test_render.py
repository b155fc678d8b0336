"""rqr's Python package: images against the CLI, AOV conventions, cameras, lifetime."""

import gc
import os
import pathlib
import threading
import time

import numpy as np
import pytest

import rqr
from conftest import asset, run_cli

W, H = 64, 48


def test_import_touches_no_device():
    # The module imported (conftest did) without a renderer: nothing is open yet, and the
    # native module names the documented exception and limit.
    assert issubclass(rqr.SceneError, Exception)
    assert rqr.AOV_ID_EXACT_LIMIT == 2**31


def test_device_info(renderer):
    d = renderer.device
    for key in ("name", "uuid", "driver", "backend", "backend_reason"):
        assert d[key], key
    assert d["backend"] in ("hw", "bvh")


def test_builtin_rgb_equals_cli_exr(renderer, builtin, tmp_path):
    exr = tmp_path / "cli.exr"
    run_cli("render", "--width", str(W), "--height", str(H), "-o", str(exr), "--backend", renderer.device["backend"])
    want = rqr.read_exr(exr)[..., :3]
    cams = builtin.default_camera(W, H)
    out = renderer.render(builtin, cams, W, H, aovs=("rgb",))
    got = out.rgb[0]
    assert got.shape == (H, W, 3) and got.dtype == np.float32
    assert np.abs(got - want).max() <= 1e-6, np.abs(got - want).max()
    assert got.max() > 0.05, "the image is black"


def test_distributed_shading_equals_the_cli(renderer, builtin, tmp_path):
    exr = tmp_path / "cli.exr"
    run_cli("render", "--width", str(W), "--height", str(H), "-o", str(exr), "--backend", renderer.device["backend"],
            "--shading", "distributed", "--spp", "4", "--sampler", "sobol", "--seed", "5")
    want = rqr.read_exr(exr)[..., :3]
    cams = builtin.default_camera(W, H)
    out = renderer.render(builtin, cams, W, H, aovs=("rgb",), shading="distributed", spp=4, seed=5)
    assert np.abs(out.rgb[0] - want).max() <= 1e-6, np.abs(out.rgb[0] - want).max()
    whitted = renderer.render(builtin, cams, W, H, aovs=("rgb",), spp=4, seed=5)
    assert np.abs(out.rgb[0] - whitted.rgb[0]).max() > 1e-3, "distributed shading rendered the Whitted image"


def test_albedo_normal_ids_equal_cli_pfm_and_exr(renderer, builtin, tmp_path):
    # The same frame through the CLI (PFM colour, PFM and EXR AOVs) and through the package.
    pfm = tmp_path / "cli.pfm"
    backend = ("--backend", renderer.device["backend"])
    run_cli("render", "--width", str(W), "--height", str(H), "-o", str(pfm), "--aov", "albedo,normal,instance", *backend)
    exr = tmp_path / "cli.exr"
    run_cli("render", "--width", str(W), "--height", str(H), "-o", str(exr), "--aov", "albedo", *backend)
    cams = builtin.default_camera(W, H)
    out = renderer.render(builtin, cams, W, H, aovs=("rgb", "albedo", "normal", "instance", "mask"))
    albedo, normal, inst, mask = out.albedo[0], out.normal[0], out.instance[0], out.mask[0]
    assert albedo.dtype == np.float32 and albedo.shape == (H, W, 3)
    assert inst.dtype == np.int32
    assert mask.any(), "the room is in view"
    assert albedo.min() >= 0.0 and albedo.max() <= 1.0
    assert albedo[mask].max() > 0.1, "lit surfaces have a base colour"
    assert np.all(albedo[~mask] == 0) and np.all(normal[~mask] == 0)
    lengths = np.linalg.norm(normal[mask], axis=-1)
    assert np.abs(lengths - 1).max() < 1e-3, "unit shading normals on hits"
    assert np.abs(_read_pfm(pfm) - out.rgb[0]).max() <= 1e-6
    assert np.array_equal(_read_pfm(tmp_path / "cli.albedo.pfm"), albedo)
    assert np.array_equal(_read_pfm(tmp_path / "cli.normal.pfm"), normal)
    assert np.array_equal(_read_pfm(tmp_path / "cli.instance.pfm")[..., 0], inst.astype(np.float32))
    assert np.array_equal(rqr.read_exr(tmp_path / "cli.albedo.exr")[..., :3], albedo)


def _read_pfm(path):
    """A colour PFM (as rqr writes it: little-endian, rows bottom to top) as [H, W, 3]."""
    data = pathlib.Path(path).read_bytes()
    magic, size, scale, rest = data.split(b"\n", 3)
    assert magic == b"PF" and float(scale) < 0
    w, h = (int(v) for v in size.split())
    return np.frombuffer(rest, dtype="<f4", count=w * h * 3).reshape(h, w, 3)[::-1]


def test_srgb8(renderer, builtin):
    cams = builtin.default_camera(W, H)
    lin = renderer.render(builtin, cams, W, H, aovs=("rgb",)).rgb[0]
    u8 = renderer.render(builtin, cams, W, H, aovs=("rgb",), tonemap="srgb8").rgb[0]
    assert u8.dtype == np.uint8 and u8.shape == (H, W, 3)
    c = np.clip(lin, 0, 1)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055) * 255
    assert np.abs(srgb - u8.astype(np.float64)).max() <= 1.5


def test_ids_int32_and_miss(renderer):
    scene = renderer.load(asset("SimpleInstancing"))
    assert len(scene.instances) > 100
    cams = rqr.Cameras.orbit(scene.bounds, n=2, fov_y_deg=50, seed=1)
    out = renderer.render(scene, cams, W, H, aovs=("instance", "primitive", "mask", "depth", "z"))
    inst, prim, mask = out.instance, out.primitive, out.mask
    assert inst.dtype == np.int32 and prim.dtype == np.int32 and mask.dtype == np.bool_
    assert mask.any() and (~mask).any(), "need hits and misses"
    assert np.array_equal(mask, inst >= 0)
    assert np.all(inst[~mask] == -1) and np.all(prim[~mask] == -1)
    assert np.all(np.isinf(out.depth[~mask])) and np.all(np.isinf(out.z[~mask]))
    hit_ids = np.unique(inst[mask])
    assert hit_ids.max() < len(scene.instances)
    assert len(hit_ids) > 10, "many instances are visible"
    for i in hit_ids:
        tris = scene.instances[int(i)]["triangles"]
        assert prim[inst == i].max() < tris
        assert scene.instances[int(i)]["id"] == i


def test_opengl_and_opencv_agree(renderer, builtin):
    gl = rqr.Cameras.orbit(builtin.bounds, n=3, fov_y_deg=45, seed=3)
    flip = np.diag([1.0, -1.0, -1.0, 1.0])
    cv = rqr.Cameras(c2w=gl.c2w @ flip, K=gl.K_for(W, H), convention="opencv")
    a = renderer.render(builtin, gl, W, H, aovs=("rgb", "depth"))
    b = renderer.render(builtin, cv, W, H, aovs=("rgb", "depth"))
    assert np.array_equal(a.rgb, b.rgb)
    assert np.array_equal(a.depth, b.depth)
    assert np.allclose(a.cameras["c2w_opencv"], b.cameras["c2w_opencv"])


def test_depth_and_z_agree_through_the_camera(renderer, builtin):
    cams = rqr.Cameras.orbit(builtin.bounds, n=2, fov_y_deg=50, seed=5)
    out = renderer.render(builtin, cams, W, H, aovs=("depth", "z", "mask"))
    K = out.cameras["K"]
    u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    for i in range(2):
        # OpenCV ray through the pixel centre: (x, y, 1) in camera space.
        x = (u - K[i, 0, 2]) / K[i, 0, 0]
        y = (v - K[i, 1, 2]) / K[i, 1, 1]
        ratio = 1.0 / np.sqrt(x * x + y * y + 1.0)
        m = out.mask[i]
        assert m.sum() > W * H / 10
        z_from_depth = out.depth[i][m] * ratio[m]
        np.testing.assert_allclose(z_from_depth, out.z[i][m], rtol=2e-4, atol=1e-5 * float(out.z[i][m].max()))
        assert np.all(out.z[i][m] > 0)


def test_nerf_transforms(renderer, builtin):
    cams = rqr.Cameras.orbit(builtin.bounds, n=4)
    out = renderer.render(builtin, cams, W, H, aovs=("rgb",))
    t = out.transforms([f"images/{i:03d}.png" for i in range(4)])
    assert t["w"] == W and t["h"] == H and len(t["frames"]) == 4
    assert np.allclose(np.array(t["frames"][2]["transform_matrix"]), out.cameras["c2w_opengl"][2])
    assert out.stats["rays"]["primary"] >= 4 * W * H
    assert out.stats["gpu_ms"] and out.stats["wall_ms"]["render"] > 0
    assert len(out.stats["view_gpu_ms"]) == 4


def test_hybrid_matches_rt_ids(renderer, builtin):
    cams = builtin.default_camera(W, H)
    rt = renderer.render(builtin, cams, W, H, mode="rt", aovs=("instance",))
    hy = renderer.render(builtin, cams, W, H, mode="hybrid", aovs=("instance", "rgb"))
    same = np.mean(rt.instance == hy.instance)
    assert same > 0.98, same


def test_render_many_prefetches(renderer):
    names = ["Box", "BoxTextured", "Avocado"]
    jobs = [(asset(n), None) for n in names]
    # Cameras depend on each scene's bounds: pass a fixed set framing the unit cube.
    cams = rqr.Cameras.orbit(([-1, -1, -1], [1, 1, 1]), n=2)
    jobs = [(p, cams) for p, _ in jobs]
    seen = []
    for scene, out in renderer.render_many(jobs, prefetch=2, width=16, height=16, aovs=("rgb", "mask")):
        seen.append(scene.source)
        assert out.rgb.shape == (2, 16, 16, 3)
    assert [os.path.basename(s) for s in seen] == [os.path.basename(str(p)) for p, _ in jobs]


def _rss_kib() -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def test_memory_flat_over_200_cycles(renderer):
    path = asset("BoxTextured")
    cams = rqr.Cameras.orbit(([-1, -1, -1], [1, 1, 1]), n=1)

    def cycle():
        scene = renderer.load(path)
        out = renderer.render(scene, cams, 8, 8, aovs=("rgb", "depth"))
        assert out.rgb.shape == (1, 8, 8, 3)
        del scene, out

    for _ in range(20):
        cycle()
    gc.collect()
    base = _rss_kib()
    for _ in range(200):
        cycle()
    gc.collect()
    grown = _rss_kib()
    assert grown <= base * 1.05, f"RSS {base} KiB -> {grown} KiB over 200 cycles"


def test_forked_child_raises(renderer, builtin):
    cams = builtin.default_camera(8, 8)
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            renderer.render(builtin, cams, 8, 8)
        except RuntimeError as e:
            code = 0 if "fork" in str(e) else 2
        except BaseException:
            code = 3
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status), f"child died: {status}"
    assert os.WEXITSTATUS(status) == 0, f"child exit {os.WEXITSTATUS(status)}"
    # The parent's renderer still works.
    assert renderer.render(builtin, cams, 8, 8, aovs=("rgb",)).rgb.shape == (1, 8, 8, 3)


def test_forked_child_drops_safely():
    r = rqr.Renderer()
    scene = r.load()
    pid = os.fork()
    if pid == 0:
        # Dropping the renderer and the scene in the child must neither crash nor hang.
        del scene, r
        gc.collect()
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, status
    r.close()


def test_gil_released_during_render(renderer, builtin):
    cams = rqr.Cameras.orbit(builtin.bounds, n=6)
    ticks = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            ticks[0] += 1
            time.sleep(0.001)

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = ticks[0]
        render_s = 0.0
        # Render until the renders took long enough for ticks to count, whatever the device.
        while render_s < 0.2:
            out = renderer.render(builtin, cams, 256, 256, spp=4, aovs=("rgb",))
            render_s += out.stats["wall_ms"]["total"] / 1e3
        during = ticks[0] - before
    finally:
        stop.set()
        t.join()
    # A thread starved of the GIL would tick at most a few times per render.
    assert during >= 10, f"{during} ticks in {render_s:.2f} s"


def test_close_and_context_manager():
    with rqr.Renderer() as r:
        scene = r.load()
    assert r.closed
    with pytest.raises(RuntimeError, match="closed"):
        r.render(scene, scene.default_camera(8, 8), 8, 8)
    r.close()


def test_bad_arguments(renderer, builtin, tmp_path):
    cams = builtin.default_camera(8, 8)
    bad = [
        dict(width=0),
        dict(height=-3),
        dict(mode="path"),
        dict(shading="pbr"),
        dict(aovs=("rgb", "nope")),
        dict(aovs=("albedo", "emission")),
        dict(aovs=()),
        dict(tonemap="filmic"),
        dict(spp=0),
        dict(environment=str(tmp_path / "missing.hdr")),
    ]
    for kw in bad:
        args = dict(width=8, height=8)
        args.update(kw)
        with pytest.raises(ValueError):
            renderer.render(builtin, cams, **args)
    with pytest.raises(ValueError):
        renderer.render("not a scene", cams, 8, 8)
    with pytest.raises(ValueError):
        rqr.Cameras(c2w=np.eye(3), fov_y_deg=40)
    with pytest.raises(ValueError):
        rqr.Cameras(c2w=np.diag([2.0, 2.0, 2.0, 1.0]), fov_y_deg=40)
    with pytest.raises(ValueError):
        rqr.Cameras(c2w=np.eye(4), fov_y_deg=40, convention="blender")
    with pytest.raises(ValueError):
        rqr.Cameras(c2w=np.eye(4), fov_y_deg=200)
    with pytest.raises(ValueError):
        rqr.Cameras(c2w=np.eye(4), K=[[100, 0, 10], [0, 120, 10], [0, 0, 1]])
    off_centre = rqr.Cameras(c2w=np.eye(4), K=[[100, 0, 3], [0, 100, 4], [0, 0, 1]])
    with pytest.raises(ValueError):
        renderer.render(builtin, off_centre, 8, 8)
    with pytest.raises(ValueError):
        rqr.Renderer(backend="optix")
    with pytest.raises(ValueError):
        rqr.Renderer(device=-1)
    with pytest.raises(ValueError):
        rqr.Renderer(device="uuid:1234")
    with pytest.raises(RuntimeError):
        rqr.Renderer(device=99)
    with pytest.raises(ValueError):
        renderer.render_many([], prefetch=-1).__next__()


def test_scene_errors(renderer, tmp_path):
    with pytest.raises(rqr.SceneError, match="missing.glb"):
        renderer.load(tmp_path / "missing.glb")
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]}')
    with pytest.raises(rqr.SceneError, match="broken.gltf"):
        renderer.load(broken)
    with pytest.raises(rqr.SceneError):
        renderer.load(asset("Box"), variant="no-such-variant")
    with pytest.raises(rqr.SceneError):
        renderer.load(asset("Box"), scene=5)


def test_environment(renderer, builtin, tmp_path):
    # A uniform grey equirect map written as Radiance HDR: misses see it.
    hdr = tmp_path / "grey.hdr"
    w, h = 16, 8
    rows = b"".join(bytes([128, 128, 128, 129]) * w for _ in range(h))
    hdr.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w) + rows)
    cams = rqr.Cameras.orbit(builtin.bounds, n=1, distance=float(np.linalg.norm(builtin.bounds[1] - builtin.bounds[0])) * 3)
    lit = renderer.render(builtin, cams, 32, 32, environment=hdr, aovs=("rgb", "mask"))
    plain = renderer.render(builtin, cams, 32, 32, aovs=("rgb", "mask"))
    miss = ~lit.mask[0]
    assert miss.any()
    assert np.allclose(lit.rgb[0][miss], 1.0, atol=0.02)
    assert not np.allclose(plain.rgb[0][miss], 1.0, atol=0.02)


def test_nerf_example(tmp_path):
    import json
    import pathlib
    import subprocess
    import sys

    example = pathlib.Path(__file__).resolve().parents[1] / "examples" / "nerf_dataset.py"
    out = tmp_path / "ds"
    subprocess.run([sys.executable, str(example), str(asset("Avocado")), "-o", str(out), "-n", "3", "--size", "24"], check=True, capture_output=True)
    t = json.loads((out / "transforms.json").read_text())
    assert len(t["frames"]) == 3 and t["w"] == 24
    for f in t["frames"]:
        assert (out / f["file_path"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        d = np.load(out / f["depth_file_path"])
        assert d.shape == (24, 24) and np.isfinite(d).any()
