"""Helpers shared by the test modules (``from helpers import ...``; tests/ is on sys.path)."""

import contextlib
import gc

import jax
import numpy as np


def tree_allclose(x, y, *, rtol=1e-7, atol=0.0) -> bool:
    leaves_x, tree_x = jax.tree_util.tree_flatten(x)
    leaves_y, tree_y = jax.tree_util.tree_flatten(y)
    return tree_x == tree_y and all(np.allclose(a, b, rtol=rtol, atol=atol) for a, b in zip(leaves_x, leaves_y, strict=True))


class Ticks:
    """A progress bar that counts (``tofjax.progress.reporting(Ticks())``): ``n`` ticks of ``total``."""

    n, total = 0, 0.0

    def update(self, k=1):
        self.n += k

    def close(self):
        pass


def fd_check(f, x0, rtol=1e-4):
    """jax.grad(f) against a central finite difference (step 1e-6 relative) at the float x0."""
    g = float(jax.grad(f)(x0))
    h = 1e-6 * abs(x0)
    fd = (float(f(x0 + h)) - float(f(x0 - h))) / (2 * h)
    scale = abs(float(f(x0))) / abs(x0)  # a derivative this small is "zero" at this precision
    assert np.isfinite(g)
    assert abs(g - fd) <= rtol * max(abs(fd), 1e-6 * scale), (g, fd)


def split_between_taps(fraction_a, contrast, active_e, background_e):
    """The tap split of the one exposure (tofjax._charges.Exposure.charges): photo-electrons of taps A
    and B from the correlation fractions a_j (Eqs 3.19-3.21)."""
    import jax.numpy as jnp

    from tofjax._charges import Exposure

    active_e, background_e = jnp.asarray(active_e, dtype=float), jnp.asarray(background_e, dtype=float)
    contrast = jnp.asarray(contrast, dtype=float)
    zero = jnp.zeros(active_e.shape)
    q = Exposure(contrast * active_e[..., None] * fraction_a, active_e, background_e, contrast, jnp.zeros(()),
                 zero, zero).charges()
    return q.photo_a, q.photo_b


#: The frame tests' small camera: 31 x 21 pixels (odd, so a pixel sits on the axis) of the default pitch.
PITCH = 17.5e-6
COLS, ROWS = 31, 21


def small(params=None):
    """``params`` (default: the defaults) with the small camera's array (:data:`COLS` x :data:`ROWS`)."""
    import equinox as eqx
    import jax.numpy as jnp
    import tofjax as tj

    p = tj.Params() if params is None else params
    return eqx.tree_at(lambda q: q.camera.optical_area_m, p, jnp.array([COLS * PITCH, ROWS * PITCH]))


def opencv_project(points, camera_matrix, dist_coeffs):
    """OpenCV's ``projectPoints`` with no rotation or translation, in NumPy, from its documentation
    ("Camera Calibration and 3D Reconstruction"): OpenCV camera frame (x right, y down)."""
    k1, k2, p1, p2, k3 = dist_coeffs
    x, y = points[..., 0] / points[..., 2], points[..., 1] / points[..., 2]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    k = np.asarray(camera_matrix)
    return np.stack([k[0, 0] * xd + k[0, 2], k[1, 1] * yd + k[1, 2]], axis=-1)


def to_opencv(points):
    """tofjax's camera frame (y up) to OpenCV's (y down)."""
    return points * np.array([1.0, -1.0, 1.0])


def traces(fn):
    """The names of the programs ``fn`` traced (none: it ran programs traced before) and its result."""
    names = []

    def listen(event, duration, **kwargs):
        if event == "/jax/core/compile/jaxpr_trace_duration":
            names.append(kwargs.get("fun_name"))

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        out = fn()
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    return names, out


@contextlib.contextmanager
def examples_as_scripts():
    """Run documented examples that turn the compilation cache (and its notice) on as a script does,
    ``tj.enable_compilation_cache()``; afterwards this worker's tests compile as before: the cache's
    directory and threshold restored (the examples keep every program, the suite only those above
    its threshold), no notice."""
    from tofjax import progress

    before = (jax.config.jax_compilation_cache_dir, jax.config.jax_persistent_cache_min_compile_time_secs)
    try:
        yield
    finally:
        progress.compile_notice(False)
        jax.config.update("jax_compilation_cache_dir", before[0])
        jax.config.update("jax_persistent_cache_min_compile_time_secs", before[1])


def out_of_the_collectors_way() -> None:
    """Collect the young garbage and move every surviving object out of the garbage collector's
    generations (``gc.freeze``): after each test (tests/conftest.py), and between the blocks of a
    long example. A worker holds millions of objects by the end (JAX's traced and compiled
    programs), and CPython's full collections scanned them all, each taking longer as the worker
    grew (20-22 s of each worker's time). Cycles that became garbage earlier are not collected."""
    gc.collect(1)
    gc.freeze()
