"""shells: thin elastic shells with natural curvature in FEniCSx (dolfinx 0.9).

Computes how spherical caps, closed spheres, ellipsoidal caps and disks deform, buckle and snap when
a natural (spontaneous) curvature kappa is imposed, following Pezzulla, Stoop, Steranka, Bade and
Holmes, "Curvature-Induced Instabilities of Shells", Phys. Rev. Lett. 120, 048002 (2018).
The NumPy/geometry layer imports without dolfinx; meshing and models import it lazily.
"""

from __future__ import annotations

__version__ = "0.1.0"

from typing import Any

from shells.errors import InputError

__all__ = ["__version__", "InputError", "Sphere", "SphericalCap", "EllipsoidalCap", "Disk",
           "make_shape"]

#: imported on first use: ``import shells`` stays light (SciPy alone takes 0.36 s), so the
#: ``shells`` command installs its signal handlers before any heavy import (a Ctrl-C in that
#: time ended in a KeyboardInterrupt traceback)
_GEOMETRY = ("Sphere", "SphericalCap", "EllipsoidalCap", "Disk", "make_shape")


def __getattr__(name: str) -> Any:
    if name in _GEOMETRY:
        from shells import geometry

        return getattr(geometry, name)
    raise AttributeError(f"module 'shells' has no attribute {name!r}")
