"""Label volumes as scenario bodies (tissuempm.scenarios.images): readers, frames, errors, and the
verification of issue 20 item 5c: each label's seeded volume and centroid against the analytic ones.

The phantom: an ellipsoid (label 1) holding a smaller, off-centre ellipsoid (label 2), voxelised
at an anisotropic spacing and written in every format, each with its own header convention
(NIfTI RAS+ with a flipped and permuted affine, NRRD in LPS, TIFF and .npy with the spacing given
by the scenario, .npz with it stored). The seeded bodies are compared in the world frame, so a
wrong axis order, a missed flip or LPS sign, or a mm/m slip moves a centroid by centimetres.
"""

import math
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from tissuempm.scenarios import ScenarioError, images, load_scenario
from tissuempm.scenarios.build import build_model, seed_particles
from tissuempm.scenarios.schema import Scenario

CENTRE = np.array([0.004, -0.003, 0.002])  # world centre of the outer ellipsoid [m]
OUTER = np.array([0.020, 0.015, 0.012])  # semi-axes [m]
INNER = np.array([0.007, 0.005, 0.004])
SHIFT = np.array([0.005, 0.003, -0.002])  # centre of the inner ellipsoid relative to CENTRE [m]
SPACING = np.array([0.0005, 0.0007, 0.0006])  # voxel edges along the world axes x, y, z [m]
CELL, PER_CELL = 0.001, 2


def analytic() -> dict[int, tuple[float, np.ndarray]]:
    """Label -> (volume [m^3], centroid [m]) of the phantom."""
    v_out, v_in = (4.0 / 3.0 * math.pi * float(np.prod(a)) for a in (OUTER, INNER))
    c_in = CENTRE + SHIFT
    return {2: (v_in, c_in), 1: (v_out - v_in, (v_out * CENTRE - v_in * c_in) / (v_out - v_in))}


def phantom(world: np.ndarray) -> np.ndarray:
    """Labels (int16) at world points (..., 3) [m]."""
    inside = lambda c, a: (((world - c) / a) ** 2).sum(axis=-1) <= 1.0  # noqa: E731
    out = np.zeros(world.shape[:-1], dtype=np.int16)
    out[inside(CENTRE, OUTER)] = 1
    out[inside(CENTRE + SHIFT, INNER)] = 2
    return out


def voxelise(affine: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """The phantom sampled at the voxel centres of ``affine`` (index -> world [m])."""
    idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).astype(float)
    return phantom(idx @ affine[:3, :3].T + affine[:3, 3])


def flipped_affine() -> tuple[np.ndarray, tuple[int, int, int]]:
    """A non-identity affine: i runs along -x (a flip), j along z, k along y (a permutation)."""
    lo, hi = CENTRE - OUTER - 0.002, CENTRE + OUTER + 0.002
    n = np.ceil((hi - lo) / SPACING).astype(int) + 1
    a = np.zeros((4, 4))
    a[3, 3] = 1.0
    a[0, 0] = -SPACING[0]  # i -> -x
    a[2, 1] = SPACING[2]  # j -> +z
    a[1, 2] = SPACING[1]  # k -> +y
    a[:3, 3] = [hi[0], lo[1], lo[2]]
    return a, (int(n[0]), int(n[2]), int(n[1]))


def plain_affine() -> tuple[np.ndarray, tuple[int, int, int]]:
    """Axis-aligned voxels of SPACING from the corner ``lo`` (for the formats without orientation)."""
    lo, hi = CENTRE - OUTER - 0.002, CENTRE + OUTER + 0.002
    n = np.ceil((hi - lo) / SPACING).astype(int) + 1
    a = np.diag([*SPACING, 1.0])
    a[:3, 3] = lo
    return a, tuple(int(v) for v in n)  # type: ignore[return-value]


def write_nifti(path: Path) -> dict:
    import nibabel as nib

    a, shape = flipped_affine()
    mm = a.copy()
    mm[:3, :] *= 1e3
    img = nib.Nifti1Image(voxelise(a, shape), mm)
    img.header.set_xyzt_units("mm")
    nib.save(img, str(path))
    return {}


def write_nrrd(path: Path) -> dict:
    import nrrd

    a, shape = flipped_affine()
    lps = np.diag([-1.0, -1.0, 1.0])
    header = {"space": "left-posterior-superior", "space directions": (lps @ a[:3, :3] * 1e3).T,
              "space origin": lps @ a[:3, 3] * 1e3}  # fmt: skip
    nrrd.write(str(path), voxelise(a, shape), header)
    return {}


def write_tiff(path: Path) -> dict:
    import tifffile

    a, shape = plain_affine()
    tifffile.imwrite(str(path), voxelise(a, shape).transpose(2, 1, 0))  # pages k, rows j, columns i
    return {"spacing": [f"{s * 1e3:g} mm" for s in SPACING], "origin": [f"{o * 1e3:g} mm" for o in a[:3, 3]]}


def write_npy(path: Path) -> dict:
    a, shape = plain_affine()
    np.save(path, voxelise(a, shape))
    return {"spacing": list(SPACING), "origin": list(a[:3, 3])}


def write_npz(path: Path) -> dict:
    a, shape = plain_affine()
    np.savez(path, labels=voxelise(a, shape).astype(np.float32), spacing=SPACING, origin=a[:3, 3])
    return {}


WRITERS = {"phantom.nii.gz": write_nifti, "phantom.nrrd": write_nrrd, "phantom.tif": write_tiff,
           "phantom.npy": write_npy, "phantom.npz": write_npz}  # fmt: skip


def _toml(value: object) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(float(value)) if isinstance(value, float) else str(value)


def scenario_text(file: str, options: dict, cell: float = CELL) -> str:
    lo, hi = CENTRE - OUTER - 0.004, CENTRE + OUTER + 0.004
    extra = "".join(f"{k} = {_toml(v)}\n" for k, v in options.items())
    return f"""
[grid]
lower = {_toml(list(lo))}
upper = {_toml(list(hi))}
cell_size = {cell!r}
[materials.gel]
kind = "neo_hookean"
C10 = "5 kPa"
K = "30 kPa"
density = "1000 kg/m^3"
[[label_volume]]
file = "{file}"
particles_per_cell = {PER_CELL}
{extra}[[label_volume.label]]
label = 1
name = "shell"
material = "gel"
[[label_volume.label]]
label = 2
name = "core"
library = "csf"
[run]
end_time = "0.1 ms"
"""


def seeded(sc: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    particles, body = seed_particles(sc, build_model(sc))
    return particles.x, particles.volume, body


def tolerances(label: int) -> tuple[float, float]:
    """(volume [m^3], centroid [m]) tolerances of a label.

    Two samplings classify a point wrongly only within half a sample of the surface: the voxels
    (the phantom at voxel centres, half-diagonal d_v/2 = 0.53 mm) and the particles (nearest-voxel
    lookup at the sub-cell centres, d_p/2 = 0.43 mm). The worst case, every sample in that band
    wrong, bounds |dV| by A (d_v + d_p)/2 (A the label's surface area); on a smooth closed surface
    the errors of the two sides cancel to first order, and we take a tenth of that bound (measured:
    1/700 to 1/30 of it, 0.03 % to 2 % of the volume). A centroid moves by |dV| R / V (R the largest
    semi-axis) plus the shift of nearest-voxel resampling: where the particle lattice and the voxel
    lattice are commensurate (0.5 mm particles on 0.5 mm voxels along x here), every particle sits
    at the same offset from its voxel's centre and the sampled shape moves by that offset, at most
    half a voxel edge (measured: 0.25 mm along x, the particles lying on the voxel faces).
    """
    band = 0.5 * (np.linalg.norm(SPACING) + math.sqrt(3.0) * CELL / PER_CELL)
    def area(a: np.ndarray) -> float:  # Thomsen's ellipsoid area formula (within 1.1 %)
        return 4 * math.pi * (((a[0] * a[1]) ** 1.6 + (a[0] * a[2]) ** 1.6 + (a[1] * a[2]) ** 1.6) / 3) ** (1 / 1.6)

    a = area(OUTER) + area(INNER) if label == 1 else area(INNER)
    dv = 0.1 * a * band
    v = analytic()[label][0]
    return dv, dv * float(OUTER.max()) / v + 0.5 * float(SPACING.max())


@pytest.mark.parametrize("name", list(WRITERS))
def test_label_volume_and_centroid_match_the_analytic_phantom(tmp_path, name):
    """Issue 20 item 5c: each format, its header convention converted to RAS+ metres."""
    options = WRITERS[name](tmp_path / name)
    (tmp_path / "s.toml").write_text(scenario_text(name, options))
    sc = load_scenario(tmp_path / "s.toml")
    assert [b.name for b in sc.bodies] == ["shell", "core"]
    x, vol, body = seeded(sc)
    for index, label in ((0, 1), (1, 2)):
        v_exact, c_exact = analytic()[label]
        keep = body == index
        v = float(vol[keep].sum())
        c = (x[keep] * vol[keep, None]).sum(axis=0) / v
        dv, dc = tolerances(label)
        assert abs(v - v_exact) < dv, (name, label, v, v_exact, dv)
        assert np.all(np.abs(c - c_exact) < dc), (name, label, c, c_exact, dc)


def test_reader_frames_agree(tmp_path):
    """The NIfTI (RAS, flipped) and NRRD (LPS) files of one phantom give one world geometry."""
    write_nifti(tmp_path / "a.nii.gz")
    write_nrrd(tmp_path / "a.nrrd")
    a, b = images.read_volume(tmp_path / "a.nii.gz"), images.read_volume(tmp_path / "a.nrrd")
    np.testing.assert_allclose(a.affine, b.affine, atol=1e-12)
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_allclose(sorted(a.spacing), sorted(SPACING), rtol=1e-6)  # mm -> m


def test_flip_offset_and_lps_frame_move_the_body(tmp_path):
    """flip mirrors about the volume's centre, offset translates, frame = LPS negates x and y."""
    write_npz(tmp_path / "p.npz")
    vol = images.read_volume(tmp_path / "p.npz")
    lo, hi = images._box(vol.affine, np.zeros(3, int), np.asarray(vol.labels.shape) - 1)
    mid = 0.5 * (lo + hi)
    base = images.LabelShape(vol, (2,))
    x = (CENTRE + SHIFT)[None]
    assert base.contains(x)[0]
    mirrored = images.LabelShape(vol, (2,), images.placement(vol, flip=("x",)))
    xm = x.copy()
    xm[0, 0] = 2 * mid[0] - x[0, 0]
    assert mirrored.contains(xm)[0] and not mirrored.contains(x)[0]
    moved = images.LabelShape(vol, (2,), images.placement(vol, offset=(0.01, 0.0, 0.0)))
    assert moved.contains(x + [0.01, 0, 0])[0]
    lps = images.LabelShape(vol, (2,), images.placement(vol, frame="LPS"))
    assert lps.contains(x * [-1, -1, 1])[0]


def test_volume_read_once_per_build(tmp_path):
    """Two bodies of one file and the validation, the checks and the seeding: one read."""
    write_npz(tmp_path / "p.npz")
    (tmp_path / "s.toml").write_text(scenario_text("p.npz", {}))
    images._cached.cache_clear()
    from tissuempm.scenarios.build import build

    build(load_scenario(tmp_path / "s.toml"))
    assert images.cache_info().misses == 1


def _bad(tmp_path: Path, text: str) -> str:
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(ScenarioError) as e:
        load_scenario(tmp_path / "s.toml")
    return str(e.value)


def test_named_errors(tmp_path):
    write_npz(tmp_path / "p.npz")
    good = scenario_text("p.npz", {})
    assert "label volume file not found" in _bad(tmp_path, good.replace("p.npz", "missing.nii.gz"))
    assert "unknown label volume format" in _bad(tmp_path, good.replace("p.npz", "p.vtk"))
    (tmp_path / "junk.nii.gz").write_bytes(b"not a nifti file")
    assert "cannot read it as a nifti file" in _bad(tmp_path, good.replace("p.npz", "junk.nii.gz"))
    np.save(tmp_path / "f.npy", np.full((4, 4, 4), 1.5))
    msg = _bad(tmp_path, scenario_text("f.npy", {"spacing": "1 mm"}))
    assert "non-integer label data" in msg and "1.5" in msg
    msg = _bad(tmp_path, good.replace("label = 2\n", "label = 7\n"))
    assert "labels [7] are not in the volume" in msg and "[0, 1, 2]" in msg
    assert "label_volume[0].label[1].label[0]" in _bad(tmp_path, good.replace("label = 2\n", "label = 2.5\n"))
    assert "spacing[1] = -1 m must be > 0" in _bad(tmp_path, scenario_text("p.npz", {"spacing": [1, -1, 1]}))
    np.save(tmp_path / "n.npy", np.ones((4, 4, 4), np.int8))
    assert "carries no voxel size: give spacing" in _bad(tmp_path, scenario_text("n.npy", {}))
    msg = _bad(tmp_path, good.replace('file = "p.npz"', 'file = "../p.npz"'))
    assert "leaves the scenario's folder" in msg
    msg = _bad(tmp_path, scenario_text("p.npz", {}, cell=0.0001))
    assert "below 0.25 of the voxel size 0.7 mm" in msg and "body[0].shape" in msg


def test_body_shape_form_and_unused_label_warning(tmp_path):
    """A [[body]] with shape type 'labels'; a label no body takes is named in a warning."""
    write_npz(tmp_path / "p.npz")
    text = scenario_text("p.npz", {})
    data = tomllib.loads(text)
    data.pop("label_volume")
    data["body"] = [{"material": "gel", "shape": {"type": "labels", "file": "p.npz", "labels": [2]}}]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = Scenario.from_dict(data, base=tmp_path)
    assert any("labels [1] are in the volume but no body takes them" in str(w.message) for w in caught)
    x, vol, _ = seeded(sc)
    v_exact, _ = analytic()[2]
    assert abs(vol.sum() - v_exact) < tolerances(2)[0]
    data["body"][0]["shape"]["labels"] = ["2"]
    with pytest.raises(ScenarioError, match=r"body\[0\]\.shape\.labels\[0\]: Input should be a valid integer"):
        Scenario.from_dict(data, base=tmp_path)


def test_cli_exit_2_on_a_bad_label_volume(tmp_path):
    from typer.testing import CliRunner

    from tissuempm.cli import app

    (tmp_path / "s.toml").write_text(scenario_text("missing.nrrd", {}))
    result = CliRunner().invoke(app, ["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    # the console wraps the message at its width, where the temporary path's length puts the breaks
    assert "label volume file not found" in " ".join(result.output.split())
    assert "Traceback" not in result.output


def test_coarse_particles_warn(tmp_path):
    """A particle spacing above 4 voxel edges (3 mm against 0.7 mm voxels) is a warning, not an error."""
    write_npz(tmp_path / "p.npz")
    (tmp_path / "s.toml").write_text(scenario_text("p.npz", {}, cell=0.006))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_scenario(tmp_path / "s.toml")
    assert any("particle spacing cell_size/particles_per_cell = 3 mm" in str(w.message) for w in caught)
