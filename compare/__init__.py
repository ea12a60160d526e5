"""Analysis of granular-dynamics runs written in the "granular-frames" HDF5 schema.

The package is engine-agnostic on purpose: every engine (the native C++ one and
any reference engine) writes the same schema (see docs/output_schema.md), so
comparisons only ever go through :func:`compare.reader.read_run`.
"""

from .reader import Frames, Profile, Run, read_run
from .bands import BandCount, BandFormation
from .box import BigDiskHeight, ConvectiveFlux, ForceRatio, VelocityField
from .profile import AxialProfile
from .spacetime import SpaceTime, axial_profile
from .surface import FreeSurface

__all__ = ["Frames", "Profile", "Run", "read_run", "SpaceTime", "axial_profile", "AxialProfile", "BandCount",
           "BandFormation", "FreeSurface", "BigDiskHeight", "ConvectiveFlux", "ForceRatio", "VelocityField"]
