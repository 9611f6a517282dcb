"""The packed parameters generated from each law's declaration (materials/base.py ``packed_slots``).

Checks: the Warp accessors ``cls.packed(t)`` read back, from ``pack()``, exactly the value of every
declared parameter, option code, tuple entry and derived value, for every registered law and for
composed laws whose blocks sit behind variable-length inner laws (Failure over Viscoelastic over
Ogden); options are validated from their ``Literal``; derived values are not parameters; the shared
signature decorator refuses a wrong argument list; a law declared in a test module (no hand-written
layout) gives the stress of its NumPy closed form.
"""

import dataclasses
import functools
import typing
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pytest
import warp as wp

import tissuempm.materials  # noqa: F401  (registers every law)
from tissuempm.materials import (
    MATERIALS,
    ElasticPlastic,
    Failure,
    NeoHookean,
    Ogden,
    ParameterError,
    Viscoelastic,
    Weiss,
    from_dict,
)
from tissuempm.materials.base import HEADER, derived, option, packed_slots, parameter
from tissuempm.materials.drivers import PointEvaluator
from tissuempm.materials.invariant_hyperelastic import InvariantHyperelastic
from tissuempm.materials.warp_interface import option_codes, stress_func
from tissuempm.precision import warp_types

wp.config.quiet = True


def _expected(m) -> list[float]:
    """The values the accessors must return, in slot order, from the Python attributes."""
    out = [float(m.density), *map(float, m.wave_moduli())]
    for sl in packed_slots(type(m)):
        v = getattr(m, sl.name)
        if sl.kind == "sequence":
            out += [float(len(v)), *map(float, v)]
        elif sl.kind == "option":
            out.append(float(sl.choices.index(v)))
        elif sl.kind == "value":
            out.append(float(v))
    return out


def _step(t, prev, get, count, kind):
    """One link of the reader chain: ``prev`` writes the values before this slot, this one its own."""
    s = t.scalar
    if kind == "sequence":

        @wp.func
        def seq(prm: wp.array(dtype=s), out: wp.array(dtype=s), i: int):
            j = prev(prm, out, i)
            c = count(prm)
            out[j] = s(c)
            for k in range(c):
                out[j + 1 + k] = get(prm, k)
            return j + 1 + c

        return seq
    if kind == "option":

        @wp.func
        def code(prm: wp.array(dtype=s), out: wp.array(dtype=s), i: int):
            j = prev(prm, out, i)
            out[j] = s(get(prm))
            return j + 1

        return code

    @wp.func
    def value(prm: wp.array(dtype=s), out: wp.array(dtype=s), i: int):
        j = prev(prm, out, i)
        out[j] = get(prm)
        return j + 1

    return value


@functools.cache
def _reader(cls: type, precision: str):
    """A kernel writing every accessor's value of ``cls`` (header, then each slot; tuples as count and
    entries) into ``out``: a chain of Warp functions, one per slot, built from ``packed_slots``."""
    t = warp_types(precision)
    s = t.scalar
    P = cls.packed(t)
    steps = [(name, "value") for name in HEADER]
    steps += [(sl.name, sl.kind) for sl in packed_slots(cls) if sl.kind != "law"]

    @wp.func
    def start(prm: wp.array(dtype=s), out: wp.array(dtype=s), i: int):
        return i

    chain = start
    for name, kind in steps:
        chain = _step(t, chain, getattr(P, name), getattr(P, f"{name}_count", None), kind)
    last = chain

    @wp.kernel
    def read(prm: wp.array(dtype=s), out: wp.array(dtype=s)):
        last(prm, out, 0)

    return read


def _read_back(m, precision: str = "float64") -> np.ndarray:
    t = warp_types(precision)
    out = wp.zeros(len(_expected(m)), dtype=t.scalar, device="cpu")
    prm = wp.array(m.pack().astype(t.numpy), dtype=t.scalar, device="cpu")
    wp.launch(_reader(type(m), precision), 1, inputs=[prm, out], device="cpu")
    return out.numpy().astype(float)


OGDEN_VE = Viscoelastic(elastic=Ogden.example(), g=(0.5, 0.2), tau=(1e-3, 1e-1), k=(0.1, 0.05))
COMPOSED = {
    "failure_over_viscoelastic_over_ogden": Failure(base=OGDEN_VE, criterion="green_strain", limit=0.3,
                                                    failed="compression"),
    "viscoelastic_over_ogden": OGDEN_VE,
    "failure_over_ogden": Failure(base=Ogden.example(), criterion="principal_stress", limit=1e5),
    "failure_over_elastic_plastic": Failure(base=ElasticPlastic.example(), criterion="plastic_strain", limit=0.5),
}


@pytest.mark.parametrize("name", sorted(MATERIALS) + sorted(COMPOSED))
def test_accessors_read_every_declared_value(name):
    m = COMPOSED[name] if name in COMPOSED else MATERIALS[name].example()
    # exact: the accessors copy stored values (float64) and round stored whole numbers to int
    np.testing.assert_array_equal(_read_back(m), _expected(m))


def test_float32_accessors_read_the_rounded_values():
    m = COMPOSED["failure_over_viscoelastic_over_ogden"]
    np.testing.assert_array_equal(_read_back(m, "float32"), np.float32(_expected(m)).astype(float))


def test_composed_blocks_are_found_from_the_end():
    """Failure over a Prony law over Ogden: the layer's block start is the second-to-last entry and the
    Prony block start (the last entry) is the viscoelastic law's own pointer, copied."""
    m = COMPOSED["failure_over_viscoelastic_over_ogden"]
    p, pv = m.pack(), OGDEN_VE.pack()
    np.testing.assert_array_equal(p[: pv.size], pv)
    assert p[-1] == pv[-1] and int(p[-2]) == pv.size
    assert p[int(p[-1])] == len(OGDEN_VE.g)  # the Prony block starts with N


def test_option_choices_come_from_the_literal():
    f = next(f for f in dataclasses.fields(Weiss) if f.name == "fiber_kinematics")
    codes = option_codes(f.type)
    assert [getattr(codes, c.upper()) for c in typing.get_args(f.type)] == [0, 1]
    with pytest.raises(ParameterError, match=r"Weiss.fiber_kinematics = 'I4': valid are isochoric, full"):
        Weiss(fiber_kinematics="I4")
    with pytest.raises(ParameterError, match=r"Failure.failed = 'none': valid are stress_free, compression"):
        Failure(base=NeoHookean(), failed="none")


def test_derived_values_are_not_parameters():
    m = Weiss.example()
    assert "C6" not in m.to_dict() and from_dict(m.to_dict()) == m
    # C0 continuity of the fiber stress at lam*, written out here: C6 = C3 (exp(C4 (lam* - 1)) - 1) - C5 lam*
    assert m.C6 == pytest.approx(m.C3 * (np.exp(m.C4 * (m.lam_star - 1.0)) - 1.0) - m.C5 * m.lam_star, rel=1e-14)
    with pytest.raises(ParameterError, match="unknown parameter"):
        from_dict({**m.to_dict(), "C6": 1.0})
    assert m.replace(C5=2.0e5).C6 != m.C6  # recomputed from the new parameters


def test_interface_signature_is_checked():
    t = warp_types("float64")
    with pytest.raises(TypeError, match="takes \\(F, L, a0, prm, s_in, s_out, p, dt\\)"):

        @stress_func(t)
        def stress(F, L, a0, prm, s_in, s_out, p):  # dt missing
            return F


Switch = Literal["plain", "doubled"]
SWITCH = option_codes(Switch)


@dataclass(frozen=True, kw_only=True)
class _TwoTerm(InvariantHyperelastic):
    """A law declared only here (no ``kind``, so not registered): W = c (C1 (I1b - 3) + C2 (I2b - 3)),
    c = 2 when ``scale = "doubled"``; its Warp derivatives read the generated accessors."""

    C1: float = parameter("Pa", default=1.0e3, gt=0.0)
    scale: Switch = option("plain")
    C2: float = parameter("Pa", default=0.0, ge=0.0)
    c: float = derived(lambda m: 2.0 if m.scale == "doubled" else 1.0)  # packed only (computed after check())

    def iso_derivatives(self, I1, I2):
        f = 2.0 if self.scale == "doubled" else 1.0
        return f * self.C1 + 0.0 * I1, f * self.C2 + 0.0 * I2

    @classmethod
    def _build_derivatives(cls, t):
        s = t.scalar
        P = cls.packed(t)

        @wp.func
        def dW(I1: s, I2: s, prm: wp.array(dtype=s)):
            f = s(1.0)
            if P.scale(prm) == SWITCH.DOUBLED:
                f = s(2.0)
            return f * P.C1(prm), f * P.C2(prm)

        return dW


@pytest.mark.parametrize("scale", ["plain", "doubled"])
def test_a_law_declared_elsewhere_gets_its_layout(scale):
    m = _TwoTerm(C1=1.2e3, C2=300.0, K=2.0e6, scale=scale, volumetric="log")
    assert m.pack().tolist()[3:] == [1.0, 2.0e6, 1.2e3, float(scale == "doubled"), 300.0, m.c]
    F = np.array([[1.1, 0.05, 0.0], [0.02, 0.95, 0.03], [0.0, -0.04, 0.97]])
    sig, _ = PointEvaluator(m)(F[None], np.zeros((1, 3, 3)), m.initial_state(), 1.0)
    # the NumPy chain rule of the same law (invariant_hyperelastic.py), float64 round-off of K ln J terms
    np.testing.assert_allclose(sig[0], m.cauchy_stress(F), rtol=1e-10, atol=1e-9 * m.K)
