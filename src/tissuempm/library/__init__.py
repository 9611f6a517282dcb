"""Tissue parameter library: published material parameter sets by name.

Built-in entries: the 39 head and torso components of Brewick et al. 2017
(NRL report, tables A1-A4: equations of state, hyperelastic, viscoelastic bone,
hyper-viscoelastic soft tissue), the parameter sets of the tests of Ionescu
et al. 2006 (myocardium, medial collateral ligament, lead projectile) and ballistic
gelatin cards of explicit impact codes (failure layer around elastic-plastic). All values
are SI; derived quantities (bulk moduli from Poisson's ratios, rule-of-mixture
bone properties, ...) are computed from the published inputs.

>>> from tissuempm import library
>>> entry = library.get("csf")
>>> entry.table, entry.group, entry.kind
('A1', 'csf', 'us_up')
>>> round(library.derived(entry.alternative("neo_hookean"))["D1"].value * 1e9, 3)
0.913

User entries are read from ``~/.tissuempm/materials``, the directories in
``TISSUEMPM_LIBRARY_PATH`` and paths given to :func:`register`; :func:`write_entry`
writes one (see docs/library.md).
"""

from tissuempm.library.catalog import (
    ENV_VAR,
    LibraryFileError,
    NotLibraryFile,
    builtin_entries,
    entries,
    get,
    names,
    read_file,
    register,
    unregister,
)
from tissuempm.library.derived import Quantity, StatedCheck, check_stated, derived
from tissuempm.library.entry import LibraryEntry
from tissuempm.library.stability import ModeStability, StabilityReport, stability
from tissuempm.library.userfile import write_entry

__all__ = [
    "ENV_VAR",
    "LibraryEntry",
    "LibraryFileError",
    "NotLibraryFile",
    "ModeStability",
    "Quantity",
    "StabilityReport",
    "StatedCheck",
    "builtin_entries",
    "check_stated",
    "derived",
    "entries",
    "get",
    "names",
    "read_file",
    "register",
    "stability",
    "unregister",
    "write_entry",
]
