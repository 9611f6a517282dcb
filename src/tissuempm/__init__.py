"""tissuempm: Material Point Method simulation of soft-tissue injury and
calibration of the tissue material models it uses.

Subpackages
-----------
materials    constitutive models (one module per family), homogeneous drivers
library      tissue parameter tables (Brewick et al. 2017, Ionescu et al. 2006)
calibration  fitting of model parameters to stress-strain data
mpm          explicit GIMP material point method solver (NVIDIA Warp)
scenarios    TOML scenario files and geometry builders
analysis     wound metrics and plots
io           VTU / HDF5 output and checkpoints
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
