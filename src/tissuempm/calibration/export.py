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
* LS-DYNA ``*MAT_ANISOTROPIC_HYPERELASTIC`` (MAT_295) for HGO: see :func:`_mat295_hgo`
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


def _check_hgo_form(el: Material, solver: str) -> None:
    """Refuse an HGO law with ``fiber_kinematics = "full"``: Abaqus, LS-DYNA (MAT_295) and FEBio all use
    the isochoric fiber invariants, so the card would describe a different law."""
    form = getattr(el, "fiber_kinematics", "isochoric")
    if form != "isochoric":
        raise ValueError(
            f"hgo.fiber_kinematics = {form!r}: {solver}'s HGO uses the isochoric fiber invariants "
            "(fiber_kinematics = 'isochoric'); a 'full' HGO has no equivalent card and is not exported"
        )


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
        _check_hgo_form(el, "Abaqus")
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
    """One fixed-format card: 8 fields of 10 characters (strings left-justified, numbers right-justified,
    reals with as many significant digits as fit)."""
    cells = []
    for v in values:
        if isinstance(v, str):
            cells.append(v.ljust(10))
            continue
        if v is None:
            s = ""
        elif isinstance(v, int):
            s = str(v)
        else:  # the most significant digits that fit (nu = 0.4999995 must not round to 0.5)
            s = next(t for t in (f"{v:.{p}g}" for p in range(9, 0, -1)) if len(t) <= 10)
        cells.append(s.rjust(10))
    return "".join(cells)


def poisson_ratio(K: float, G: float) -> float:
    """Poisson's ratio nu = (3K - 2G) / (6K + 2G) of an isotropic solid with bulk modulus K and shear modulus G."""
    return (3.0 * K - 2.0 * G) / (6.0 * K + 2.0 * G)


def _mat295_hgo(el: Material, mid: int, rho: float, stress: float) -> list[str]:
    """``*MAT_ANISOTROPIC_HYPERELASTIC`` (MAT_295) cards of an HGO law, one fiber family along the a-axis.

    Card layout as in the LS-DYNA keyword manual (Vol. II, MAT_295) and Ansys' ``pydyna`` keyword
    classes: ``MID RHO AOPT`` / ``ISO ITYPE BETA NU`` / isotropic parameters / ``ANISO ATYPE
    INTYPE NF`` / per fiber ``THETA A B`` and ``FTYPE FCID K1 K2`` / the AOPT = 2 axes
    ``XP YP ZP A1 A2 A3 MACF`` and ``V1 V2 V3 D1 D2 D3 BETA REF``. Mapping:

    * matrix C10 (I1b - 3): isotropic module ITYPE = -2 (Yeoh, W = sum c_i (I1b - 3)^i) with
      c1 = C10, c2 = c3 = 0. Yeoh's c_i carry no convention factor, unlike Ogden's mu_i;
    * NU = (3K - 2 G0)/(6K + 2 G0), G0 = 2 C10: LS-DYNA derives the bulk modulus from NU, so K at
      J = 1 is reproduced; BETA (the volumetric-function coefficient) is 0. The volumetric function
      behind BETA could not be checked against the manual text here, so U(J) away from J = 1 may
      differ from tissuempm's ``volumetric`` form (negligible for nearly incompressible tissue);
    * fiber family: ATYPE = -1 (generalized structure tensor H = A I + B a0 (x) a0, Holzapfel et al.),
      INTYPE = 0, NF = 1, THETA = 0 (along the material a-axis), A = kappa, B = 1 - 3 kappa, so that
      H : C - 1 = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1) is the HGO fiber strain E; FTYPE = 1 (HGO
      fiber, W = k1/(2 k2) (exp(k2 <E>^2) - 1)), FCID = 0, K1 = k1, K2 = k2;
    * AOPT = 2 with a = e1, d = e2: the fibers run along global x. Replace these two cards (or
      AOPT) with the part's own fiber directions.

    Unverified here (no manual text at hand): ITYPE = -2 is the only Yeoh code listed; for ATYPE the
    keyword documentation lists "EQ.-1/+1" with the sign choosing the compressible or the nearly
    incompressible formulation, and -1 follows the published decks that pair it with a negative
    ITYPE. Check both signs and BETA against the manual of the LS-DYNA version in use. MAT_295
    is written without Prony terms, so a viscoelastic HGO is not exported.
    """
    G0 = 2.0 * el.C10
    return [
        "*MAT_ANISOTROPIC_HYPERELASTIC",
        "$      MID       RHO      AOPT",
        _card([mid, rho, 2.0]),
        "$    TITLE     ITYPE      BETA        NU",
        _card(["ISO", -2, 0.0, poisson_ratio(el.K, G0)]),
        "$       C1        C2        C3",
        _card([el.C10 / stress, 0.0, 0.0]),
        "$    TITLE     ATYPE    INTYPE        NF",
        _card(["ANISO", -1, 0, 1]),
        "$    THETA         A         B",
        _card([0.0, el.kappa, 1.0 - 3.0 * el.kappa]),
        "$    FTYPE      FCID        K1        K2",
        _card([1, 0, el.k1 / stress, el.k2]),
        "$       XP        YP        ZP        A1        A2        A3      MACF",
        _card([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1]),
        "$       V1        V2        V3        D1        D2        D3      BETA       REF",
        _card([0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]),
    ]


def lsdyna_cards(material: Material, mid: int = 1, units: str = "SI") -> str:
    """LS-DYNA keywords (``*MAT_OGDEN_RUBBER``, ``*MAT_ANISOTROPIC_HYPERELASTIC``, ``*MAT_ELASTIC``,
    ``*MAT_GENERAL_VISCOELASTIC``, ``*MAT_NULL`` + ``*EOS_GRUNEISEN``) in ``units``."""
    if units not in UNIT_SYSTEMS:
        raise ValueError(f"units = {units!r}: valid are {', '.join(UNIT_SYSTEMS)}")
    u = UNIT_SYSTEMS[units]
    el, g, tau, _ = _split(material)
    rho = material.density / u["density"]
    g_inf = 1.0 - sum(g)
    out = [f"$ tissuempm export, units {units}"]
    if el.kind == "ogden":
        G0 = sum(el.mu)
        mu_dyna = [2.0 * m / a * g_inf / u["stress"] for m, a in zip(el.mu, el.alpha)]
        out += ["*MAT_OGDEN_RUBBER", _card([mid, rho, poisson_ratio(el.K, G0), 0, len(g), None, None, None])]
        out.append(_card(mu_dyna + [0.0] * (8 - len(mu_dyna))))
        out.append(_card(list(el.alpha) + [0.0] * (8 - len(el.alpha))))
        for gi, ti in zip(g, tau):
            out.append(_card([gi * G0 / u["stress"], u["time"] / ti]))
    elif el.kind == "hgo":
        _check_hgo_form(el, "LS-DYNA")
        if g:
            raise ValueError("no LS-DYNA export for a viscoelastic HGO (MAT_295 is written without Prony terms)")
        out += _mat295_hgo(el, mid, rho, u["stress"])
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
    key = None
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
_FEBIO_COUPLED: frozenset[str] = frozenset({"linear_elastic", "polynomial"})
"""Kinds whose FEBio material is not an uncoupled one (wrapped in ``viscoelastic``, not ``uncoupled viscoelastic``)."""


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
    elif kind in ("yeoh", "reduced_polynomial"):
        e.set("type", "Yeoh")  # FEYeoh: W = sum_i c_i (I1b - 3)^i, i <= 6
        coefficients = el.C if kind == "reduced_polynomial" else (el.C10, el.C20, el.C30)
        for i, c in enumerate(coefficients, start=1):
            p(f"c{i}", c)
        p("k", el.K)
    elif kind == "polynomial":
        e.set("type", "polynomial")  # FEPolynomialHyperElastic: U = D1 (J - 1)^2, so D1 = K/2
        for name in ("c10", "c01", "c20", "c11", "c02"):
            p(name, getattr(el, name.upper()))
        p("D1", 0.5 * el.K)
    elif kind == "hgo":
        _check_hgo_form(el, "FEBio")
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
        uncoupled = el.kind not in _FEBIO_COUPLED
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

