"""The geometry layer: shapes of shells, their imperfections, meridian tables, surfaces known
only by a mesh, and natural-curvature fields.

Modules:

* ``shapes``: the analytic shapes (sphere, spherical cap, ellipsoidal cap, disk, torus), their
  imperfect variants, meridian tables and the shape catalogue;
* ``surface_fit``: a surface known only by its mesh (normal and curvatures fitted at its nodes);
* ``stimulus``: natural-curvature fields (expressions, tables) and their anisotropy.

The shapes are re-exported here: ``from shells.geometry import SphericalCap``.
"""

from shells.geometry.shapes import *  # noqa: F403
from shells.geometry.shapes import __all__  # noqa: F401
