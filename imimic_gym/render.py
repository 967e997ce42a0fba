"""Headless MuJoCo rendering: RGB and depth from one pass, segmentation and depth from
another.

``mujoco.Renderer`` renders once per output (RGB, depth and segmentation each cost a full
pass). On the software EGL renderer a pass of the demonstrator scene costs a few ms, so
this reads colour and depth back from the same pass, and leaves anti-aliasing and shadows
off (``offsamples=0``, ``shadowsize=0``): with MSAA a 240x320 frame costs ~5x more.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["OffscreenRenderer", "project_points"]


class OffscreenRenderer:
    """Renders one camera of one model into numpy arrays. Close it, or use ``with``."""

    def __init__(self, model: mujoco.MjModel, height: int, width: int) -> None:
        if height <= 0 or width <= 0:
            raise ValueError(f"image size must be positive, got {height}x{width}")
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        model.vis.quality.offsamples = 0
        self.model, self.height, self.width = model, height, width
        self._gl = mujoco.GLContext(width, height)
        self._gl.make_current()
        self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._scene = mujoco.MjvScene(model, maxgeom=1000)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._zbuffer = np.empty((height, width), dtype=np.float32)
        extent = model.stat.extent
        self._near = model.vis.map.znear * extent
        self._far = model.vis.map.zfar * extent

    def _update(self, data: mujoco.MjData, camera: int, groups: tuple[int, ...] | None) -> None:
        self._option.geomgroup[:] = 1 if groups is None else 0
        for group in groups or ():
            self._option.geomgroup[group] = 1
        self._camera.fixedcamid = camera
        mujoco.mjv_updateScene(
            self.model, data, self._option, self._perturb, self._camera,
            mujoco.mjtCatBit.mjCAT_ALL, self._scene,
        )

    def render(
        self, data: mujoco.MjData, camera: int, depth: bool = False,
        out: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """RGB (H, W, 3) uint8 and, if asked, depth (H, W) float32 metres, from one pass.
        ``out``: an (H, W, 3) uint8 array (a view into a larger picture will do) that
        receives the RGB and is returned, instead of a new array."""
        self._check_out(out)
        self._draw(data, camera)
        return self._read(out, depth)

    def start(self, data: mujoco.MjData, camera: int) -> None:
        """Begin drawing the RGB picture that `render` would give, and return without
        waiting for it: the GL driver draws it meanwhile (Mesa's software renderer on a
        thread of its own). `finish` reads it back."""
        from OpenGL import GL  # after mujoco has chosen the GL platform

        self._draw(data, camera)
        GL.glFlush()  # hands the drawing to the driver now, not at the read-back

    def finish(self, out: np.ndarray | None = None) -> np.ndarray:
        """The RGB picture (H, W, 3) uint8 that `start` began, into ``out`` as in
        `render`; it waits for the drawing to end. Nothing else may draw with this
        renderer in between."""
        self._check_out(out)
        self._gl.make_current()
        rgb, _ = self._read(out, depth=False)
        return rgb

    def _check_out(self, out: np.ndarray | None) -> None:
        if out is not None and (out.shape != self._rgb.shape or out.dtype != np.uint8):
            raise ValueError(f"out must be {self._rgb.shape} uint8 for this renderer, got "
                             f"{out.shape} {out.dtype}")

    def _draw(self, data: mujoco.MjData, camera: int) -> None:
        self._gl.make_current()
        self._update(data, camera, None)
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 0
        self._scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0
        mujoco.mjr_render(self._rect, self._scene, self._context)

    def _read(self, out: np.ndarray | None, depth: bool
              ) -> tuple[np.ndarray, np.ndarray | None]:
        mujoco.mjr_readPixels(self._rgb, self._zbuffer if depth else None, self._rect,
                              self._context)
        flipped = np.flipud(self._rgb)  # OpenGL's rows run bottom to top
        if out is None:
            rgb = flipped.copy()
        else:
            np.copyto(out, flipped)
            rgb = out
        return rgb, (self._metres() if depth else None)

    def _metres(self, zbuffer: np.ndarray | None = None) -> np.ndarray:
        """OpenGL's non-linear z-buffer (bottom row first) to metres along the camera
        axis, top row first."""
        z = np.flipud(self._zbuffer if zbuffer is None else zbuffer)
        near, ratio = np.float32(self._near), np.float32(1.0 - self._near / self._far)
        return near / (np.float32(1.0) - z * ratio)  # float32 throughout, no extra copy

    def segment(
        self, data: mujoco.MjData, camera: int, groups: tuple[int, ...] | None = None,
        box: tuple[int, int, int, int] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(h, w) int32 model geom id seen at each pixel (-1 for none), and (h, w) float32
        depth in metres, from one pass.

        With ``groups``, only geoms of those groups are drawn, as if nothing else existed.
        With ``box`` = (x0, y0, x1, y1) image pixels (top-left origin, end exclusive), only
        that part is read back: reading and converting the whole frame costs more than
        drawing a few geoms.
        """
        self._gl.make_current()
        self._update(data, camera, groups)
        scene = self._scene
        scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        mujoco.mjr_render(self._rect, scene, self._context)
        x0, y0, x1, y1 = box if box is not None else (0, 0, self.width, self.height)
        rgb = np.empty((y1 - y0, x1 - x0, 3), dtype=np.uint8)
        zbuffer = np.empty((y1 - y0, x1 - x0), dtype=np.float32)
        # OpenGL counts rows from the bottom.
        rect = mujoco.MjrRect(x0, self.height - y1, x1 - x0, y1 - y0)
        mujoco.mjr_readPixels(rgb, zbuffer, rect, self._context)
        # Each scene geom is drawn in colour segid + 1 (0 is the background).
        lut = np.full(scene.ngeom + 1, -1, dtype=np.int32)
        for i in range(scene.ngeom):
            geom = scene.geoms[i]
            if geom.objtype == mujoco.mjtObj.mjOBJ_GEOM and geom.segid >= 0:
                lut[geom.segid + 1] = geom.objid
        code = rgb.astype(np.int32)
        code = code[..., 0] | (code[..., 1] << 8) | (code[..., 2] << 16)
        return np.flipud(lut[np.minimum(code, scene.ngeom)]), self._metres(zbuffer)

    def close(self) -> None:
        if self._gl is not None:
            self._context.free()
            self._gl.free()
            self._gl = None

    def __enter__(self) -> OffscreenRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass


def project_points(
    model: mujoco.MjModel, data: mujoco.MjData, camera: int, points: np.ndarray,
    height: int, width: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (K, 2) float32 (x = column, y = row) of world points (K, 3), and
    their distances (K,) in metres along the camera axis (comparable with rendered depth)."""
    fovy = np.radians(model.cam_fovy[camera])
    focal = 0.5 * height / np.tan(fovy / 2)
    rotation = data.cam_xmat[camera].reshape(3, 3)
    local = (np.asarray(points) - data.cam_xpos[camera]) @ rotation
    distance = -local[:, 2]
    x = width / 2 + focal * local[:, 0] / distance
    y = height / 2 - focal * local[:, 1] / distance
    return np.stack([x, y], axis=1).astype(np.float32), distance
