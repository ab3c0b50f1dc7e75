"""tofjax.jit (tofjax._jit.jit): equinox.filter_jit's semantics (arrays traced, other leaves static)
with one jax.jit per argument structure."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import _jit


class Box(eqx.Module):
    x: jax.Array
    scale: float  # a non-array leaf: static, like equinox.filter_jit
    name: str = eqx.field(static=True, default="box")


def _counted():
    traces = []

    @_jit.jit
    def f(box, power=2, *, shift=0.0):
        traces.append(1)
        return box.scale * box.x**power + shift

    return f, traces


def test_arrays_traced_statics_keyed_and_defaults_bound():
    f, traces = _counted()
    a = Box(jnp.array([1.0, 2.0]), 3.0)
    np.testing.assert_allclose(f(a), [3.0, 12.0], rtol=0, atol=0)
    np.testing.assert_allclose(f(Box(jnp.array([2.0, 3.0]), 3.0)), [12.0, 27.0], rtol=0, atol=0)
    np.testing.assert_allclose(f(a, 2, shift=0.0), [3.0, 12.0], rtol=0, atol=0)  # defaults given: same program
    assert len(traces) == 1
    np.testing.assert_allclose(f(Box(jnp.array([1.0, 2.0]), 4.0)), [4.0, 16.0], rtol=0, atol=0)  # new static value
    np.testing.assert_allclose(f(a, 3), [3.0, 24.0], rtol=0, atol=0)
    np.testing.assert_allclose(f(a, shift=jnp.asarray(1.0)), [4.0, 13.0], rtol=0, atol=0)  # shift now an array
    assert len(traces) == 4


def test_under_grad_vmap_and_jit():
    f, _ = _counted()
    g = jax.grad(lambda x: jnp.sum(f(Box(x, 3.0), shift=x[0])))(jnp.array([1.0, 2.0]))
    np.testing.assert_allclose(g, [6.0 + 2.0, 12.0], rtol=0, atol=0)  # d(3 x^2)/dx + the shift on both elements
    v = jax.vmap(lambda x: f(Box(x, 2.0)))(jnp.arange(6.0).reshape(3, 2))
    np.testing.assert_allclose(v, 2.0 * jnp.arange(6.0).reshape(3, 2) ** 2, rtol=0, atol=0)
    j = jax.jit(lambda x: f(Box(x, 2.0), 1))(jnp.array([5.0]))
    np.testing.assert_allclose(j, [10.0], rtol=0, atol=0)


def test_public_name_is_the_wrapper():
    """The siblings (fitting) compile their hot entry points with it: the public name is this function."""
    assert tofjax.jit is _jit.jit and "jit" in tofjax.__all__


def test_unknown_argument_refused():
    f, _ = _counted()
    with pytest.raises(TypeError):
        f(Box(jnp.ones(1), 1.0), nonsense=1)


class Holder(eqx.Module):
    x: jax.Array

    @_jit.method
    def scaled(self, k: float = 2.0) -> jax.Array:
        """x times k."""
        return k * self.x

    def plain(self):
        return self.x


def test_method_is_bound_without_building_a_module():
    """tofjax._jit.method: an equinox module's method bound as a partial, not as equinox's BoundMethod
    (a module built per access, which checks every leaf of the instance); the class attribute keeps
    its name, docstring and signature; it runs through the class and under jit."""
    import inspect

    h = Holder(jnp.arange(3.0))
    assert isinstance(h.plain, eqx.Module)  # what equinox does to a method
    assert not isinstance(h.scaled, eqx.Module) and h.scaled.func is Holder.scaled.__func__
    assert Holder.scaled.__doc__ == "x times k." and list(inspect.signature(Holder.scaled).parameters) == ["self", "k"]
    np.testing.assert_array_equal(h.scaled(3.0), [0.0, 3.0, 6.0])
    np.testing.assert_array_equal(Holder.scaled(h), [0.0, 2.0, 4.0])
    np.testing.assert_array_equal(jax.jit(lambda g: g.scaled())(h), [0.0, 2.0, 4.0])
    camera = tofjax.Camera(tofjax.Params(), tofjax.FrameSettings())
    assert not isinstance(camera.prepare, eqx.Module) and not isinstance(camera.expose, eqx.Module)
    from tofjax._frame import PreparedCamera, PreparedFrame

    for cls, names in ((PreparedCamera, ("expose", "sample", "noise_image", "predict", "prepare", "render")),
                       (PreparedFrame, ("render", "predict", "noise_image", "sample"))):
        assert all(isinstance(vars(cls)[name], _jit.method) for name in names), cls


def test_a_module_is_flattened_once_while_it_lives(monkeypatch):
    """A module argument is flattened on its first call and looked up by identity afterwards (its
    arrays are immutable); the entry goes with the module, and a module of tracers is never kept."""
    import gc

    f, traces = _counted()
    a = Box(jnp.array([1.0, 2.0]), 3.0)
    f(a)
    assert id(a) in _jit._FLAT
    flattened = []
    real = jax.tree_util.tree_flatten
    monkeypatch.setattr(jax.tree_util, "tree_flatten", lambda x, *r, **k: flattened.append(x) or real(x, *r, **k))
    np.testing.assert_allclose(f(a), [3.0, 12.0], rtol=0, atol=0)
    assert flattened == [2, 0.0] and len(traces) == 1  # only the arguments that are not modules
    b = Box(jnp.array([2.0, 3.0]), 3.0)  # another module of the same structure: flattened, same program
    np.testing.assert_allclose(f(b), [12.0, 27.0], rtol=0, atol=0)
    assert flattened[2:] == [b, 2, 0.0] and len(traces) == 1
    monkeypatch.undo()
    ident = id(b)
    del b, flattened
    gc.collect()
    assert ident not in _jit._FLAT
    size = len(_jit._FLAT)
    jax.jit(lambda x: f(Box(x, 3.0)))(jnp.array([1.0, 2.0]))  # inside a caller's jit: a module of tracers
    assert len(_jit._FLAT) == size
