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
* FEBio: uncoupled ``Ogden`` with ``c_i = 2 mu_i`` and ``m_i = alpha_i``; ``Mooney-Rivlin``
  with c1 = C10, c2 = C01; viscoelastic ``G(t) = g0 + sum g_i exp(-t/t_i)`` with
  ``g0 = g_inf`` around the instantaneous law.

Units: LS-DYNA has no unit system of its own; ``units`` selects one of :data:`UNIT_SYSTEMS`
and every value is converted from SI. Abaqus and FEBio cards are written in SI.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

from tissuempm.materials.base import Material

UNIT_SYSTEMS: dict[str, dict[str, float]] = {
    "SI": {"stress": 1.0, "density": 1.0, "time": 1.0, "velocity": 1.0},
    "mm-ms-kg": {"stress": 1.0e9, "density": 1.0e9, "time": 1.0e-3, "velocity": 1.0},
    "mm-s-tonne": {"stress": 1.0e6, "density": 1.0e12, "time": 1.0, "velocity": 1.0e-3},
}
"""SI value of one unit of stress, density, time and velocity in each system (value_file = SI / factor)."""


def _split(material: Material) -> tuple[Material, tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    if getattr(material, "kind", "") == "viscoelastic":
        k = tuple(material.k) if material.k else ()
        return material.elastic, tuple(material.g), tuple(material.tau), k
    return material, (), (), ()


def _lines(values: list[float], per_line: int = 8) -> list[str]:
    return [", ".join(f"{v:.8g}" for v in values[i : i + per_line]) for i in range(0, len(values), per_line)]


# ---------------------------------------------------------------------- Abaqus
def abaqus_cards(material: Material, name: str = "TISSUE") -> str:
    """Abaqus keywords ``*MATERIAL ... *DENSITY, *HYPERELASTIC/*ELASTIC/*EOS, *VISCOELASTIC`` (SI)."""
    el, g, tau, k = _split(material)
    out = [f"*MATERIAL, NAME={name}", "*DENSITY", f"{material.density:.8g},"]
    kind = el.kind
    D = 2.0 / el.K if hasattr(el, "K") else 0.0
    if kind == "ogden":
        n = len(el.mu)
        vals = [v for m, a in zip(el.mu, el.alpha) for v in (m, a)] + [D] + [0.0] * (n - 1)
        out += [f"*HYPERELASTIC, OGDEN, N={n}", *_lines(vals)]
    elif kind == "polynomial":
        vals = [el.C10, el.C01, el.C20, el.C11, el.C02, D, 0.0]
        out += ["*HYPERELASTIC, POLYNOMIAL, N=2", *_lines(vals)]
    elif kind == "mooney_rivlin":
        out += ["*HYPERELASTIC, POLYNOMIAL, N=1", *_lines([el.C10, el.C01, D])]
    elif kind == "neo_hookean":
        out += ["*HYPERELASTIC, REDUCED POLYNOMIAL, N=1", *_lines([el.C10, D])]
    elif kind == "yeoh":
        out += ["*HYPERELASTIC, REDUCED POLYNOMIAL, N=3", *_lines([el.C10, el.C20, el.C30, D, 0.0, 0.0])]
    elif kind == "reduced_polynomial":
        n = len(el.C)
        out += [f"*HYPERELASTIC, REDUCED POLYNOMIAL, N={n}", *_lines([*el.C, D] + [0.0] * (n - 1))]
    elif kind == "hgo":
        out += ["*ANISOTROPIC HYPERELASTIC, HOLZAPFEL, LOCAL DIRECTIONS=1", *_lines([el.C10, D, el.k1, el.k2, el.kappa])]
    elif kind == "linear_elastic":
        out += ["*ELASTIC", *_lines([el.E, el.nu])]
    elif kind == "us_up":
        out += ["*EOS, TYPE=USUP", *_lines([el.c0, el.s, el.gamma0])]
        if getattr(el, "viscosity", 0.0):
            out += ["*VISCOSITY", f"{el.viscosity:.8g},"]
    else:
        raise ValueError(f"no Abaqus export for material kind {kind!r}")
    if g:
        kk = k or ((g if kind == "linear_elastic" else (0.0,) * len(g)))
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
def _card(values: list[Any]) -> str:
    """One fixed-format card: 8 fields of 10 characters."""
    cells = []
    for v in values:
        s = "" if v is None else (str(v) if isinstance(v, int) else f"{v:.4E}" if abs(v) >= 1e6 or (v != 0 and abs(v) < 1e-3) else f"{v:.6g}")
        if len(s) > 10:
            s = f"{v:.3E}"
        cells.append(s.rjust(10))
    return "".join(cells)


def lsdyna_cards(material: Material, mid: int = 1, units: str = "SI") -> str:
    """LS-DYNA keywords (``*MAT_OGDEN_RUBBER``, ``*MAT_ELASTIC``, ``*EOS_GRUNEISEN``) in ``units``."""
    if units not in UNIT_SYSTEMS:
        raise ValueError(f"units = {units!r}: valid are {', '.join(UNIT_SYSTEMS)}")
    u = UNIT_SYSTEMS[units]
    el, g, tau, _ = _split(material)
    rho = material.density / u["density"]
    g_inf = 1.0 - sum(g)
    out = [f"$ tissuempm export, units {units}"]
    if el.kind == "ogden":
        G0 = sum(el.mu)
        nu = (3 * el.K - 2 * G0) / (6 * el.K + 2 * G0)
        mu_dyna = [2.0 * m / a * g_inf / u["stress"] for m, a in zip(el.mu, el.alpha)]
        out += ["*MAT_OGDEN_RUBBER", _card([mid, rho, nu, 0, len(g), None, None, None])]
        out.append(_card(mu_dyna + [0.0] * (8 - len(mu_dyna))))
        out.append(_card(list(el.alpha) + [0.0] * (8 - len(el.alpha))))
        for gi, ti in zip(g, tau):
            out.append(_card([gi * G0 / u["stress"], u["time"] / ti]))
    elif el.kind == "linear_elastic":
        if g:
            K = el.E / (3 * (1 - 2 * el.nu)) / u["stress"]
            G0 = el.E / (2 * (1 + el.nu))
            out += ["*MAT_GENERAL_VISCOELASTIC", _card([mid, rho, K, None, None, None, None, None])]
            out.append(_card([g_inf * G0 / u["stress"], 0.0]))
            for gi, ti in zip(g, tau):
                out.append(_card([gi * G0 / u["stress"], u["time"] / ti]))
        else:
            out += ["*MAT_ELASTIC", _card([mid, rho, el.E / u["stress"], el.nu])]
    elif el.kind == "us_up":
        out += ["*MAT_NULL", _card([mid, rho, 0.0, getattr(el, "viscosity", 0.0) / (u["stress"] * u["time"])])]
        out += ["*EOS_GRUNEISEN", _card([mid, el.c0 / u["velocity"], el.s, 0.0, 0.0, el.gamma0, 0.0, 0.0]), _card([1.0])]
    else:
        raise ValueError(f"no LS-DYNA export for material kind {el.kind!r}")
    return "\n".join(out) + "\n*END\n"


def read_lsdyna(text: str) -> dict[str, list[list[float]]]:
    """Parse fixed-format cards into ``{keyword: [card values...]}`` (blank fields as None)."""
    out: dict[str, list[list[float | None]]] = {}
    key = None
    for ln in text.splitlines():
        if not ln.strip() or ln.startswith("$"):
            continue
        if ln.startswith("*"):
            key = ln.strip().upper()
            out[key] = []
            continue
        cells = [ln[i : i + 10].strip() for i in range(0, len(ln), 10)]
        out[key].append([float(c) if c else None for c in cells])
    return out


# ---------------------------------------------------------------------- FEBio
def _elastic_xml(el: Material, tag: str = "material") -> ET.Element:
    e = ET.Element(tag)
    kind = el.kind

    def p(name: str, v: float) -> None:
        ET.SubElement(e, name).text = f"{v:.10g}"

    if kind == "ogden":
        e.set("type", "Ogden")
        for i, (m, a) in enumerate(zip(el.mu, el.alpha), start=1):
            p(f"c{i}", 2.0 * m)
            p(f"m{i}", a)
        p("k", el.K)
    elif kind in ("mooney_rivlin", "neo_hookean"):
        e.set("type", "Mooney-Rivlin")
        p("c1", el.C10)
        p("c2", getattr(el, "C01", 0.0))
        p("k", el.K)
    elif kind == "hgo":
        e.set("type", "Holzapfel-Gasser-Ogden")
        p("c", 2.0 * el.C10)
        p("k1", el.k1)
        p("k2", el.k2)
        p("kappa", el.kappa)
        p("gamma", 0.0)
        p("k", el.K)
    elif kind == "linear_elastic":
        e.set("type", "isotropic elastic")
        p("E", el.E)
        p("v", el.nu)
    else:
        raise ValueError(f"no FEBio export for material kind {kind!r}")
    return e


def febio_xml(material: Material, name: str = "tissue", mat_id: int = 1) -> str:
    """FEBio ``<material>`` element (SI)."""
    el, g, tau, _ = _split(material)
    if g:
        uncoupled = el.kind != "linear_elastic"
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
            d[c.tag] = walk(c) if len(c) else float(c.text)
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

