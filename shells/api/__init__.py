"""The public Python API (API layer, above the analyses; the command line is a thin layer over
the same analyses): shells described with units, the analyses as functions returning result
objects with tables and plots. Re-exported by the package: ``shells.cap``, ``shells.Shell``,
``shells.critical``, ...

Modules: ``shell`` (geometries, ``Shell``, ``bilayer``), ``runs`` (``critical``, ``branch``,
``postbuckle``, ``knockdown``, ``phase_diagram``, ``sweep``), ``results`` (``Result``,
``load``).
"""
