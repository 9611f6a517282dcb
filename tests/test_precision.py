"""tissuempm.precision: types per precision and the CPU compiler flags of tissuempm's kernels."""

import pytest
import warp as wp

from tissuempm.precision import cpu_compiler_flags, warp_types


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
