"""The study table: one row per finished run, rewritten (atomically) each time a run finishes.

``study.csv`` always; ``study.parquet`` too when pyarrow is importable. Columns: ``run``, ``status``
(completed, max_steps, unstable, failed), ``message`` (why a run stopped or failed, and outputs that
could not be read), one column per varied key path (SI numbers where the value is a quantity), then
the outputs (``summary.KEY``, ``wound.KEY``, ``history.COLUMN``). An empty cell is a missing value.
"""

import csv
from pathlib import Path
from typing import Any

from tissuempm.io import atomic_path

CSV = "study.csv"
PARQUET = "study.parquet"


def _column_type(values: list[Any]) -> str:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "bool"
    if all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int"
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return "float"
    return "string"


def _typed(value: Any, kind: str) -> Any:
    if value is None:
        return None
    return float(value) if kind == "float" else str(value) if kind == "string" else value


class StudyTable:
    """Rows by run name, written in run order to ``folder``."""

    def __init__(self, folder: str | Path, columns: list[str]):
        self.folder = Path(folder)
        self.columns = list(columns)
        self.rows: dict[str, dict[str, Any]] = {}

    def add(self, row: dict[str, Any]) -> None:
        """Add or replace the row of ``row["run"]``."""
        self.rows[row["run"]] = row

    def ordered(self) -> list[dict[str, Any]]:
        """Rows in run order, every column present (None where missing), typed per column."""
        rows = [self.rows[k] for k in sorted(self.rows)]
        kinds = {c: _column_type([r.get(c) for r in rows]) for c in self.columns}
        return [{c: _typed(r.get(c), kinds[c]) for c in self.columns} for r in rows]

    def write(self) -> list[Path]:
        """Write the table; returns the files written."""
        rows = self.ordered()
        path = self.folder / CSV
        with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, self.columns)
            w.writeheader()
            w.writerows({c: "" if v is None else repr(v) if isinstance(v, float) else v for c, v in r.items()}
                        for r in rows)
        written = [path]
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            return written
        data = {c: [r[c] for r in rows] for c in self.columns}
        parquet = self.folder / PARQUET
        with atomic_path(parquet) as tmp:
            pq.write_table(pa.table(data), tmp)
        return written + [parquet]
