"""The Warp side of the material interface: the laws' shared function signatures and option codes.

Every law writes its solver functions with one of these argument lists
(:mod:`tissuempm.materials.base`, module docstring)::

    stress(F, L, a0, prm, s_in, s_out, p, dt)          # also stress_moduli and tangent
    moduli(F, a0, prm, s_in, p)
    rate(F, L, a0, prm, s_in, s_out, p, dt, D)          # Kirchhoff stress rate (tangent.rate_tangent)
    dW(I1, I2, prm)                                     # also d2W: an invariant law's derivatives
                                                        # (tissuempm.materials.invariant_hyperelastic)

The decorators :func:`stress_func`, :func:`moduli_func`, :func:`rate_func` and
:func:`invariant_func` give an unannotated Python function those arguments' Warp types for a
precision and make it a ``@wp.func``, so a law writes ``def stress(F, L, a0, prm, s_in, s_out, p, dt):``
once instead of the eight typed lines (and mypy, which does not understand Warp's array and
precision-dependent types as annotations, sees none); a misspelt or missing argument raises
``TypeError`` at build time.

Options (a law's switches, e.g. ``volumetric = "log"``) are declared as a ``Literal`` of their
choices; they are packed as the index of the choice and read in Warp code as an ``int``
(:func:`as_int`) compared with the constants of :func:`option_codes`::

    VOLUMETRIC = option_codes(VolumetricForm)   # VOLUMETRIC.ABAQUS == 0, VOLUMETRIC.LOG == 1

Example
-------
>>> from typing import Literal
>>> codes = option_codes(Literal["stress_free", "compression"])
>>> codes.STRESS_FREE, codes.COMPRESSION
(0, 1)
"""

import functools
import inspect
import typing
from collections.abc import Callable
from typing import Any

import warp as wp

from tissuempm.precision import WarpTypes

STRESS_ARGS: tuple[str, ...] = ("F", "L", "a0", "prm", "s_in", "s_out", "p", "dt")
"""Arguments of a law's stress, stress-and-moduli and tangent functions."""
MODULI_ARGS: tuple[str, ...] = ("F", "a0", "prm", "s_in", "p")
"""Arguments of a law's moduli function."""
RATE_ARGS: tuple[str, ...] = (*STRESS_ARGS, "D")
"""Arguments of a Kirchhoff stress rate (:func:`tissuempm.materials.tangent.rate_tangent`)."""
INVARIANT_ARGS: tuple[str, ...] = ("I1", "I2", "prm")
"""Arguments of an invariant law's derivative functions ``dW`` and ``d2W``: the isochoric invariants
I1b, I2b and the packed parameters (:mod:`tissuempm.materials.invariant_hyperelastic`)."""


def argument_types(t: WarpTypes) -> dict[str, Any]:
    """Warp type of every interface argument at the precision of ``t``."""
    s = t.scalar
    return {
        "F": t.mat33,
        "L": t.mat33,
        "a0": t.vec3,
        "prm": wp.array(dtype=s),
        "s_in": wp.array2d(dtype=s),
        "s_out": wp.array2d(dtype=s),
        "p": int,
        "dt": s,
        "D": t.mat33,
        "I1": s,
        "I2": s,
    }


def _typed(t: WarpTypes, names: tuple[str, ...]) -> Callable[[Callable[..., Any]], Any]:
    def decorate(fn: Callable[..., Any]) -> Any:
        args = tuple(inspect.signature(fn).parameters)
        if args != names:
            raise TypeError(f"{fn.__qualname__}{args}: the interface function takes ({', '.join(names)})")
        types = argument_types(t)
        fn.__annotations__ = {name: types[name] for name in names}
        return wp.func(fn)

    return decorate


def stress_func(t: WarpTypes) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``def f(F, L, a0, prm, s_in, s_out, p, dt)`` as a ``@wp.func`` typed for ``t``."""
    return _typed(t, STRESS_ARGS)


def moduli_func(t: WarpTypes) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``def f(F, a0, prm, s_in, p)`` as a ``@wp.func`` typed for ``t``."""
    return _typed(t, MODULI_ARGS)


def rate_func(t: WarpTypes) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``def f(F, L, a0, prm, s_in, s_out, p, dt, D)`` as a ``@wp.func`` typed for ``t``."""
    return _typed(t, RATE_ARGS)


def invariant_func(t: WarpTypes) -> Callable[[Callable[..., Any]], Any]:
    """Decorator: ``def f(I1, I2, prm)`` as a ``@wp.func`` typed for ``t`` (an invariant law's ``dW``, ``d2W``)."""
    return _typed(t, INVARIANT_ARGS)


def option_codes(choices: Any) -> type:
    """Namespace of the integer code of each choice of an option, ``Literal["a", "b"]`` (or a tuple of
    names) -> ``A = 0, B = 1`` (the index of the choice, upper case), readable in Warp code."""
    names = typing.get_args(choices) if not isinstance(choices, tuple) else choices
    return type("Codes", (), {str(c).upper(): i for i, c in enumerate(names)})


@functools.cache
def as_int(t: WarpTypes) -> Any:
    """``as_int(x) -> int``: a packed code, count or slot index (a whole number stored as a scalar) as an
    ``int``, rounded to the nearest (exact for every stored value, also -1)."""
    s = t.scalar

    @wp.func
    def to_int(x: s):
        return int(wp.floor(x + s(0.5)))

    return to_int
