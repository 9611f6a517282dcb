"""The head label volume (tissuempm.head): the synthetic head against its closed-form volumes, the
ICBM 2009a build against the template's own tissue volume and the layer thicknesses, the label
table against the library, the command's outputs and errors, and the scenario snippet."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tissuempm import library
from tissuempm.cli import app
from tissuempm.head import HEAD_LABELS, LABEL, LAYERS, build_head, synthetic_head, write_nifti
from tissuempm.head import synthetic as syn
from tissuempm.head.build import effective_layers, label_stats

ROOT = Path(__file__).resolve().parents[2]


def _area(axes) -> float:
    """Surface area of an ellipsoid (Thomsen's formula, within 1.1 %)."""
    a, b, c = axes
    p = 1.6075
    return 4 * math.pi * (((a * b) ** p + (a * c) ** p + (b * c) ** p) / 3) ** (1 / p)


def _bounding_area(name: str) -> float:
    """An upper bound of the area of the surfaces bounding a label of the synthetic head."""
    vent, stem = _area(syn.VENTRICLES[1]), _area(syn.BRAIN_STEM[1])
    disk = lambda axes: math.pi * axes[0] * axes[1]  # noqa: E731  (the cerebellum plane's section)
    shells = dict(syn._shells())
    inner = {"csf": syn.BRAIN, "skull_inner_table": shells["csf"], "skull_diploe": shells["skull_inner_table"],
             "skull_outer_table": shells["skull_diploe"], "scalp": shells["skull_outer_table"]}  # fmt: skip
    if name in shells:
        return _area(shells[name]) + _area(inner[name])
    return {
        "ventricles": vent,
        "brain_stem": stem,
        "cerebrum_white_matter": _area(syn.WHITE_MATTER) + disk(syn.WHITE_MATTER) + vent,
        "cerebellum_white_matter": _area(syn.WHITE_MATTER) + disk(syn.WHITE_MATTER) + stem,
        "cerebrum_grey_matter": _area(syn.BRAIN) + _area(syn.WHITE_MATTER) + disk(syn.BRAIN),
        "cerebellum_grey_matter": _area(syn.BRAIN) + _area(syn.WHITE_MATTER) + disk(syn.BRAIN),
    }[name]


@pytest.mark.parametrize("h", [0.001, 0.002])
def test_synthetic_head_volumes_match_the_ellipsoids(h):
    """Each label's voxel volume against its closed form (ellipsoids, caps below a plane).

    A voxel is labelled by its centre, so it is wrong only within half its diagonal (h sqrt(3)/2) of
    a bounding surface: |dV| <= A h sqrt(3)/2. The errors of the two sides of a smooth surface cancel
    to first order; we allow a tenth of the bound (measured: at most 0.36 of that allowance at 1 mm
    and 0.62 at 2 mm; the largest relative errors, 2.3 % and 4.2 %, are the small ellipsoids')."""
    labels, affine = synthetic_head(h)
    assert labels.dtype == np.int32 and affine.shape == (4, 4)
    np.testing.assert_allclose(np.diag(affine)[:3], h)
    exact = syn.analytic_volumes()
    assert set(exact) == {name for name, _ in HEAD_LABELS.values()}
    for name, v in exact.items():
        voxels = np.count_nonzero(labels == LABEL[name]) * h**3
        tol = 0.1 * _bounding_area(name) * h * math.sqrt(3) / 2
        assert abs(voxels - v) < tol, (name, voxels, v, tol)
    assert 1.1e-3 < sum(exact[n] for n in ("cerebrum_grey_matter", "cerebrum_white_matter", "cerebellum_grey_matter",
                                           "cerebellum_white_matter", "brain_stem")) < 1.6e-3  # fmt: skip


def test_label_table_maps_to_the_library():
    """Every label names a tissue of seed 004's Table 1 in the library; the shipped TOML is the table."""
    assert sorted(HEAD_LABELS) == list(range(1, 12))
    for value, (_name, entry) in HEAD_LABELS.items():
        assert library.get(entry).table in ("A1", "A2", "A3", "A4"), (value, entry)
    assert HEAD_LABELS[LABEL["skull_diploe"]][1] == "skull_cancellous"
    assert HEAD_LABELS[LABEL["scalp"]][1] == "skin"


def test_nifti_round_trip(tmp_path):
    """write_nifti stores metres as NIfTI millimetres; the scenario reader gives them back in metres."""
    from tissuempm.scenarios.images import read_volume

    labels, affine = synthetic_head(0.004)
    affine = affine.copy()
    affine[:3, 3] += [0.01, -0.02, 0.03]
    write_nifti(tmp_path / "h.nii.gz", labels, affine)
    vol = read_volume(tmp_path / "h.nii.gz")
    np.testing.assert_array_equal(vol.labels, labels)
    np.testing.assert_allclose(vol.affine, affine, atol=1e-9)


@pytest.fixture(scope="module")
def icbm_6mm():
    pytest.importorskip("nilearn")
    return build_head(0.006)


def test_icbm_head_at_6_mm(icbm_6mm):
    """Each label present; the brain keeps the template's tissue volume; layers in order at the vertex."""
    from tissuempm.head.anatomy import load_templates

    labels, affine = icbm_6mm
    h = 0.006
    np.testing.assert_allclose(np.linalg.norm(affine[:3, :3], axis=0), h)
    stats = label_stats(labels, affine)
    for name, v in stats["volume_ml"].items():
        assert v > 0.0, name
    # the template's own brain volume: the integral of p_gm + p_wm at 1 mm (1678 mL; MNI space is
    # larger than the mean adult brain, docs/head.md). Thresholding at 0.5 after averaging over the
    # voxel keeps it within a few per cent (the 1 mm build: 1730 mL, +3 %)
    maps, _ = load_templates()
    template_ml = float((maps["gm"] + maps["wm"]).sum()) * 1e-3
    assert abs(stats["brain_volume_ml"] - template_ml) < 0.06 * template_ml
    # ventricles: 10-40 mL in young adults; the build gives about 19 mL at 1 to 6 mm
    assert 10.0 < stats["volume_ml"]["ventricles"] < 40.0
    # up from the centroid: brain, then CSF, the three skull layers and the scalp in this order, then air
    order = stats["vertex_order"]
    assert order[-6:] == [LABEL[n] for n in ("csf", "skull_inner_table", "skull_diploe", "skull_outer_table", "scalp")] + [0]
    # each layer at least one voxel, and a band of the distance d in (D_k-1, D_k]: one or two voxels
    # thick along a grid line through a staircase surface
    for name, t in effective_layers(h):
        if name != "csf":  # the CSF above the centroid includes the interhemispheric fissure
            assert t - 1e-9 <= stats["vertex_thickness_mm"][name] * 1e-3 <= t + h + 1e-9, name


def test_head_scale_scales_the_volume():
    """scale s multiplies the brain volume by s^3 (to voxel rounding)."""
    pytest.importorskip("nilearn")
    s = 0.92
    a = label_stats(*build_head(0.008))["brain_volume_ml"]
    b = label_stats(*build_head(0.008, scale=s))["brain_volume_ml"]
    assert abs(b / a - s**3) < 1e-9  # the same voxels, each of volume (s h)^3


def test_a_larger_hull_radius_fills_wider_sulci_with_csf():
    """The same brain voxels closed by a 15 mm ball instead of 5 mm: the brain labels are unchanged, the hull
    (brain, ventricles and CSF) only grows (a closing by a larger ball contains the smaller one's), the CSF gains
    what the hull gains, and the skull's inner surface, the hull's boundary, holds fewer voxel faces for the
    hull's larger volume (the sphericity index area^1.5 / volume falls)."""
    pytest.importorskip("nilearn")
    from tissuempm.head.labels import LABEL

    a, _ = build_head(0.006)
    b, _ = build_head(0.006, hull_radius=0.015)
    brain = [LABEL[n] for n in ("cerebrum_grey_matter", "cerebrum_white_matter", "cerebellum_grey_matter",
                                "cerebellum_white_matter", "brain_stem")]  # fmt: skip
    np.testing.assert_array_equal(np.isin(a, brain), np.isin(b, brain))
    hull_a = (a >= 1) & (a <= LABEL["csf"])
    hull_b = (b >= 1) & (b <= LABEL["csf"])
    assert np.all(hull_b[hull_a]) and hull_b.sum() > 1.01 * hull_a.sum()  # 10,532 against 10,362 voxels
    assert (b == LABEL["csf"]).sum() - (a == LABEL["csf"]).sum() == hull_b.sum() - hull_a.sum() - (
        (b == LABEL["ventricles"]).sum() - (a == LABEL["ventricles"]).sum())

    def faces(m):
        return sum(int(np.abs(np.diff(m.astype(np.int8), axis=k)).sum()) for k in range(3))

    assert faces(hull_b) ** 1.5 / hull_b.sum() < 0.95 * faces(hull_a) ** 1.5 / hull_a.sum()  # 22.1 against 24.6


@pytest.mark.parametrize("args, text", [(["--hull-radius", "50 mm"], "--hull-radius '50 mm' = 0.05 m is out of range: "
                                         "choose 1 mm to 30 mm"),
                                        (["--hull-radius", "5 kg"], "wrong unit"),
                                        (["--synthetic", "--hull-radius", "10 mm"], "the --synthetic head has none")])  # fmt: skip
def test_command_bad_hull_radius_exits_2_and_writes_nothing(tmp_path, args, text):
    result = CliRunner().invoke(app, ["head", "build", "--resolution", "8 mm", "--out", str(tmp_path / "h.nii.gz"),
                                      *args])  # fmt: skip
    assert result.exit_code == 2 and text in " ".join(result.output.split()), result.output
    assert "Traceback" not in result.output and list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_icbm_head_at_1_mm_layer_thicknesses():
    """At 1 mm the layers take their literature thicknesses rounded to whole voxels."""
    pytest.importorskip("nilearn")
    labels, affine = build_head(0.001)
    stats = label_stats(labels, affine)
    for name, t in effective_layers(0.001):
        if name != "csf":
            assert abs(stats["vertex_thickness_mm"][name] - t * 1e3) <= 1.0 + 1e-9, name
    assert dict(LAYERS)["skull_diploe"] == 0.003


def test_command_writes_the_four_outputs(tmp_path):
    out = tmp_path / "head.nii.gz"
    result = CliRunner().invoke(app, ["head", "build", "--synthetic", "--resolution", "4 mm", "--out", str(out)])
    assert result.exit_code == 0, result.output
    for name in ("head.nii.gz", "head.labels.toml", "head.json", "head.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    stats = json.loads((tmp_path / "head.json").read_text())
    assert stats["resolution_mm"] == pytest.approx(4.0)
    assert (tmp_path / "head.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("value, text", [("0.1 mm", "out of range: choose 0.2 mm to 20 mm"),
                                         ("4 kg", "wrong unit"), ("fast", "cannot read")])  # fmt: skip
def test_command_bad_resolution_exits_2(tmp_path, value, text):
    result = CliRunner().invoke(app, ["head", "build", "--synthetic", "--resolution", value,
                                      "--out", str(tmp_path / "h.nii.gz")])  # fmt: skip
    assert result.exit_code == 2
    assert text in " ".join(result.output.split()) and "--resolution" in result.output
    assert "Traceback" not in result.output


def test_scenario_snippet_seeds_every_label(tmp_path):
    """examples/head/head_labels.toml with the synthetic head: 11 bodies of library tissues, each
    seeded with the volume of its label (nearest-voxel resampling on the 8 mm grid)."""
    from tissuempm.scenarios import load_scenario
    from tissuempm.scenarios.build import build_model, seed_particles

    shutil.copy(ROOT / "examples" / "head" / "head_labels.toml", tmp_path)
    result = CliRunner().invoke(app, ["head", "build", "--synthetic", "--resolution", "2 mm",
                                      "--out", str(tmp_path / "head.nii.gz")])  # fmt: skip
    assert result.exit_code == 0, result.output
    sc = load_scenario(tmp_path / "head_labels.toml")
    assert [b.name for b in sc.bodies] == [name for name, _ in HEAD_LABELS.values()]
    assert sc.materials["skull_cancellous"] == {"library": "skull_cancellous"}
    particles, body = seed_particles(sc, build_model(sc))
    exact = syn.analytic_volumes()
    total = float(particles.volume.sum())
    # a particle is wrong only within half a particle diagonal of the scalp's outer surface: A d/2 / V
    # is 6 % here; the two sides cancel to first order: 2 % allowed (measured 0.06 %, white matter 0.6 %)
    assert abs(total - sum(exact.values())) < 0.02 * total
    brain = [i for i, b in enumerate(sc.bodies) if b.name == "cerebrum_white_matter"][0]
    v = float(particles.volume[body == brain].sum())
    assert abs(v - exact["cerebrum_white_matter"]) < 0.05 * exact["cerebrum_white_matter"]


def test_head_command_imports_no_image_library():
    """``tissuempm --help`` lists the head group; naming it loads neither nibabel, nilearn nor SciPy."""
    import subprocess
    import sys

    code = ("import sys, typer; from tissuempm.cli import app; group = typer.main.get_command(app); "
            "assert group.get_command(None, 'head').get_command(None, 'build') is not None; "
            "print(' '.join(m for m in sys.modules if m.split('.')[0] in ('nibabel', 'nilearn', 'nrrd', 'tifffile') "
            "or m == 'scipy.ndimage'))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == []
