"""The geometry layer: shapes of shells, their imperfections, meridian tables, surfaces known
only by a mesh, and natural-curvature fields.

Modules:

* ``shapes``: the analytic shapes (sphere, spherical cap, ellipsoidal cap, disk, torus) and the
  length scales of a run;
* ``imperfections``: spheres with an axisymmetric or harmonic imperfection;
* ``meridian``: any shell of revolution from a table of its meridian;
* ``catalogue``: shapes by name and description, and the reference shape of a mesh;
* ``surface_fit``: a surface known only by its mesh (normal and curvatures fitted at its nodes);
* ``stimulus``: natural-curvature fields (expressions, tables) and their anisotropy.

The shapes are re-exported here: ``from shells.geometry import SphericalCap``.
"""

from shells.geometry.catalogue import SHAPES, make_shape, shape_from_description
from shells.geometry.imperfections import HarmonicImperfectSphere, ImperfectSphere
from shells.geometry.meridian import MeridianTable
from shells.geometry.shapes import Disk, EllipsoidalCap, Shape, Sphere, SphericalCap, Torus

__all__ = ["SHAPES", "Disk", "EllipsoidalCap", "HarmonicImperfectSphere", "ImperfectSphere",
           "MeridianTable", "Shape", "Sphere", "SphericalCap", "Torus", "make_shape",
           "shape_from_description"]
