"""Start-up of the ``tissuempm`` command: what a command imports before its first step."""

import subprocess
import sys


def test_run_command_loads_neither_calibration_nor_dask():
    """Start-up of ``tissuempm run`` (issue: first step within 3 s on a warm kernel cache): the
    command group imports the calibration, analysis and study commands only when they are named,
    and the run path loads no SciPy optimizer, statistics or integrator and no Dask. Checked in a
    fresh interpreter (modules already imported by this test session would hide a regression)."""
    code = (
        "import sys, typer; from tissuempm.cli import app; "
        "group = typer.main.get_command(app); group.get_command(None, 'run'); "
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed') "
        "or m in ('scipy.optimize', 'scipy.stats', 'scipy.integrate', 'scipy.signal', 'matplotlib') "
        "or m.startswith(('tissuempm.calibration', 'tissuempm.study', 'tissuempm.analysis')))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == []
