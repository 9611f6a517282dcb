"""HDF5 checkpoints of the particle state (h5py).

A checkpoint holds every array of ``State.to_numpy()`` as a dataset and a JSON
string attribute ``meta`` (time, step, output counters, a hash of the scenario).
It is written to a temporary file and renamed onto the target, so the previous
checkpoint survives a crash during the write.

``meta["dtypes"]`` records each array's dtype. On reading, :func:`check_arrays` refuses a
checkpoint whose arrays are not numeric (e.g. stored as strings), differ from the recorded
dtype, or hold a NaN or infinity in a float array (except :data:`MAY_BE_NAN`): a damaged
checkpoint is a named error, never a restart that runs on garbage.
"""

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from tissuempm.io.files import _plain, atomic_path

FORMAT = "tissuempm-checkpoint-1"


MAY_BE_NAN = frozenset({"dt_ref"})
"""Float arrays that may hold NaN (``dt_ref`` is NaN until the first step sets it)."""


class CheckpointError(RuntimeError):
    """A checkpoint is missing, unreadable or from another scenario."""


def check_arrays(arrays: dict[str, Any], declared: Any, path: str | Path) -> None:
    """Raise :class:`CheckpointError` unless every array is numeric (or bool), of its ``declared`` dtype
    (name -> ``dtype.str``, when recorded) and finite where it is a float array."""
    if declared is not None and not isinstance(declared, dict):
        raise CheckpointError(f"{path} has an unreadable 'meta' attribute: 'dtypes' is not a JSON object")
    declared = declared or {}
    for name in sorted(set(declared) - set(arrays)):
        raise CheckpointError(f"{path} is not a complete checkpoint of this run: the array {name!r} it records "
                              "is missing")
    for name, value in arrays.items():
        a = np.asarray(value)
        want = declared.get(name)
        if a.dtype.kind not in "biuf":
            raise CheckpointError(f"{path} is damaged: the array {name!r} holds {a.dtype} data, not numbers"
                                  + (f" (written as {np.dtype(want)})" if isinstance(want, str) else ""))
        if want is not None and a.dtype.str != want:
            raise CheckpointError(f"{path} is damaged: the array {name!r} is {a.dtype}, written as {want}")
        if a.dtype.kind == "f" and name not in MAY_BE_NAN:
            bad = a.size - int(np.count_nonzero(np.isfinite(a)))
            if bad:
                raise CheckpointError(f"{path} is damaged: the array {name!r} holds {bad} value(s) that are NaN "
                                      "or infinite; restart from an intact checkpoint or start anew with --overwrite")


def write_checkpoint(path: str | Path, arrays: dict[str, Any], meta: dict[str, Any]) -> None:
    """Write ``arrays`` (name -> array or scalar) and ``meta`` (JSON-serialisable) to ``path`` atomically;
    ``meta["dtypes"]`` is added (each array's dtype, checked on reading)."""
    arrays = {name: np.asarray(value) for name, value in arrays.items()}
    meta = {**meta, "dtypes": {name: a.dtype.str for name, a in arrays.items()}}
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["meta"] = json.dumps(_plain(meta))
        grp = f.create_group("state")
        for name, value in arrays.items():
            grp.create_dataset(name, data=value)


def read_checkpoint(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read a checkpoint: ``(arrays, meta)`` (``meta`` as written, without ``dtypes``); 0-d datasets come
    back as NumPy scalars.

    Raises :class:`CheckpointError` for a missing, unreadable or damaged file (:func:`check_arrays`)."""
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
    check_arrays(arrays, meta.pop("dtypes", None), path)
    return arrays, meta
