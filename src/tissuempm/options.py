"""Options declared once: the dataclass a solver takes is also the schema of its file section.

An option set (:class:`tissuempm.mpm.SolverConfig`, :class:`tissuempm.mpm.ImplicitConfig`,
:class:`tissuempm.mpm.ContactLaw`, :class:`tissuempm.calibration.optimizers.SearchSettings`) is a
frozen dataclass whose field annotations carry the valid range and the unit as pydantic metadata::

    cfl: Annotated[Number, Field(gt=0.0, le=1.0)] = 0.3
    damping: Annotated[quantity("1/s"), Field(ge=0.0)] = 0.0

* :func:`check` (called from the dataclass's ``__post_init__``) validates and converts every field
  by its annotation, so the Python API refuses ``SolverConfig(cfl=1.5)`` with a message naming the
  option, the value and the valid range: ``cfl = 1.5 is out of range: valid range is (0, 1]``.
* :func:`section` builds the pydantic model of a file section from the same fields (their
  annotations and defaults), so a scenario's ``[solver]``, ``[solver.implicit]`` and ``[[contact]]``
  and a calibration's ``[optimizer]`` accept exactly what the dataclass accepts; the section's
  :meth:`OptionSection.options` gives the keyword arguments of the dataclass.

Units are converted at the boundary: a field of type :func:`quantity` takes an SI number or a
string with a unit (``"2 ms"``, ``"9.81 m/s^2"``), converted by
:func:`tissuempm.scenarios.units.parse_quantity`; inside, values are SI numbers.
"""

import dataclasses
import functools
import math
import numbers
import typing
from typing import Annotated, Any, ClassVar, Literal, cast

from pydantic import AfterValidator, BaseModel, BeforeValidator, TypeAdapter, ValidationError, create_model
from pydantic.fields import FieldInfo


@dataclasses.dataclass(frozen=True)
class Unit:
    """Marker in a :func:`quantity` annotation: the SI unit of the value (shown in messages)."""

    symbol: str


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number")
    return value


def _parse(value: Any, unit: str) -> float:
    from tissuempm.scenarios.units import parse_quantity  # lazily: tissuempm.scenarios imports this module

    if isinstance(value, numbers.Real) and not isinstance(value, bool):  # NumPy scalars (np.float32) too
        return float(value)
    return parse_quantity(value, unit)


def quantity(unit: str) -> Any:
    """A finite float accepting SI numbers or strings with a unit of the dimension of ``unit``."""
    return Annotated[float, BeforeValidator(functools.partial(_parse, unit=unit)), AfterValidator(_finite), Unit(unit)]


Length = quantity("m")
Time = quantity("s")
Speed = quantity("m/s")
Acceleration = quantity("m/s^2")
Angle = quantity("rad")
Density = quantity("kg/m^3")
Mass = quantity("kg")
Number = quantity("1")
Rate = quantity("1/s")
Pressure = quantity("Pa")
AngularSpeed = quantity("rad/s")
AngularAcceleration = quantity("rad/s^2")


# ---------------------------------------------------------------------------- the Python API


_HINTS: dict[type, dict[str, Any]] = {}
_ADAPTERS: dict[tuple[type, str], TypeAdapter[Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    """Field name -> annotation (with its metadata) of the dataclass ``cls`` (resolved once)."""
    if cls not in _HINTS:
        hints = typing.get_type_hints(cls, include_extras=True)
        _HINTS[cls] = {f.name: hints[f.name] for f in dataclasses.fields(cls) if f.init}
    return _HINTS[cls]


def annotations(cls: type) -> dict[str, Any]:
    """Option name -> its annotation (type, range and unit) of the option dataclass ``cls``: the
    type a file section gives the same option."""
    return dict(_hints(cls))


def _adapter(cls: type, name: str) -> TypeAdapter[Any]:
    if (cls, name) not in _ADAPTERS:
        _ADAPTERS[cls, name] = TypeAdapter(_hints(cls)[name])
    return _ADAPTERS[cls, name]


def _metadata(annotation: Any) -> list[Any]:
    """Every metadata object in ``annotation``, through ``Annotated``, unions (``X | None``) and the
    items of tuples and lists."""
    out: list[Any] = []
    if typing.get_origin(annotation) is Annotated:
        for m in annotation.__metadata__:
            out += m.metadata if isinstance(m, FieldInfo) else [m]
        out += _metadata(typing.get_args(annotation)[0])
    elif typing.get_origin(annotation) is not Literal:
        for arg in typing.get_args(annotation):
            out += _metadata(arg)
    return out


def choices(annotation: Any) -> tuple[Any, ...]:
    """The values of the ``Literal`` in ``annotation`` (``()`` if none)."""
    if typing.get_origin(annotation) is Literal:
        return typing.get_args(annotation)
    return tuple(c for arg in typing.get_args(annotation) for c in choices(arg))


def _number(x: Any) -> str:
    return repr(x) if isinstance(x, int) else f"{x:g}"


def valid_range(annotation: Any) -> str:
    """The range the bounds of ``annotation`` allow: ``(0, 1]``, ``>= 0``, ``[1, 1024]`` (with its unit)."""
    bounds: dict[str, Any] = {}
    unit = ""
    for m in _metadata(annotation):
        for key in ("gt", "ge", "lt", "le"):  # annotated_types.Gt, Ge, ... (and Interval)
            if not isinstance(m, FieldInfo) and getattr(m, key, None) is not None:
                bounds[key] = getattr(m, key)
        if isinstance(m, Unit) and m.symbol != "1":
            unit = f" {m.symbol}"
    lo = ("(", bounds["gt"]) if "gt" in bounds else ("[", bounds["ge"]) if "ge" in bounds else None
    hi = (")", bounds["lt"]) if "lt" in bounds else ("]", bounds["le"]) if "le" in bounds else None
    if lo and hi:
        text = f"{lo[0]}{_number(lo[1])}, {_number(hi[1])}{hi[0]}"
    elif lo:
        text = f"{'>' if lo[0] == '(' else '>='} {_number(lo[1])}"
    else:
        text = f"{'<' if hi and hi[0] == ')' else '<='} {_number(hi[1]) if hi else ''}"
    return text + unit


_RANGE_ERRORS = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def option_message(key: str, value: Any, annotation: Any, error: ValidationError) -> str:
    """The message of a bad option value: ``key = value`` and why, with the valid choices or range."""
    e = error.errors()[0]
    item = "".join(f"[{p}]" for p in e["loc"] if isinstance(p, int))
    msg = e["msg"].removeprefix("Value error, ")
    optional = " (or None)" if type(None) in typing.get_args(annotation) else ""
    if e["type"] == "literal_error":
        return f"{key} = {value!r} is not valid: choose one of {', '.join(map(str, choices(annotation)))}{optional}"
    if e["type"] in _RANGE_ERRORS:
        return f"{key}{item} = {e['input']!r} is out of range: valid range is {valid_range(annotation)}{optional}"
    if e["type"] == "missing" and item:  # a tuple given too few items
        return f"{key} = {value!r}: too few items (item {item} is missing)"
    if msg.startswith((key.rsplit(" ", 1)[-1], "is ")):  # the validator named the option
        return f"{key} = {value!r} {msg}" if msg.startswith("is ") else msg
    return f"{key}{item} = {e['input'] if item else value!r}: {msg}"


def check(options: Any, prefix: str = "") -> None:
    """Validate and convert every field of the option dataclass ``options`` by its annotation
    (call from ``__post_init__``); raise ``ValueError`` naming the first bad option (``prefix`` +
    name), its value and the valid choices or range."""
    cls = type(options)
    for name in _hints(cls):
        value = getattr(options, name)
        try:
            converted = _adapter(cls, name).validate_python(value)
        except ValidationError as e:
            raise ValueError(option_message(f"{prefix}{name}", value, _hints(cls)[name], e)) from None
        if converted is not value:
            object.__setattr__(options, name, converted)


# ---------------------------------------------------------------------------- file sections


class OptionSection(BaseModel):
    """A file section built by :func:`section` (mixed into the file's own section base)."""

    option_class: ClassVar[type]
    option_keys: ClassVar[dict[str, str]]
    """Option name -> key in the file."""

    def options(self) -> dict[str, Any]:
        """The keyword arguments of :attr:`option_class` that this section gives."""
        return {name: getattr(self, key) for name, key in self.option_keys.items()}

    def config(self, **more: Any) -> Any:
        """The option dataclass of this section, ``more`` options (those the file does not hold, or
        values that replace the file's) added."""
        return self.option_class(**{**self.options(), **more})


def section(cls: type, base: type[BaseModel], name: str, include: tuple[str, ...] | None = None,
            rename: dict[str, str] | None = None, defaults: dict[str, Any] | None = None) -> Any:
    """A pydantic model (subclass of ``base``) whose fields are the options ``include`` (default all)
    of the dataclass ``cls``, with their annotations and defaults; ``rename`` maps an option to its
    key in the file, ``defaults`` replaces an option's default in the file. Subclass it to add the
    file's own keys and checks."""
    rename, defaults = rename or {}, defaults or {}
    hints = _hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    names = include if include is not None else tuple(hints)
    spec: dict[str, Any] = {}
    for option in names:
        default = defaults.get(option, fields[option].default)
        spec[rename.get(option, option)] = (hints[option], ... if default is dataclasses.MISSING else default)
    # a subclass of base and OptionSection; create_model's stubs give it the type of one base of the tuple
    model = cast(type[OptionSection], create_model(name, __base__=(base, OptionSection), __module__=cls.__module__,
                                                   **spec))
    model.option_class = cls
    model.option_keys = {option: rename.get(option, option) for option in names}
    return model
