"""One library entry: a named tissue component and the parameter set it uses."""

import copy
import functools
from dataclasses import dataclass, field
from typing import Any

from tissuempm.materials.base import Material, from_dict


@dataclass(frozen=True, kw_only=True)
class LibraryEntry:
    """A tissue component with its published material parameters (SI units).

    Attributes
    ----------
    name
        snake_case key, e.g. ``"csf"`` or ``"cerebrum_white_matter"``.
    title
        Display name, e.g. ``"Cerebrum - White Matter"``.
    table
        Source table (``"A1"`` .. ``"A4"`` for Brewick et al. 2017, ``"Ionescu2006"``,
        ``"user"`` for user files).
    group
        Parameter-set name; components with the same group share one set.
    source
        Publication and place (table, section) the parameters come from.
    notes
        How values were obtained or derived, assumptions, caveats.
    model
        ``{"kind": ..., **parameters}`` in SI units, including ``density``
        (nested for composed laws); :func:`tissuempm.materials.from_dict` builds it.
    density
        Reference mass density [kg/m^3].
    form
        Model form as the source names it.
    references
        The original references behind the set, as cited by the source.
    inputs
        The numbers the source publishes (SI), from which ``model`` is computed.
    alternatives
        Other model forms the source gives for the same set, by label.
    stated
        Derived numbers the source prints, keyed by path (``"model.K"``,
        ``"derived.nu"``, ...), as printed strings (their digits set the rounding).
    expressions
        Extra derived quantities of the inputs (name -> (expression, unit)).
    aliases
        Other names :func:`tissuempm.library.get` accepts.
    origin
        File the entry was read from.
    """

    name: str
    title: str
    table: str
    group: str
    source: str
    notes: str = ""
    model: dict[str, Any]
    density: float
    form: str = ""
    references: str = ""
    inputs: dict[str, Any] = field(default_factory=dict)
    alternatives: dict[str, dict[str, Any]] = field(default_factory=dict)
    stated: dict[str, str] = field(default_factory=dict)
    expressions: dict[str, tuple[str, str]] = field(default_factory=dict)
    aliases: tuple[str, ...] = ()
    origin: str = ""

    @property
    def kind(self) -> str:
        """Material kind of the main model."""
        return str(self.model["kind"])

    @functools.cached_property
    def material(self) -> Material:
        """The :class:`~tissuempm.materials.base.Material` of the main model."""
        return from_dict(copy.deepcopy(self.model))

    def alternative(self, label: str) -> Material:
        """Material of an alternative model form (e.g. ``"neo_hookean"`` for CSF)."""
        if label not in self.alternatives:
            known = ", ".join(sorted(self.alternatives)) or "none"
            raise KeyError(f"{self.name} has no alternative {label!r} (alternatives: {known})")
        return from_dict(copy.deepcopy(self.alternatives[label]))

    def to_record(self) -> dict[str, Any]:
        """The entry as a single-entry record (the user-file format, see :func:`write_entry`)."""
        out: dict[str, Any] = {
            "name": self.name,
            "title": self.title,
            "table": self.table,
            "group": self.group,
            "source": self.source,
            "notes": self.notes,
            "density": self.density,
        }
        for key in ("form", "references"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        if self.aliases:
            out["aliases"] = list(self.aliases)
        out["model"] = copy.deepcopy(self.model)
        for key in ("inputs", "alternatives", "stated"):
            if getattr(self, key):
                out[key] = copy.deepcopy(getattr(self, key))
        if self.expressions:
            out["derived"] = {k: [text, unit] for k, (text, unit) in self.expressions.items()}
        return out
