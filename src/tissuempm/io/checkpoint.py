"""HDF5 checkpoints of the particle state (h5py).

A checkpoint holds every array of ``State.to_numpy()`` as a dataset and a JSON
string attribute ``meta`` (time, step, output counters, a hash of the scenario).
It is written to a temporary file and renamed onto the target, so the previous
checkpoint survives a crash during the write.
"""

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from tissuempm.io.files import _plain, atomic_path

FORMAT = "tissuempm-checkpoint-1"


class CheckpointError(RuntimeError):
    """A checkpoint is missing, unreadable or from another scenario."""


def write_checkpoint(path: str | Path, arrays: dict[str, Any], meta: dict[str, Any]) -> None:
    """Write ``arrays`` (name -> array or scalar) and ``meta`` (JSON-serialisable) to ``path`` atomically."""
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["meta"] = json.dumps(_plain(meta))
        grp = f.create_group("state")
        for name, value in arrays.items():
            grp.create_dataset(name, data=np.asarray(value))


def read_checkpoint(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read a checkpoint: ``(arrays, meta)``; 0-d datasets come back as NumPy scalars."""
    path = Path(path)
    if not path.exists():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                raise CheckpointError(f"{path} is not a tissuempm checkpoint (no format attribute {FORMAT!r})")
            if "meta" not in f.attrs or not isinstance(f.get("state"), h5py.Group):
                raise CheckpointError(f"{path} is incomplete: it lacks the 'meta' attribute or the 'state' group")
            meta = json.loads(f.attrs["meta"])
            arrays = {name: ds[()] for name, ds in f["state"].items() if isinstance(ds, h5py.Dataset)}
    except OSError as e:
        raise CheckpointError(f"cannot read checkpoint {path}: {e}") from None
    except (ValueError, TypeError) as e:  # meta is not JSON
        raise CheckpointError(f"{path} has an unreadable 'meta' attribute: {e}") from None
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path} has an unreadable 'meta' attribute: not a JSON object")
    return arrays, meta
