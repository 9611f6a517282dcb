"""tissuempm.precision: types per precision and the CPU compiler flags of tissuempm's kernels."""

import subprocess
import sys

import pytest
import warp as wp

from tissuempm.precision import cpu_compiler_flags, cuda_driver_present, warp_types


def test_warp_types_bundle_the_4_vector_of_their_precision():
    assert warp_types("float64").vec4 is wp.vec4d and warp_types("float32").vec4 is wp.vec4f
    with pytest.raises(ValueError, match="float64"):
        warp_types("float16")


@pytest.mark.parametrize(
    "given, expected",
    [
        ("-march=native -mllvm=-inline-threshold=9000 -mllvm=-slp-recursion-max-depth=4",
         "-march=native -mllvm=-inline-threshold=9000"),
        ("-march=native -mllvm -slp-recursion-max-depth=4 -O2", "-march=native -O2"),
        ("", ""),
        (None, None),
    ],
)  # fmt: skip
def test_cpu_flags_drop_only_the_slp_depth_cap(monkeypatch, given, expected):
    """Warp's flags are kept (a user's generic-CPU "" too), without the SLP recursion cap."""
    monkeypatch.setattr(wp.config, "cpu_compiler_flags", given)
    assert cpu_compiler_flags() == expected


@pytest.mark.skipif(cuda_driver_present(), reason="this machine has the NVIDIA driver: Warp prints no warning")
def test_no_cuda_driver_warning_on_a_cpu_machine():
    """Without the NVIDIA driver, starting Warp through tissuempm prints nothing on stderr (Warp's
    native start-up writes "Could not find or load the NVIDIA CUDA driver" there; the CPU needs no
    driver). Run in a fresh interpreter: Warp initialises once a process."""
    code = "from tissuempm.precision import init_warp; init_warp(); import warp; print(warp.is_cuda_available())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
    assert "CUDA driver" not in out.stderr
