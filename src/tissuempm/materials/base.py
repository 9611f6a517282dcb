"""The material interface shared by the homogeneous drivers, calibration and the MPM solver.

A material is a frozen, keyword-only dataclass of named parameters. Each
parameter is declared with :func:`parameter`, which records its unit, its valid
range and a start value for calibration; values are validated when the object
is built, and a bad value raises :class:`ParameterError` naming the parameter and
its valid range.

Solver-facing interface (all a solver needs to know about a law)
-----------------------------------------------------------------
``pack()``
    1-D float array: header ``[rho0, K_wave, G_wave]`` followed by the law's own
    parameters (:data:`HEADER` entries; the law's data start at index
    ``len(HEADER)``). The layout is generated from the declaration
    (:func:`packed_slots`): parameters, switches (:func:`option`, packed as codes),
    derived values (:func:`derived`) and an inner law, in declaration order; a law's
    Warp code reads them with the generated accessors ``P = cls.packed(t)``
    (``P.K(prm)``, ``P.volumetric(prm) == VOLUMETRIC.LOG``), never by an index.
``state_vars`` / ``n_state`` / ``initial_state()``
    The law's history variables. The solver allocates an ``(n, n_state)`` array,
    double-buffers it and carries it without interpreting it.
``stress_function(precision)``
    A ``@wp.func`` with the signature::

        stress(F: mat33, L: mat33, a0: vec3, prm: wp.array(dtype=scalar),
               s_in: wp.array2d(dtype=scalar), s_out: wp.array2d(dtype=scalar),
               p: int, dt: scalar) -> mat33

    returning the Cauchy stress [Pa] (tension positive) for deformation gradient
    ``F``, velocity gradient ``L`` [1/s], reference fiber direction ``a0`` (unit
    vector, ignored by isotropic laws), parameters ``prm`` (from ``pack()``),
    history row ``s_in[p]`` at the start of the step and time step ``dt`` [s].
    It must write every entry of ``s_out[p]`` (copying those that do not change).
``moduli_function(precision)``
    A ``@wp.func`` ``moduli(F, a0, prm, s_in, p) -> (K, G)`` giving the
    instantaneous bulk and shear moduli [Pa] used for the dilatational wave
    speed (Ionescu et al. 2006, eq. 9)::

        c = sqrt((K + 4 G / 3) / rho),   rho = rho0 / J.

    The default returns the header's ``K_wave`` and ``G_wave``, which each law
    sets from :meth:`Material.wave_moduli`.
``stress_moduli_function(precision)``
    ``stress_moduli(F, L, a0, prm, s_in, s_out, p, dt) -> (sigma, K, G)``: the
    stress and the moduli of the state it leaves, in one call (the explicit
    stress pass, which also gives the next step's CFL speeds). The default calls
    the two functions above; a law whose moduli reuse its stress's invariants
    overrides ``_build_stress_moduli`` (the same values, computed once).
``tangent_function(precision)``
    A ``@wp.func`` for the implicit solver with the stress function's signature::

        tangent(F, L, a0, prm, s_in, s_out, p, dt) -> M66

    returning the spatial elasticity tensor ``c`` [Pa] (Lie derivative of the
    Kirchhoff stress, ``L_v(tau) = J c : d``) as a 6 x 6 Voigt matrix of plain
    tensor components, order xx, yy, zz, yz, xz, xy; ``M66 =
    tissuempm.materials.kinematics.mat66(warp_types(precision))``. ``s_out[p]``
    may be overwritten (scratch): call the stress function afterwards. The
    default differentiates the stress function numerically (the algorithmic
    tangent of history laws); laws with a standard closed form override
    ``_build_tangent`` (:mod:`tissuempm.materials.tangent`).
"""


import dataclasses
import functools
import math
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import warp as wp

from tissuempm.materials.tangent import numeric_tangent
from tissuempm.materials.warp_interface import as_int, moduli_func, stress_func
from tissuempm.precision import WarpTypes, warp_types

HEADER: tuple[str, ...] = ("density", "K_wave", "G_wave")
"""Names of the leading entries of every packed parameter vector (Warp: ``P.density(prm)``, ...)."""
_PRM_OFFSET = len(HEADER)
"""Index of the first law-specific entry of a packed parameter vector (private: laws read their entries with
the generated accessors, :meth:`Material.packed`)."""

MATERIALS: dict[str, type["Material"]] = {}
"""Registry of material laws by :attr:`Material.kind`."""


class ParameterError(ValueError):
    """A material parameter is missing, not finite or outside its valid range."""


def parameter(
    unit: str,
    *,
    default: Any = dataclasses.MISSING,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    fit: "Fit | None" = None,
    doc: str = "",
) -> Any:
    """Declare a material parameter as a dataclass field.

    Parameters
    ----------
    unit
        SI unit of the value (``"Pa"``, ``"1"``, ``"s"``, ``"kg/m^3"``, ...).
    default
        Default value; a tuple for parameters with one value per term.
    gt, ge, lt, le
        Valid range (strict or inclusive bounds), checked for every element.
    fit
        How a calibration searches the parameter (:class:`Fit`: bounds, log scale, start value,
        the term count from which it is fitted); None: never fitted. A law with fitted
        parameters declares :attr:`Material.fit_terms` and is then a calibration form.
    doc
        One-line meaning of the parameter.
    """
    metadata = {"unit": unit, "gt": gt, "ge": ge, "lt": lt, "le": le, "fit": fit, "doc": doc}
    return field(default=default, metadata=metadata)


def option(default: str, *, doc: str = "") -> Any:
    """Declare a switch as a dataclass field typed ``Literal[choice, ...]`` (the one list of its choices).

    The value is checked against the choices (:class:`ParameterError` naming them) and packed as its
    index; Warp code reads it as an ``int`` (``P.<name>(prm)``, :meth:`Material.packed`) and compares it
    with the constants of :func:`tissuempm.materials.warp_interface.option_codes` of the same ``Literal``.
    """
    return field(default=default, metadata={"option": True, "doc": doc})


def derived(value: Callable[[Any], float], *, doc: str = "") -> Any:
    """Declare a packed value computed from the parameters (not given, not compared, not in ``to_dict``):
    ``value(material)`` is evaluated once the parameters are checked and packed at the field's place in
    the declaration (e.g. the Weiss fiber branch's intercept C6, a wrapper's history slot)."""
    return field(init=False, repr=False, compare=False, metadata={"derived": value, "doc": doc})


def option_choices(f: dataclasses.Field) -> tuple[str, ...]:
    """The choices of an :func:`option` field, from its ``Literal`` annotation."""
    return typing.get_args(f.type)


@dataclass(frozen=True)
class Fit:
    """How calibration searches one material parameter (the ``fit`` of :func:`parameter`).

    Attributes
    ----------
    lower, upper
        Search bounds, in units of the data's modulus scale S [Pa]
        (:func:`tissuempm.calibration.forms.modulus_scale`) when ``scaled``, else absolute.
    scaled
        Bounds and ``start`` are multiples of S (moduli).
    log
        Search in log10 (requires lower > 0).
    modulus
        Counts in the sum of moduli that must stay positive (sum mu_i > 0, sum C_ij > 0), and
        without a ``start`` the moduli share S equally.
    order
        For a scalar field: fitted when the form has at least this many terms (Yeoh's C20: 2).
        A tuple field (Ogden's ``mu``) is fitted with one entry per term.
    start
        Start value (multiple of S when ``scaled``); a tuple gives one per term. None: the moduli
        share S equally, another stress is S, anything else the middle of its bounds. Starts are
        clipped into the bounds.
    """

    lower: float
    upper: float
    scaled: bool = False
    log: bool = False
    modulus: bool = False
    order: int = 1
    start: float | tuple[float, ...] | None = None

    def bounds(self, S: float) -> tuple[float, float]:
        """Bounds for modulus scale ``S`` [Pa]."""
        k = S if self.scaled else 1.0
        return self.lower * k, self.upper * k

    def start_value(self, i: int | None, S: float) -> float | None:
        """Declared start of entry ``i`` (None for a scalar field) at modulus scale ``S``, or None."""
        if self.start is None:
            return None
        v = self.start[i or 0] if isinstance(self.start, tuple) else self.start
        return v * (S if self.scaled else 1.0)


def describe_range(meta: dict[str, Any]) -> str:
    """Human-readable valid range of a parameter, e.g. ``"> 0 Pa"``."""
    parts = []
    for key, op in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
        if meta.get(key) is not None:
            parts.append(f"{op} {meta[key]:g}")
    unit = meta.get("unit", "")
    text = " and ".join(parts) if parts else "finite"
    return f"{text} {unit}".strip() if unit and unit != "1" else text


def is_sequence_field(f: dataclasses.Field) -> bool:
    """Whether a parameter field holds a tuple of numbers (Ogden's ``mu``) rather than one number."""
    if f.default is not dataclasses.MISSING:
        return isinstance(f.default, (tuple, list))
    return "tuple" in str(f.type) or "list" in str(f.type)


def _check_value(owner: str, name: str, value: float, meta: dict[str, Any]) -> None:
    rng = describe_range(meta)
    if not isinstance(value, (int, float, np.floating, np.integer)) or isinstance(value, bool):
        raise ParameterError(f"{owner}.{name} = {value!r} is not a number (valid range: {rng})")
    v = float(value)
    ok = math.isfinite(v)
    if ok and meta.get("gt") is not None:
        ok = v > meta["gt"]
    if ok and meta.get("ge") is not None:
        ok = v >= meta["ge"]
    if ok and meta.get("lt") is not None:
        ok = v < meta["lt"]
    if ok and meta.get("le") is not None:
        ok = v <= meta["le"]
    if not ok:
        raise ParameterError(f"{owner}.{name} = {value!r} is out of range: valid range is {rng}")


@dataclass(frozen=True)
class StateVar:
    """A history variable of a material law.

    Attributes
    ----------
    name
        Name used in output files.
    size
        Number of scalar slots.
    initial
        Initial value of each slot (a float for all slots, or a tuple of ``size``).
    doc
        Meaning and unit.
    """

    name: str
    size: int = 1
    initial: float | tuple[float, ...] = 0.0
    doc: str = ""

    def initial_values(self) -> np.ndarray:
        """Initial values as an array of length ``size``."""
        if isinstance(self.initial, tuple):
            return np.asarray(self.initial, dtype=float)
        return np.full(self.size, float(self.initial))


@dataclass(frozen=True, kw_only=True)
class Material:
    """Base of all constitutive laws (see the module docstring for the interface)."""

    kind: ClassVar[str] = ""
    """Registry name of the law (e.g. ``"neo_hookean"``)."""
    state_vars: ClassVar[tuple[StateVar, ...]] = ()
    """History variables, in storage order."""
    anisotropic: ClassVar[bool] = False
    """True when the law uses the fiber direction ``a0``."""
    rate_dependent: ClassVar[bool] = False
    """True when the stress depends on the loading rate (viscous laws)."""
    fit_terms: ClassVar[tuple[int, int] | None] = None
    """(default, maximum) number of terms when the law is a calibration form (its fitted parameters
    are the fields declared with a :class:`Fit`); None: not a calibration form."""
    fit_rank: ClassVar[int] = 100
    """Position of the form in listings (:data:`tissuempm.calibration.forms.FORMS`)."""

    density: float = parameter("kg/m^3", default=1000.0, gt=0.0, doc="reference mass density rho0")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("kind"):
            MATERIALS[cls.kind] = cls

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for f in dataclasses.fields(self):
            if "unit" not in f.metadata:
                continue
            value = getattr(self, f.name)
            if isinstance(value, (tuple, list)) and not is_sequence_field(f):
                raise ParameterError(f"{owner}.{f.name} = {value!r} is a list: {f.name} is one number "
                                     f"(valid range: {describe_range(f.metadata)})")
            if isinstance(value, (tuple, list)):
                if isinstance(value, list):
                    object.__setattr__(self, f.name, tuple(value))
                for i, v in enumerate(value):
                    _check_value(owner, f"{f.name}[{i}]", v, f.metadata)
            else:
                _check_value(owner, f.name, value, f.metadata)
        for f in dataclasses.fields(self):
            choices = option_choices(f) if "option" in f.metadata else ()
            if choices and getattr(self, f.name) not in choices:
                raise ParameterError(f"{owner.split('[')[0]}.{f.name} = {getattr(self, f.name)!r}: "
                                     f"valid are {', '.join(choices)}")
        self.check()
        for f in dataclasses.fields(self):
            if "derived" in f.metadata:
                object.__setattr__(self, f.name, f.metadata["derived"](self))

    @classmethod
    def example(cls) -> "Material":
        """A representative, valid instance (used by the conformance tests and docs)."""
        return cls()

    # ------------------------------------------------------------------ validation
    def check(self) -> None:
        """Check relations between parameters; raise :class:`ParameterError` if violated."""

    # ------------------------------------------------------------------ parameters
    @classmethod
    def parameter_fields(cls) -> tuple[dataclasses.Field, ...]:
        """Dataclass fields declared with :func:`parameter` (those with a unit)."""
        return tuple(f for f in dataclasses.fields(cls) if "unit" in f.metadata)

    def to_dict(self) -> dict[str, Any]:
        """Parameters as a plain dict with ``kind``; :func:`from_dict` inverts it."""
        out: dict[str, Any] = {"kind": self.kind}
        for f in dataclasses.fields(self):
            if not f.init:  # derived values
                continue
            v = getattr(self, f.name)
            if isinstance(v, Material):
                v = v.to_dict()
            out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    def replace(self, **changes: Any) -> "Material":
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ solver interface
    def small_strain_moduli(self) -> tuple[float, float]:
        """Initial bulk and shear moduli ``(K0, G0)`` [Pa] of the unstrained material."""
        raise NotImplementedError

    def wave_moduli(self) -> tuple[float, float]:
        """Bulk and shear moduli [Pa] for the header of :meth:`pack`.

        Laws that stiffen strongly should return a conservative (large) value or
        override :meth:`moduli_function`.
        """
        return self.small_strain_moduli()

    def wave_speed(self, J: float = 1.0) -> float:
        """Dilatational wave speed c = sqrt((K + 4G/3) / (rho0 / J)) [m/s] from :meth:`wave_moduli`."""
        K, G = self.wave_moduli()
        return math.sqrt((K + 4.0 * G / 3.0) * J / self.density)

    def law_parameters(self) -> list[float]:
        """The law's own packed parameters (after the header), generated from the declaration
        (:func:`packed_slots`, in declaration order): a :func:`parameter` as its value, a tuple
        parameter as its length followed by its values, an :func:`option` as the index of its
        choice, a :func:`derived` value as computed, a composed law (a field holding a
        :class:`Material`, first) as its own ``law_parameters()``. A composed law whose inner law is
        declared as any :class:`Material` (so of unknown length) ends with the index of its own first
        entry and a copy of the inner law's trailing indices (:func:`trailer_length`), so each finds
        its block from the end.
        """
        out: list[float] = []
        inner: Material | None = None
        for sl in packed_slots(type(self)):
            v = getattr(self, sl.name)
            if sl.kind == "law":
                inner = v
                out.extend(v.law_parameters())
                start = _PRM_OFFSET + len(out)
            elif sl.kind == "sequence":
                out.append(float(len(v)))
                out.extend(float(x) for x in v)
            elif sl.kind == "option":
                out.append(float(sl.choices.index(v)))
            else:
                out.append(float(v))
        if inner is not None and _inner_length(type(self)) is None:
            inner_prm = inner.law_parameters()
            out.extend([float(start), *inner_prm[len(inner_prm) - trailer_length(type(inner)):]])
        return out

    @classmethod
    def packed(cls, t: WarpTypes) -> SimpleNamespace:
        """Warp accessors of the packed parameters for the precision of ``t`` (cached; :func:`accessors`):
        ``P.<field>(prm)`` the value of a parameter or derived value, the ``int`` code of an option;
        ``P.<field>(prm, i)`` and ``P.<field>_count(prm)`` for a tuple parameter; ``P.density(prm)``,
        ``P.K_wave(prm)``, ``P.G_wave(prm)`` for the header."""
        return accessors(cls, t)

    def pack(self) -> np.ndarray:
        """Packed parameter vector ``[rho0, K_wave, G_wave, *law_parameters()]`` (float64)."""
        K, G = self.wave_moduli()
        return np.asarray([self.density, K, G, *self.law_parameters()], dtype=np.float64)

    @property
    def n_state(self) -> int:
        """Number of history slots per particle."""
        return sum(v.size for v in self.state_vars)

    def state_layout(self) -> dict[str, slice]:
        """Slice of each history variable in a state row."""
        out, i = {}, 0
        for v in self.state_vars:
            out[v.name] = slice(i, i + v.size)
            i += v.size
        return out

    def initial_state(self) -> np.ndarray:
        """Initial history row (length :attr:`n_state`, at least 1 so arrays are never empty)."""
        if not self.state_vars:
            return np.zeros(1)
        return np.concatenate([v.initial_values() for v in self.state_vars])

    @classmethod
    def stress_function(cls, precision: str = "float64") -> Any:
        """The law's Cauchy stress ``@wp.func`` for ``precision`` (built once, cached)."""
        return _cached_build(cls, "_build_stress", precision)

    @classmethod
    def moduli_function(cls, precision: str = "float64") -> Any:
        """The law's instantaneous ``(K, G)`` ``@wp.func`` for ``precision`` (cached)."""
        return _cached_build(cls, "_build_moduli", precision)

    @classmethod
    def stress_moduli_function(cls, precision: str = "float64") -> Any:
        """``stress_moduli(F, L, a0, prm, s_in, s_out, p, dt) -> (sigma, K, G)`` (cached): the stress
        function's Cauchy stress and the moduli of the state it leaves (``moduli(F, a0, prm, s_out, p)``),
        what the explicit solver's stress pass needs for the next time step. The default calls the two
        functions; laws whose moduli reuse the stress's invariants override ``_build_stress_moduli``
        (same values, computed once: :class:`~tissuempm.materials.weiss.Weiss`)."""
        return _cached_build(cls, "_build_stress_moduli", precision)

    @classmethod
    def tangent_function(cls, precision: str = "float64") -> Any:
        """The law's spatial elasticity tensor ``@wp.func`` for ``precision`` (cached; module docstring)."""
        return _cached_build(cls, "_build_tangent", precision)

    analytic_tangent: ClassVar[bool] = False
    """True when :meth:`tangent_function` is a closed form (False: central differences of the stress)."""

    @classmethod
    def _build_stress(cls, t: WarpTypes) -> Any:
        raise NotImplementedError(f"{cls.__name__} has no Warp stress function")

    @classmethod
    def _build_tangent(cls, t: WarpTypes) -> Any:
        return numeric_tangent(t, cls.stress_function(t.precision))

    @classmethod
    def _build_moduli(cls, t: WarpTypes) -> Any:
        return header_moduli(t)

    @classmethod
    def _build_stress_moduli(cls, t: WarpTypes) -> Any:
        stress = cls.stress_function(t.precision)
        moduli = cls.moduli_function(t.precision)

        @stress_func(t)
        def stress_moduli(F, L, a0, prm, s_in, s_out, p, dt):
            sig = stress(F, L, a0, prm, s_in, s_out, p, dt)
            K, G = moduli(F, a0, prm, s_out, p)
            return sig, K, G

        return stress_moduli

    # ------------------------------------------------------------------ verification
    has_strain_energy: ClassVar[bool] = False
    """True when :meth:`strain_energy` is implemented (hyperelastic laws)."""
    symmetric_tangent: ClassVar[bool | None] = None
    """Whether the spatial tangent has the major symmetry c_ijkl = c_klij (the implicit solver then
    assembles half the blocks); None: as ``has_strain_energy`` (hyperelastic laws)."""

    @classmethod
    def tangent_is_symmetric(cls) -> bool:
        """:attr:`symmetric_tangent`, defaulting to :attr:`has_strain_energy`."""
        return cls.has_strain_energy if cls.symmetric_tangent is None else cls.symmetric_tangent

    def without_new_failure(self) -> "Material":
        """The same law with every failure limit out of reach: failed constituents stay failed, none
        fails anew. The implicit solver's Newton iterations use it (failure is evaluated once, at
        the converged step). Laws without failure return themselves."""
        return self

    def failure_slot(self) -> int | None:
        """Index in a history row of the state variable named ``failure`` (1 slot; 0 intact, nonzero
        failed, codes of :class:`tissuempm.materials.failure.FailureMode`), or None for a law without
        one. Frames, checkpoints and the analysis read the failure code from this slot."""
        sl = self.state_layout().get("failure")
        return None if sl is None else sl.start

    def erodes(self) -> bool:
        """Whether the solver removes this law's particles once failed (erosion).

        Contract with the solver: a particle whose law ``erodes()`` and whose history slot
        :meth:`failure_slot` is nonzero is taken out of the computation (no mass, momentum or
        stress transferred to the grid). False for every law but a failure layer built with
        ``erosion=True`` (:class:`tissuempm.materials.failure_layer.Failure`)."""
        return False

    def strain_energy(self, F: np.ndarray, a0: np.ndarray | None = None) -> float:
        """Strain energy per unit reference volume W(F) [J/m^3] (NumPy), for hyperelastic laws."""
        raise NotImplementedError(f"{type(self).__name__} has no strain energy")

    # ------------------------------------------------------------------ calibration closed forms
    def simple_shear_stress(self, gamma: np.ndarray) -> np.ndarray:
        """Shear stress tau [Pa] of the incompressible law in simple shear F = I + gamma e1 (x) e2
        (the calibration's closed-form forward model); laws without one raise ValueError."""
        raise ValueError(f"no simple_shear closed form for material kind {self.kind or type(self).__name__!r}; "
                         "use forward = 'driver'")

    def nominal_stress(self, mode: str, strain: np.ndarray) -> np.ndarray:
        """Instantaneous nominal stress P0 [Pa] at engineering ``strain`` in a stretch ``mode``
        (``uniaxial``, ``equibiaxial``, ``pure_shear``): the incompressible closed form
        ``nominal_stress_incompressible(mode, 1 + strain)`` of hyperelastic laws."""
        f = getattr(self, "nominal_stress_incompressible", None)
        if f is None:
            raise TypeError(f"{type(self).__name__} has no incompressible closed form (nominal_stress_incompressible)")
        return np.asarray(f(mode, 1.0 + np.asarray(strain, dtype=float)), dtype=float)

    # ------------------------------------------------------------------ solver cards (tissuempm.calibration.export)
    febio_uncoupled: ClassVar[bool] = True
    """FEBio: the law is an uncoupled material (a Prony series wraps it in ``uncoupled viscoelastic``)."""
    abaqus_bulk_relaxes: ClassVar[bool] = False
    """Abaqus ``*VISCOELASTIC``: the bulk modulus relaxes with the shear Prony ratios (k_i = g_i)."""

    def abaqus_keywords(self) -> list[str]:
        """Abaqus keyword lines of the elastic law (after ``*DENSITY``), SI."""
        raise ValueError(f"no Abaqus export for material kind {self.kind!r}")

    def lsdyna_keywords(self, mid: int, rho: float, units: dict[str, float],
                        g: tuple[float, ...], tau: tuple[float, ...]) -> list[str]:
        """LS-DYNA keyword lines of the law with Prony ratios ``g`` and times ``tau`` [s] (empty when
        elastic); ``rho`` already in ``units`` (the SI value of one unit of stress, density, time and
        velocity: :data:`tissuempm.calibration.export.UNIT_SYSTEMS`)."""
        raise ValueError(f"no LS-DYNA export for material kind {self.kind!r}")

    def febio_parameters(self) -> tuple[str, dict[str, float]]:
        """FEBio material ``type`` and its parameters (SI)."""
        raise ValueError(f"no FEBio export for material kind {self.kind!r}")


@functools.cache
def _cached_build(cls: type, method: str, precision: str) -> Any:
    return getattr(cls, method)(warp_types(precision))


@functools.cache
def header_moduli(t: WarpTypes) -> Any:
    """``moduli(F, a0, prm, s_in, p) -> (K, G)`` reading the packed header (constant moduli)."""
    H = header(t)

    @moduli_func(t)
    def moduli(F, a0, prm, s_in, p):
        return H.K_wave(prm), H.G_wave(prm)

    return moduli


# ---------------------------------------------------------------------- packed layout (from the declaration)
@dataclass(frozen=True)
class Slot:
    """One packed field of a law: ``kind`` is ``"value"`` (a :func:`parameter` or :func:`derived` number),
    ``"sequence"`` (a tuple parameter: length, then values), ``"option"`` (the index of one of
    ``choices``) or ``"law"`` (a composed law's inner law, packed first as its own parameters)."""

    name: str
    kind: str
    choices: tuple[str, ...] = ()


def _is_law_field(f: dataclasses.Field) -> bool:
    return isinstance(f.type, type) and issubclass(f.type, Material)


@functools.cache
def packed_slots(cls: type) -> tuple[Slot, ...]:
    """The packed fields of ``cls`` in declaration order (the layout of :meth:`Material.law_parameters`):
    every field declared with :func:`parameter` (but ``density``, in the header), :func:`option` or
    :func:`derived`, and a field holding a :class:`Material` (which must come first)."""
    out: list[Slot] = []
    for f in dataclasses.fields(cls):
        if f.name == "density":
            continue
        if _is_law_field(f):
            if out:
                raise TypeError(f"{cls.__name__}.{f.name}: a composed law's inner law must be its first packed field")
            out.append(Slot(f.name, "law"))
        elif "option" in f.metadata:
            out.append(Slot(f.name, "option", option_choices(f)))
        elif "unit" in f.metadata:
            out.append(Slot(f.name, "sequence" if is_sequence_field(f) else "value"))
        elif "derived" in f.metadata:
            out.append(Slot(f.name, "value"))
    return tuple(out)


def inner_class(cls: type, name: str) -> type:
    """Class of the inner law in field ``name`` of a composed law ``cls``: its ``<name>_class`` (the
    class a specialised wrapper was built for, e.g. ``Failure[Weiss].base_class``) or the annotation."""
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return getattr(cls, f"{name}_class", None) or f.type


@functools.cache
def specialised(cls: type, name: str, inner: type, flags: tuple[str, ...] = ("anisotropic",)) -> type:
    """The subclass of the composed law ``cls`` whose Warp functions wrap the class ``inner`` of its field
    ``name`` (``Failure[ElasticPlastic]``: ``base_class = ElasticPlastic``; one per class, cached), with the
    class ``flags`` (e.g. ``anisotropic``) of the inner class. A new instance takes it at the end of its
    ``__post_init__``, so :func:`inner_class` and the accessors know the inner law's layout."""
    label = f"{cls.__name__}[{inner.__name__}]"
    attrs: dict[str, Any] = {f"{name}_class": inner, "__module__": cls.__module__, "__qualname__": label}
    attrs.update({flag: bool(getattr(inner, flag, False)) for flag in flags})
    return type(label, (cls,), attrs)


def fixed_length(cls: type) -> int | None:
    """Number of packed law parameters of ``cls`` when its declaration fixes it (no tuple parameter, no
    inner law declared as any :class:`Material`), else None."""
    n = 0
    for sl in packed_slots(cls):
        if sl.kind == "sequence":
            return None
        m = _inner_length(cls) if sl.kind == "law" else 1
        if m is None:
            return None
        n += m
    return n


def _inner_length(cls: type) -> int | None:
    """Fixed length of the inner law as declared (``base: Weiss``), None for any law (``base: Material``)."""
    slots = packed_slots(cls)
    if not slots or slots[0].kind != "law":
        return None
    declared = next(f for f in dataclasses.fields(cls) if f.name == slots[0].name).type
    return None if declared is Material else fixed_length(declared)


def trailer_length(cls: type) -> int:
    """Number of block indices a packed vector of ``cls`` ends with: 1 + the inner law's for a composed
    law whose inner law is declared as any :class:`Material` (:meth:`Material.law_parameters`), else 0."""
    slots = packed_slots(cls)
    if not slots or slots[0].kind != "law" or _inner_length(cls) is not None:
        return 0
    inner = inner_class(cls, slots[0].name)
    if inner is Material:
        raise NotImplementedError(f"{cls.__name__} needs its inner law: build it with the {slots[0].name} given")
    return 1 + trailer_length(inner)


@functools.cache
def header(t: WarpTypes) -> SimpleNamespace:
    """Warp accessors ``density(prm)``, ``K_wave(prm)``, ``G_wave(prm)`` of the packed header (:data:`HEADER`)."""
    return SimpleNamespace(**{name: _value(t, i) for i, name in enumerate(HEADER)})


@functools.cache
def accessors(cls: type, t: WarpTypes) -> SimpleNamespace:
    """Warp accessors of the packed parameters of ``cls`` (see :meth:`Material.packed`), generated from
    :func:`packed_slots`. An index is a constant until a tuple parameter or an inner law of variable
    length; from there it is a Warp function of ``prm`` (the inner law's block is followed by the own
    block, whose start the packed vector holds :func:`trailer_length` entries from its end)."""
    out = dict(vars(header(t)))
    index: Any = _PRM_OFFSET
    for sl in packed_slots(cls):
        if sl.kind == "law":
            n = _inner_length(cls)
            index = index + n if n is not None else _pointer(t, trailer_length(inner_class(cls, sl.name)))
            continue
        if sl.kind == "sequence":
            out[sl.name] = _item(t, index)
            out[f"{sl.name}_count"] = _code(t, index)
            index = _after_sequence(t, index)
            continue
        out[sl.name] = _code(t, index) if sl.kind == "option" else _value(t, index)
        index = index + 1 if isinstance(index, int) else _shift(t, index, 1)
    return SimpleNamespace(**out)


@functools.cache
def _value(t: WarpTypes, index: Any) -> Any:
    """``get(prm) -> prm[index]`` (a constant index, or a Warp function of ``prm``)."""
    s = t.scalar
    if isinstance(index, int):

        @wp.func
        def get(prm: wp.array(dtype=s)):
            return prm[index]

        return get

    @wp.func
    def get_at(prm: wp.array(dtype=s)):
        return prm[index(prm)]

    return get_at


@functools.cache
def _code(t: WarpTypes, index: Any) -> Any:
    """``get(prm) -> int`` of the whole number stored at ``index`` (an option's code, a count)."""
    value = _value(t, index)
    to_int = as_int(t)

    @wp.func
    def get(prm: wp.array(dtype=t.scalar)):
        return to_int(value(prm))

    return get


@functools.cache
def _item(t: WarpTypes, index: Any) -> Any:
    """``get(prm, i) -> prm[index + 1 + i]``: entry ``i`` of the tuple whose length is at ``index``."""
    s = t.scalar
    if isinstance(index, int):

        @wp.func
        def get(prm: wp.array(dtype=s), i: int):
            return prm[index + 1 + i]

        return get

    @wp.func
    def get_at(prm: wp.array(dtype=s), i: int):
        return prm[index(prm) + 1 + i]

    return get_at


@functools.cache
def _shift(t: WarpTypes, index: Any, n: int) -> Any:
    """``at(prm) -> index(prm) + n``."""

    @wp.func
    def at(prm: wp.array(dtype=t.scalar)):
        return index(prm) + n

    return at


@functools.cache
def _after_sequence(t: WarpTypes, index: Any) -> Any:
    """``at(prm)``: the index after the tuple whose length is at ``index`` (index + 1 + length)."""
    count = _code(t, index)
    start = index if not isinstance(index, int) else None

    if start is None:

        @wp.func
        def at(prm: wp.array(dtype=t.scalar)):
            return index + 1 + count(prm)

        return at

    @wp.func
    def at_after(prm: wp.array(dtype=t.scalar)):
        return start(prm) + 1 + count(prm)

    return at_after


@functools.cache
def _pointer(t: WarpTypes, back: int) -> Any:
    """``at(prm)``: the block start stored ``back + 1`` entries from the end of the packed vector."""
    to_int = as_int(t)

    @wp.func
    def at(prm: wp.array(dtype=t.scalar)):
        return to_int(prm[prm.shape[0] - 1 - back])

    return at


def copy_state(t: WarpTypes) -> Any:
    """``copy(s_in, s_out, p, start, count)``: carry ``count`` history slots unchanged."""
    return _copy_state(t)


@functools.cache
def _copy_state(t: WarpTypes) -> Any:
    @wp.func
    def copy(s_in: wp.array2d(dtype=t.scalar), s_out: wp.array2d(dtype=t.scalar), p: int, start: int, count: int):
        for k in range(count):
            s_out[p, start + k] = s_in[p, start + k]

    return copy


def get_material_class(kind: str) -> type[Material]:
    """Material class registered as ``kind``; raises ``KeyError`` listing the known kinds."""
    try:
        return MATERIALS[kind]
    except KeyError:
        known = ", ".join(sorted(MATERIALS))
        raise KeyError(f"unknown material kind {kind!r}: known kinds are {known}") from None


def from_dict(data: dict[str, Any]) -> Material:
    """Build a material from ``{"kind": ..., **parameters}`` (inverse of :meth:`Material.to_dict`).

    Unknown keys raise :class:`ParameterError` naming the key and the valid ones.
    """
    data = dict(data)
    cls = get_material_class(data.pop("kind"))
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ParameterError(
            f"unknown parameter(s) {', '.join(unknown)} for {cls.kind}: valid are {', '.join(sorted(names))}"
        )
    for key, value in data.items():
        if isinstance(value, dict) and "kind" in value:
            data[key] = from_dict(value)  # composed laws (failure, viscoelastic wrappers)
    for f in dataclasses.fields(cls):  # a composed law's inner law is never silently the example default
        if f.name not in data and f.default is dataclasses.MISSING and f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
            if isinstance(default, Material):
                raise ParameterError(
                    f"{cls.kind} needs {f.name!r}: the law it wraps, e.g. "
                    f"{f.name} = {{ kind = \"{default.kind}\", ... }} or {f.name} = {{ library = \"...\" }} "
                    f"(without it the {type(default).__name__} example parameters would be used)"
                )
    return cls(**data)
