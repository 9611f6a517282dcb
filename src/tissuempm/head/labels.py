"""The head's label table (``labels.toml``): label value -> (body name, tissue library entry).

The table is shipped as data (``src/tissuempm/head/labels.toml``) in the format of a
scenario's label table (``[[label_volume]] table = ...``, :class:`tissuempm.scenarios.schema.LabelEntry`),
so that a scenario can point at it; :data:`HEAD_LABELS` is the same table in Python. The
library entries are those of seed 004's Table 1 (Brewick et al. 2017, tables A1-A4 in
``tissuempm materials list``).
"""

import tomllib
from importlib import resources
from pathlib import Path

TABLE_FILE = "labels.toml"


def table_text() -> str:
    """The text of the shipped label table (TOML)."""
    return resources.files("tissuempm.head").joinpath(TABLE_FILE).read_text(encoding="utf-8")


def _load() -> dict[int, tuple[str, str]]:
    rows = tomllib.loads(table_text())["label"]
    return {int(r["label"]): (str(r["name"]), str(r["library"])) for r in rows}


HEAD_LABELS: dict[int, tuple[str, str]] = _load()
"""Label value -> (name, library entry): 1 cerebrum grey matter, 2 cerebrum white matter, 3 cerebellum
grey matter, 4 cerebellum white matter, 5 brain stem (pons), 6 ventricles, 7 subarachnoid CSF,
8 inner skull table, 9 diploe, 10 outer skull table, 11 scalp; 0 is air (background)."""

LABEL = {name: value for value, (name, _) in HEAD_LABELS.items()}
"""Body name -> label value."""

BRAIN = tuple(LABEL[n] for n in ("cerebrum_grey_matter", "cerebrum_white_matter", "cerebellum_grey_matter",
                                 "cerebellum_white_matter", "brain_stem"))  # fmt: skip
"""The labels of brain tissue (grey and white matter of cerebrum and cerebellum, brain stem)."""
SKULL = tuple(LABEL[n] for n in ("skull_inner_table", "skull_diploe", "skull_outer_table"))
"""The labels of the skull."""


def write_table(path: str | Path) -> Path:
    """Write the label table (TOML, the shipped ``labels.toml``) to ``path``."""
    p = Path(path)
    p.write_text(table_text(), encoding="utf-8")
    return p
