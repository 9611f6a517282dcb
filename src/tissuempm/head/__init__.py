"""A human head as a label volume for MPM: brain from the ICBM 2009a templates, CSF, skull, scalp.

* :func:`build_head` (:mod:`.build`): the label volume from the ICBM 2009a nonlinear symmetric
  templates that ship in nilearn's wheel (``pip install 'tissuempm[head]'``), rules in
  :mod:`.anatomy`, CSF/skull/scalp layers of literature thickness (:data:`LAYERS`).
* :func:`synthetic_head` (:mod:`.synthetic`): nested ellipsoids with the same labels, for tests.
* :data:`HEAD_LABELS` (:mod:`.labels`): label -> (name, tissue library entry), shipped as
  ``labels.toml``, the table a scenario's ``[[label_volume]]`` reads.
* :func:`write_nifti`; the command ``tissuempm head build`` (:mod:`.command`).

Both builders return ``(labels, affine)``: an int32 array and the 4x4 voxel -> RAS+ metres affine.
See docs/head.md.
"""

from tissuempm.head.build import LAYERS, HeadError, build_head, write_nifti
from tissuempm.head.labels import HEAD_LABELS, LABEL
from tissuempm.head.synthetic import synthetic_head

__all__ = ["HEAD_LABELS", "LABEL", "LAYERS", "HeadError", "build_head", "synthetic_head", "write_nifti"]
