"""Output of MPM runs: VTU time series for ParaView, HDF5 checkpoints and a summary JSON.

All writers replace their file atomically (write a temporary file in the same
folder, then rename), so a crash never leaves a half-written file behind.
"""

from tissuempm.io.checkpoint import CheckpointError, read_checkpoint, write_checkpoint
from tissuempm.io.files import atomic_path, folder_problem, write_json
from tissuempm.io.history import HistoryLog
from tissuempm.io.vtu import VTUSeries, particle_fields, read_pvd, write_pvd

__all__ = [
    "CheckpointError",
    "HistoryLog",
    "VTUSeries",
    "atomic_path",
    "folder_problem",
    "particle_fields",
    "read_checkpoint",
    "read_pvd",
    "write_checkpoint",
    "write_json",
    "write_pvd",
]
