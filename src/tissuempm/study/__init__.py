"""Parameter studies on Dask: many runs of one scenario with varied keys, a table and plots.

    tissuempm study examples/studies/slab_speed.toml --out runs/speed            # local cluster
    tissuempm study FILE.toml --out DIR --scheduler tcp://host:8786              # an existing cluster
    tissuempm study FILE.toml --out DIR --resume                                 # continue

The study file (:mod:`.schema`) names a base scenario, the varied key paths with their values and
the outputs; :mod:`.sampling` combines them into runs (grid, zip, Latin hypercube, random);
:mod:`.cluster` sizes a local cluster or connects to a scheduler; :mod:`.execute` is the Dask task
of one run; :mod:`.runner` keeps the study folder and collects the rows into :mod:`.table`;
:mod:`.plots` draws each output against each parameter. Reference: ``docs/study.md``.
"""

from tissuempm.study.sampling import RunSpec, plan
from tissuempm.study.schema import Study, StudyError, load_study

__all__ = ["RunSpec", "Study", "StudyError", "load_study", "plan"]
