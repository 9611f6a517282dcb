"""Export of materials to solver input cards (Abaqus, LS-DYNA, FEBio) and readers for the tests.

Conventions
-----------
* Abaqus (``*HYPERELASTIC``): the tissuempm conventions are Abaqus's (Ogden
  W = sum 2 mu_i/alpha_i^2 (...), polynomial C_ij, D_i with D1 = 2/K); the elastic law is the
  *instantaneous* response and ``*VISCOELASTIC, TIME=PRONY`` lists ``g_i, k_i, tau_i``.
* LS-DYNA ``*MAT_OGDEN_RUBBER`` (MAT_077_O) uses Ogden's original form
  W = sum mu'_i/alpha_i (...), so ``mu'_i = 2 mu_i / alpha_i``; its viscoelastic terms
  ``G_i, BETA_i`` are shear moduli and decay constants added to a *long-term* elastic law:
  ``G_i = g_i G0``, ``BETA_i = 1/tau_i``, elastic moduli multiplied by ``g_inf`` (exact in the
  linear limit; see :mod:`tissuempm.materials.viscoelastic`). ``PR`` is Poisson's ratio from K
  and G0. ``*EOS_GRUNEISEN`` takes C = c0, S1 = s, GAMAO = Gamma0.
* LS-DYNA ``*MAT_ANISOTROPIC_HYPERELASTIC`` (MAT_295) for HGO: see :func:`tissuempm.materials.hgo.mat295_cards`
  (isotropic module ITYPE = -2, Yeoh, with c1 = C10; anisotropic module ATYPE = -1, one
  fiber family with the structure-tensor parameters A = kappa, B = 1 - 3 kappa and FTYPE = 1
  (HGO fiber, K1 = k1, K2 = k2); NU from K and G0 = 2 C10).
* FEBio: uncoupled ``Ogden`` with ``c_i = 2 mu_i`` and ``m_i = alpha_i``; ``Mooney-Rivlin``
  with c1 = C10, c2 = C01; uncoupled ``Yeoh`` with c_i = C_i0 (i <= 6: Yeoh and reduced
  polynomial); ``polynomial`` (FEBio's coupled class FEPolynomialHyperElastic, isochoric
  invariants) with c10, c01, c20, c11, c02 and its own volumetric coefficient ``D1`` of
  U = D1 (J - 1)^2, so **FEBio D1 = K/2** (not Abaqus' D1 = 2/K); ``Holzapfel-Gasser-Ogden``
  with c = 2 C10; viscoelastic ``G(t) = g0 + sum g_i exp(-t/t_i)`` with ``g0 = g_inf`` around
  the instantaneous law (``uncoupled viscoelastic`` around uncoupled laws, ``viscoelastic``
  around ``polynomial`` and ``isotropic elastic``). FEBio's uncoupled laws take the bulk
  modulus ``k`` with U = (k/2)(ln J)^2 (FEUncoupledMaterial), tissuempm's ``volumetric = "log"``
  form; the ``"abaqus"`` form has the same K at J = 1.

Units: LS-DYNA has no unit system of its own; ``units`` selects one of :data:`UNIT_SYSTEMS`
and every value is converted from SI. Abaqus and FEBio cards are written in SI.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

from tissuempm.materials.base import Material
from tissuempm.materials.cards import poisson_ratio

__all__ = ["UNIT_SYSTEMS", "abaqus_cards", "febio_xml", "lsdyna_cards", "poisson_ratio", "read_abaqus",
           "read_febio", "read_lsdyna", "write_all"]

UNIT_SYSTEMS: dict[str, dict[str, float]] = {
    "SI": {"stress": 1.0, "density": 1.0, "time": 1.0, "velocity": 1.0},
    "mm-ms-kg": {"stress": 1.0e9, "density": 1.0e9, "time": 1.0e-3, "velocity": 1.0},
    "mm-s-tonne": {"stress": 1.0e6, "density": 1.0e12, "time": 1.0, "velocity": 1.0e-3},
}
"""SI value of one unit of stress, density, time and velocity in each system (value_file = SI / factor)."""


def _split(material: Material) -> tuple[Material, tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    if getattr(material, "kind", "") == "viscoelastic":
        visco: Any = material  # a Viscoelastic (its kind): g, tau, k and elastic are not Material fields
        k = tuple(visco.k) if visco.k else ()
        return visco.elastic, tuple(visco.g), tuple(visco.tau), k
    return material, (), (), ()


# ---------------------------------------------------------------------- Abaqus
def abaqus_cards(material: Material, name: str = "TISSUE") -> str:
    """Abaqus keywords ``*MATERIAL ... *DENSITY``, the law's own keywords
    (:meth:`~tissuempm.materials.base.Material.abaqus_keywords`: ``*HYPERELASTIC``, ``*ELASTIC``,
    ``*EOS``, ...) and ``*VISCOELASTIC`` (SI)."""
    el, g, tau, k = _split(material)
    out = [f"*MATERIAL, NAME={name}", "*DENSITY", f"{material.density:.8g},", *el.abaqus_keywords()]
    if g:
        kk = k or (g if el.abaqus_bulk_relaxes else (0.0,) * len(g))
        out.append("*VISCOELASTIC, TIME=PRONY")
        out += [f"{gi:.8g}, {ki:.8g}, {ti:.8g}" for gi, ki, ti in zip(g, kk, tau)]
    return "\n".join(out) + "\n"


def _data_after(lines: list[str], i: int) -> list[float]:
    vals: list[float] = []
    for ln in lines[i + 1 :]:
        if ln.startswith("*"):
            break
        vals += [float(v) for v in ln.split(",") if v.strip()]
    return vals


def read_abaqus(text: str) -> dict[str, Any]:
    """Parse cards written by :func:`abaqus_cards` into ``{keyword: {"options": ..., "data": [...]}}``."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("**")]
    out: dict[str, Any] = {}
    for i, ln in enumerate(lines):
        if ln.startswith("*"):
            parts = [p.strip() for p in ln[1:].split(",")]
            opts = {}
            for p in parts[1:]:
                key, _, val = p.partition("=")
                opts[key.strip().upper()] = val.strip() if val else True
            out[parts[0].upper()] = {"options": opts, "data": _data_after(lines, i)}
    return out


# ---------------------------------------------------------------------- LS-DYNA
def lsdyna_cards(material: Material, mid: int = 1, units: str = "SI") -> str:
    """LS-DYNA keywords of the law (:meth:`~tissuempm.materials.base.Material.lsdyna_keywords`:
    ``*MAT_OGDEN_RUBBER``, ``*MAT_ANISOTROPIC_HYPERELASTIC``, ``*MAT_ELASTIC``,
    ``*MAT_GENERAL_VISCOELASTIC``, ``*MAT_NULL`` + ``*EOS_GRUNEISEN``) in ``units``."""
    if units not in UNIT_SYSTEMS:
        raise ValueError(f"units = {units!r}: valid are {', '.join(UNIT_SYSTEMS)}")
    u = UNIT_SYSTEMS[units]
    el, g, tau, _ = _split(material)
    out = [f"$ tissuempm export, units {units}", *el.lsdyna_keywords(mid, material.density / u["density"], u, g, tau)]
    return "\n".join(out) + "\n*END\n"


def _cell(text: str) -> float | str | None:
    """A fixed-format field: a number, a title word (``ISO``, ``ANISO``) or None when blank."""
    if not text:
        return None
    try:
        return float(text)
    except ValueError:
        return text


def read_lsdyna(text: str) -> dict[str, list[list[float | str | None]]]:
    """Parse fixed-format cards into ``{keyword: [card values...]}`` (blank fields as None, titles as str)."""
    out: dict[str, list[list[float | str | None]]] = {}
    key: Any = None  # the current keyword; a card before any keyword fails on out[None] (KeyError)
    for ln in text.splitlines():
        if not ln.strip() or ln.startswith("$"):
            continue
        if ln.startswith("*"):
            key = ln.strip().upper()
            out[key] = []
            continue
        cells = [ln[i : i + 10].strip() for i in range(0, len(ln), 10)]
        out[key].append([_cell(c) for c in cells])
    return out


# ---------------------------------------------------------------------- FEBio
def _elastic_xml(el: Material, tag: str = "material") -> ET.Element:
    kind, params = el.febio_parameters()
    e = ET.Element(tag)
    e.set("type", kind)
    for name, v in params.items():
        ET.SubElement(e, name).text = f"{v:.10g}"
    return e


def febio_xml(material: Material, name: str = "tissue", mat_id: int = 1) -> str:
    """FEBio ``<material>`` element (SI)."""
    el, g, tau, _ = _split(material)
    if g:
        uncoupled = el.febio_uncoupled
        root = ET.Element("material", id=str(mat_id), name=name,
                          type="uncoupled viscoelastic" if uncoupled else "viscoelastic")
        ET.SubElement(root, "density").text = f"{material.density:.10g}"
        ET.SubElement(root, "g0").text = f"{1.0 - sum(g):.10g}"
        for i, (gi, ti) in enumerate(zip(g, tau), start=1):
            ET.SubElement(root, f"g{i}").text = f"{gi:.10g}"
            ET.SubElement(root, f"t{i}").text = f"{ti:.10g}"
        root.append(_elastic_xml(el, "elastic"))
    else:
        root = _elastic_xml(el)
        root.set("id", str(mat_id))
        root.set("name", name)
        ET.SubElement(root, "density").text = f"{material.density:.10g}"
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def read_febio(text: str) -> dict[str, Any]:
    """Parse a ``<material>`` element into nested dicts of floats (``type`` kept)."""

    def walk(e: ET.Element) -> dict[str, Any]:
        d: dict[str, Any] = {"type": e.get("type")}
        for c in e:
            d[c.tag] = walk(c) if len(c) else float(c.text)  # type: ignore[arg-type]  # no text: TypeError
        return d

    return walk(ET.fromstring(text))


def write_all(material: Material, stem: str, name: str, units: str = "SI") -> dict[str, str]:
    """Write every card format that supports ``material``; returns {format: path}."""
    out = {}
    for fmt, ext, fn in (("abaqus", "inp", lambda: abaqus_cards(material, name.upper())),
                         ("lsdyna", "k", lambda: lsdyna_cards(material, units=units)),
                         ("febio", "feb.xml", lambda: febio_xml(material, name))):
        try:
            text = fn()
        except ValueError:
            continue
        path = f"{stem}.{ext}"
        with open(path, "w") as f:
            f.write(text)
        out[fmt] = path
    return out

