"""shells: thin elastic shells with natural curvature in FEniCSx (dolfinx 0.9).

Computes how spherical caps, closed spheres, ellipsoidal caps and disks deform, buckle and snap when
a natural (spontaneous) curvature kappa is imposed, following Pezzulla, Stoop, Steranka, Bade and
Holmes, "Curvature-Induced Instabilities of Shells", Phys. Rev. Lett. 120, 048002 (2018).
The NumPy/geometry layer imports without dolfinx; meshing and models import it lazily.
"""

from __future__ import annotations

__version__ = "0.1.0"

from shells.errors import InputError
from shells.geometry import Disk, EllipsoidalCap, Sphere, SphericalCap, make_shape

__all__ = ["__version__", "InputError", "Sphere", "SphericalCap", "EllipsoidalCap", "Disk",
           "make_shape"]
