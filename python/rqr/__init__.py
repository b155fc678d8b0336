"""rqr: a glTF 2.0 renderer on Vulkan. Load a scene once, render batches of cameras into
numpy arrays.

    import rqr
    with rqr.Renderer() as r:
        scene = r.load("asset.glb")
        cams = rqr.Cameras.orbit(scene.bounds, n=12)
        out = r.render(scene, cams, 512, 512, aovs=("rgb", "depth", "instance"))

Conventions:
  * ``depth`` is the distance along the camera ray (as Mitsuba and Kubric), ``z`` the
    view-space depth along the optical axis (as pyrender); both are +inf on a miss.
  * ``instance`` and ``primitive`` are int32, -1 on a miss, exact at any scene size: the
    renderer stores them as uint32 on the GPU. ``AOV_ID_EXACT_LIMIT`` (2**31) is where int32
    would overflow; ``Renderer.render`` refuses scenes with that many instances.
  * ``normal`` is the world-space shading normal (normal-mapped, facing the camera),
    ``geometric_normal`` the triangle's, ``albedo`` the linear base colour after texture,
    vertex colour and factor in [0, 1]: the guides Intel Open Image Denoise takes. All are 0 on
    a miss.
  * Cameras: ``convention="opengl"`` (glTF: the camera looks down -Z, +Y up) or
    ``"opencv"`` (looks down +Z, +Y down). Pixels are square and the principal point is the
    image centre.

Nothing touches Vulkan at import: the system Vulkan loader is opened by the first
``Renderer``.
"""

from __future__ import annotations

import concurrent.futures
import math
import os
from typing import Iterable, Iterator, Optional, Sequence, Tuple, Union

import numpy as np

from . import _rqr
from ._rqr import AOV_ID_EXACT_LIMIT, SceneError, read_exr

__all__ = [
    "AOV_ID_EXACT_LIMIT",
    "AOVS",
    "Cameras",
    "RenderResult",
    "Renderer",
    "Scene",
    "SceneError",
    "read_exr",
]

#: Every AOV ``Renderer.render`` returns by default.
AOVS = ("rgb", "depth", "z", "normal", "geometric_normal", "albedo", "instance", "primitive", "mask")

# OpenCV camera axes from OpenGL ones: x stays, y and z flip.
_FLIP_YZ = np.diag([1.0, -1.0, -1.0, 1.0])


class Scene:
    """A scene uploaded to a renderer's device with its acceleration structures (built once
    at ``Renderer.load``). ``bounds`` is ``(min xyz, max xyz)``; ``instances[id]`` maps the
    ``instance`` AOV back to the glTF node, mesh, primitive and material."""

    def __init__(self, native: "_rqr.Scene"):
        self._native = native
        self.source: str = native.source
        lo, hi = native.bounds
        self.bounds: Tuple[np.ndarray, np.ndarray] = (np.array(lo, np.float64), np.array(hi, np.float64))
        self.instances: list = native.instances
        self.triangles: int = native.triangles
        self.upload_ms: float = native.upload_ms

    def default_camera(self, width: int, height: int) -> "Cameras":
        """The camera ``rqr render`` uses without camera flags: the file's first camera, else
        the automatic one framing the bounds."""
        c2w, yfov = self._native.default_camera(width / height)
        if not math.isfinite(yfov):
            raise ValueError(f"{self.source}: the first camera is orthographic; rqr.Cameras are perspective")
        return Cameras(c2w=np.array(c2w, np.float64)[None], fov_y_rad=np.array([yfov], np.float64))

    def __repr__(self) -> str:
        return f"rqr.Scene({self.source!r}, {len(self.instances)} instances, {self.triangles} triangles)"


class Cameras:
    """N pinhole cameras: camera-to-world matrices and vertical fields of view (or
    intrinsics ``K``, with square pixels and the principal point at the image centre).

    ``c2w`` is ``[N,4,4]`` (or ``[4,4]``) in ``convention`` "opengl" (looks down -Z, +Y up,
    as glTF and NeRF's transforms.json) or "opencv" (looks down +Z, +Y down). Rotations must
    be orthonormal (no scale)."""

    def __init__(
        self,
        c2w,
        fov_y_deg=None,
        K=None,
        convention: str = "opengl",
        fov_y_rad=None,
    ):
        m = np.asarray(c2w, dtype=np.float64)
        if m.shape == (4, 4):
            m = m[None]
        if m.ndim != 3 or m.shape[1:] != (4, 4) or m.shape[0] == 0:
            raise ValueError(f"c2w has shape {m.shape}; expected [N, 4, 4]")
        if not np.all(np.isfinite(m)):
            raise ValueError("c2w has non-finite entries")
        if not np.allclose(m[:, 3], [0.0, 0.0, 0.0, 1.0], atol=1e-6):
            raise ValueError("c2w's last row must be [0, 0, 0, 1]")
        rot = m[:, :3, :3]
        err = np.abs(np.einsum("nji,njk->nik", rot, rot) - np.eye(3)).max(axis=(1, 2))
        if np.any(err > 1e-4):
            bad = int(np.argmax(err))
            raise ValueError(f"camera {bad}: c2w's rotation is not orthonormal (scale or shear); rqr cameras have none")
        if convention == "opengl":
            self.c2w = m
        elif convention == "opencv":
            self.c2w = m @ _FLIP_YZ
        else:
            raise ValueError(f'convention={convention!r}: expected "opengl" or "opencv"')
        n = m.shape[0]
        given = sum(x is not None for x in (fov_y_deg, K, fov_y_rad))
        if given != 1:
            raise ValueError("give exactly one of fov_y_deg or K")
        self._K = None
        if K is not None:
            k = np.asarray(K, dtype=np.float64)
            if k.shape == (3, 3):
                k = np.broadcast_to(k, (n, 3, 3)).copy()
            if k.shape != (n, 3, 3):
                raise ValueError(f"K has shape {k.shape}; expected [3, 3] or [{n}, 3, 3]")
            if not np.all(np.isfinite(k)) or np.any(k[:, 0, 0] <= 0) or np.any(k[:, 1, 1] <= 0):
                raise ValueError("K needs positive finite focal lengths")
            if not np.allclose(k[:, 0, 1], 0) or not np.allclose(k[:, 2], [0, 0, 1]) or not np.allclose(k[:, 1, 0], 0):
                raise ValueError("K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]")
            if not np.allclose(k[:, 0, 0], k[:, 1, 1], rtol=1e-5):
                raise ValueError("K: fx and fy differ; rqr renders square pixels")
            self._K = k
            self.fov_y_rad = None
        else:
            rad = np.asarray(fov_y_rad if fov_y_rad is not None else np.radians(np.asarray(fov_y_deg, np.float64)), np.float64)
            rad = np.broadcast_to(rad, (n,)).copy()
            if not np.all((rad > 0) & (rad < math.pi)):
                raise ValueError("fov_y_deg must be in (0, 180) degrees")
            self.fov_y_rad = rad

    def __len__(self) -> int:
        return self.c2w.shape[0]

    @classmethod
    def orbit(
        cls,
        bounds,
        n: int = 12,
        elevation_deg=(-10.0, 40.0),
        fov_y_deg: float = 40.0,
        seed: int = 7,
        distance: Optional[float] = None,
    ) -> "Cameras":
        """``n`` cameras on a sphere about the bounds' centre, looking at it (+Y up): azimuths
        evenly spaced with a seeded random start, elevations drawn uniformly in
        ``elevation_deg`` (a pair) or fixed (a number). The distance frames the bounding
        sphere in ``fov_y_deg`` unless given."""
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n={n!r}: at least one camera")
        if not (0.0 < float(fov_y_deg) < 180.0):
            raise ValueError(f"fov_y_deg={fov_y_deg!r} must be in (0, 180)")
        lo, hi = (np.asarray(b, np.float64) for b in bounds)
        if lo.shape != (3,) or hi.shape != (3,):
            raise ValueError("bounds must be (min xyz, max xyz)")
        center = (lo + hi) / 2 if np.all(hi >= lo) else np.zeros(3)
        radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-4) if np.all(hi >= lo) else 0.5
        rng = np.random.default_rng(seed)
        if np.ndim(elevation_deg) == 0:
            elev = np.full(n, float(elevation_deg))
        else:
            e0, e1 = (float(e) for e in elevation_deg)
            if not (-90 < e0 <= e1 < 90):
                raise ValueError(f"elevation_deg={elevation_deg!r}: need -90 < low <= high < 90")
            elev = rng.uniform(e0, e1, n)
        start = rng.uniform(0.0, 2 * math.pi)
        azim = start + np.arange(n) * (2 * math.pi / n)
        dist = distance if distance is not None else radius / math.sin(math.radians(fov_y_deg) / 2) * 1.05
        el = np.radians(elev)
        eye = center + dist * np.stack([np.cos(el) * np.sin(azim), np.sin(el), np.cos(el) * np.cos(azim)], axis=1)
        return cls(c2w=np.stack([_look_at(e, center) for e in eye]), fov_y_deg=fov_y_deg)

    def fov_y_for(self, height: int) -> np.ndarray:
        """Vertical fields of view (radians) for images ``height`` pixels tall."""
        if self.fov_y_rad is not None:
            return self.fov_y_rad
        return 2.0 * np.arctan2(height / 2.0, self._K[:, 1, 1])

    def K_for(self, width: int, height: int) -> np.ndarray:
        """Intrinsics ``[N,3,3]`` (pixels; origin at the top-left corner of the top-left
        pixel, pixel centres at +0.5) for images of ``width`` x ``height``."""
        if self._K is not None:
            cx, cy = self._K[:, 0, 2], self._K[:, 1, 2]
            if not (np.allclose(cx, width / 2, atol=1e-3) and np.allclose(cy, height / 2, atol=1e-3)):
                raise ValueError(f"K's principal point must be the image centre ({width / 2}, {height / 2}) for {width}x{height}")
            return self._K.copy()
        f = (height / 2.0) / np.tan(self.fov_y_rad / 2.0)
        k = np.zeros((len(self), 3, 3))
        k[:, 0, 0] = f
        k[:, 1, 1] = f
        k[:, 0, 2] = width / 2.0
        k[:, 1, 2] = height / 2.0
        k[:, 2, 2] = 1.0
        return k


def _look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    back = eye - target
    back = back / np.linalg.norm(back)
    right = np.cross(up, back)
    if np.linalg.norm(right) < 1e-9:
        right = np.cross((0.0, 0.0, 1.0), back)
    right = right / np.linalg.norm(right)
    true_up = np.cross(back, right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, back, eye
    return m


class RenderResult(dict):
    """The arrays of a render (keys as requested: rgb, depth, z, normal, geometric_normal,
    albedo, instance, primitive, mask; each with a leading view axis), plus ``cameras`` and
    ``stats``."""

    def __init__(self, arrays: dict, cameras: dict, stats: dict):
        super().__init__(arrays)
        self.cameras = cameras
        self.stats = stats

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def transforms(self, file_paths: Sequence[str]) -> dict:
        """A NeRF-style ``transforms.json`` dict for the views, ``file_paths[i]`` naming
        view i's image (OpenGL c2w, shared intrinsics when all views share them)."""
        c = self.cameras
        n = len(c["c2w_opengl"])
        if len(file_paths) != n:
            raise ValueError(f"{len(file_paths)} file paths for {n} views")
        K = c["K"]
        frames = []
        for i in range(n):
            frame = {"file_path": str(file_paths[i]), "transform_matrix": c["c2w_opengl"][i].tolist()}
            frame.update(fl_x=float(K[i, 0, 0]), fl_y=float(K[i, 1, 1]), cx=float(K[i, 0, 2]), cy=float(K[i, 1, 2]))
            frames.append(frame)
        out = {
            "camera_model": "OPENCV",
            "w": c["width"],
            "h": c["height"],
            "camera_angle_x": float(2 * math.atan(c["width"] / 2 / K[0, 0, 0])),
            "fl_x": float(K[0, 0, 0]),
            "fl_y": float(K[0, 1, 1]),
            "cx": float(K[0, 0, 2]),
            "cy": float(K[0, 1, 2]),
            "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0,
            "frames": frames,
        }
        return out


class Renderer:
    """An opened Vulkan device. ``device``: "auto", an index (as ``rqr probe`` lists them),
    "uuid:…" or a name substring; ``backend``: "auto" (measured once per device and cached),
    "hw" (ray queries) or "bvh" (compute-shader BVH); ``cache_dir``: where the autotune
    measurements are kept (default: the user cache directory).

    Close it with ``close()`` or use it as a context manager. A renderer belongs to the
    process that created it: used in a ``fork()`` child it raises RuntimeError."""

    def __init__(self, device: Union[str, int] = "auto", backend: str = "auto", cache_dir: Optional[Union[str, os.PathLike]] = None):
        if isinstance(device, bool) or not isinstance(device, (str, int, np.integer)):
            raise ValueError(f"device={device!r}: expected \"auto\", an index, \"uuid:…\" or a name")
        if not isinstance(backend, str):
            raise ValueError(f"backend={backend!r}: expected \"auto\", \"hw\" or \"bvh\"")
        self._native = _rqr.Renderer(int(device) if not isinstance(device, str) else device, backend, None if cache_dir is None else os.fspath(cache_dir))
        self._info = dict(self._native.info())

    @property
    def device(self) -> dict:
        """Name, uuid, type, driver, and the backend / raster / BVH build chosen with why."""
        return dict(self._info)

    @property
    def pid(self) -> int:
        """The process that created the renderer."""
        return self._native.pid

    @property
    def closed(self) -> bool:
        return self._native.closed

    def close(self) -> None:
        """Releases the device (scenes keep their GPU memory until they are dropped)."""
        self._native.close()

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else f"{self._info['name']}, {self._info['backend']}"
        return f"rqr.Renderer({state})"

    def load(self, path: Optional[Union[str, os.PathLike]] = None, scene: Optional[int] = None, variant: Optional[str] = None) -> Scene:
        """Parses a glTF/GLB file (None: the built-in scene), uploads it and builds its
        acceleration structures, once. Loader errors raise ``rqr.SceneError`` naming the
        file and the element."""
        return self._upload(_parse(path, scene, variant))

    def _upload(self, host) -> Scene:
        return Scene(self._native.upload(host))

    def render(
        self,
        scene: Scene,
        cameras: Cameras,
        width: int = 512,
        height: int = 512,
        mode: str = "rt",
        shading: str = "whitted",
        spp: int = 1,
        environment: Optional[Union[str, os.PathLike]] = None,
        aovs: Iterable[str] = AOVS,
        tonemap: Optional[str] = None,
        max_depth: int = 5,
        seed: int = 0,
    ) -> RenderResult:
        """Renders every camera of ``cameras`` (one batch, the GIL released throughout).

        ``mode``: "rt" (ray-traced) or "hybrid" (raster primary visibility); ``shading``:
        "whitted" (pixel centres) or "distributed" (soft shadows, glossy reflection; ``spp``
        Owen-scrambled Sobol samples per pixel, a function of ``seed``); ``environment``: None or an equirectangular .hdr/.exr lighting the scene;
        ``tonemap``: None (linear float32 rgb) or "srgb8" (clamped sRGB uint8; also
        "khronos_neutral", "aces")."""
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be an rqr.Scene from Renderer.load, not {type(scene).__name__}")
        if not isinstance(cameras, Cameras):
            raise ValueError(f"cameras must be rqr.Cameras, not {type(cameras).__name__}")
        for name, v in (("width", width), ("height", height), ("spp", spp), ("max_depth", max_depth)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name}={v!r} must be a positive integer")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not (0 <= seed < 2**32):
            raise ValueError(f"seed={seed!r} must be an integer in [0, 2**32)")
        if isinstance(aovs, str):
            aovs = (aovs,)
        aovs = tuple(aovs)
        if not aovs:
            raise ValueError("aovs is empty")
        if len(scene.instances) >= AOV_ID_EXACT_LIMIT:
            raise ValueError(f"{scene.source}: {len(scene.instances)} instances; int32 ids end at 2**31")
        if environment is not None:
            environment = os.fspath(environment)
            if not os.path.isfile(environment):
                raise ValueError(f"environment={environment!r}: no such file")
        K = cameras.K_for(width, height)
        fov = cameras.fov_y_for(height)
        c2w_gl = cameras.c2w
        raw = self._native.render(
            scene._native,
            np.ascontiguousarray(c2w_gl, dtype=np.float32),
            np.ascontiguousarray(fov, dtype=np.float32),
            int(width), int(height), mode, shading, int(spp), int(max_depth), int(seed),
            environment, list(aovs), tonemap,
        )
        stats = raw.pop("stats")
        used = c2w_gl.astype(np.float32).astype(np.float64)
        cams = {
            "c2w_opengl": used,
            "c2w_opencv": used @ _FLIP_YZ,
            "K": K,
            "fov_y_deg": np.degrees(fov.astype(np.float32).astype(np.float64)),
            "width": int(width),
            "height": int(height),
        }
        return RenderResult(raw, cams, stats)

    def render_many(self, jobs: Iterable[Tuple[Union[str, os.PathLike, None], Cameras]], prefetch: int = 2, **render_args) -> Iterator[Tuple[Scene, RenderResult]]:
        """Renders ``(scene path, cameras)`` jobs in order, yielding ``(scene, result)``;
        up to ``prefetch`` following scenes are parsed (glTF, textures) on a worker thread
        while the current one renders. ``render_args`` go to ``render``."""
        if isinstance(prefetch, bool) or not isinstance(prefetch, (int, np.integer)) or prefetch < 0:
            raise ValueError(f"prefetch={prefetch!r} must be a non-negative integer")
        jobs = iter(jobs)
        with concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="rqr-prefetch") as pool:
            pending: list = []

            def submit() -> bool:
                try:
                    path, cams = next(jobs)
                except StopIteration:
                    return False
                pending.append((pool.submit(_parse, path, None, None), cams))
                return True

            for _ in range(max(prefetch, 0) + 1):
                if not submit():
                    break
            while pending:
                future, cams = pending.pop(0)
                host = future.result()
                submit()
                scene = self._upload(host)
                yield scene, self.render(scene, cams, **render_args)
                del scene


def _parse(path, scene, variant):
    if path is not None:
        path = os.fspath(path)
    if scene is not None and (isinstance(scene, bool) or not isinstance(scene, (int, np.integer)) or scene < 0):
        raise ValueError(f"scene={scene!r} must be a non-negative scene index")
    if variant is not None and not isinstance(variant, str):
        raise ValueError(f"variant={variant!r} must be a string")
    return _rqr.parse(path, None if scene is None else int(scene), variant)
