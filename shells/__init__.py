"""shells: thin elastic shells with natural curvature in FEniCSx (dolfinx 0.9).

Computes how spherical caps, closed spheres, ellipsoidal caps, disks and any shell of
revolution or surface mesh deform, buckle and snap when a natural (spontaneous) curvature κ is
imposed, following Pezzulla, Stoop, Steranka, Bade and Holmes, "Curvature-Induced
Instabilities of Shells", Phys. Rev. Lett. 120, 048002 (2018).

The public API::

    import shells
    cap = shells.cap(theta_deg=57.3, radius="25 mm")
    shell = shells.Shell(cap, thickness="1 mm", nu=0.5)
    res = shells.critical(shell, direction="up")
    res.kind, res.kappa_R, res.mode_m, res.kappa      # κ in 1/m: the shell has units
    res.to_dataframe(); res.plot("fig.png"); res.save("out/"); shells.load("out/")

Geometries: ``cap``, ``sphere``, ``ellipsoid``, ``disk``, ``torus``, ``meridian``, ``mesh``;
``Shell``; ``bilayer`` (Timoshenko's natural curvature of two layers); analyses:
``critical``, ``branch``, ``postbuckle``, ``knockdown``, ``phase_diagram``, ``snap``,
``sweep``;
``Result``, ``load``; the shape classes ``Sphere``, ``SphericalCap``, ``EllipsoidalCap``,
``Disk`` and ``make_shape``. Names are imported on first use, so ``import shells`` stays
light.
"""

from __future__ import annotations

__version__ = "0.1.0"

from typing import Any

from shells.errors import InputError

#: public name -> the module that defines it (imported on first use: the ``shells`` command
#: installs its signal handlers before any heavy import; docs/design-notes.md, "Start-up
#: imports")
_PUBLIC = {
    **{n: "shells.api.shell" for n in ("Geometry", "Shell", "bilayer", "cap", "disk",
                                       "ellipsoid", "mesh", "meridian", "sphere", "torus")},
    **{n: "shells.api.runs" for n in ("branch", "choose_model", "critical", "knockdown",
                                      "phase_diagram", "postbuckle", "snap", "sweep")},
    "frequencies": "shells.api.runs",
    **{n: "shells.api.results" for n in ("Result", "load")},
    **{n: "shells.geometry" for n in ("Sphere", "SphericalCap", "EllipsoidalCap", "Disk",
                                      "make_shape")},
}

__all__ = ["__version__", "InputError", *sorted(_PUBLIC)]


def __getattr__(name: str) -> Any:
    if name in _PUBLIC:
        import importlib

        return getattr(importlib.import_module(_PUBLIC[name]), name)
    raise AttributeError(f"module 'shells' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))
