"""Axisymmetric (shell-of-revolution) model: the paper's energy on the meridian, exact for
axisymmetric base states, with the stability of every Fourier mode m from the same energy.

Geometry. The reference meridian (r°(t), z°(t)) of a ``shells.geometry`` shape (Sphere,
SphericalCap, EllipsoidalCap, Disk) is parametrised by its own parameter t (the colatitude of the
sphere/cap, the parametric colatitude of the spheroid, the radius of the disk) on a 1D interval
mesh of [0, t_max]; g(t) = |x°'(t)| converts to arclength, ds = g dt (g = R on a sphere, so the
mesh is uniform/graded in arclength s = R t there). With a free rim the cells are graded towards
it down to ``sqrt(R h) / layer_cells`` in arclength (the boundary layer).

Energy (same normalisation as ``shells.model``, Young's modulus scaled out, per reference area)::

    U = ∫ (1-ν)|a - a°|² + ν tr²(a - a°) + (h²/3) [(1-ν)|b - b̄|² + ν tr²(b - b̄)] dω,
    b̄ = b° + κ a°,   dω = r° g dt dφ,

with a, b in the orthonormal reference frame (e_s, e_φ): a_11 = |x_t|²/g², a_12 = x_t·x_φ/(g r°),
a_22 = |x_φ|²/r°², b_ij likewise with n·x_ij, n = x_t × x_φ / |x_t × x_φ| (outward), so energies,
Ψ3 and the curvature potential agree with the surface model. The density is written once, in
UFL, as a function of the displacement's "jet" at a point (values and t-, φ-derivatives of its
cylindrical components u_r, u_φ, u_z); the rotation of the cylindrical frame is exact.

Kirchhoff-Love C1 continuity: P3 displacements and P2 slope fields p ≈ ∂_t u, the second
derivatives ∂_tt u taken from ∂_t p, tied by a stiff penalty ``penalty`` |p - ∂_t u|² / g². The
constrained subspace is the C1 (Hermite) cubics, so there is no locking: the penalty only
selects it (see benchmarks/axisym_convergence.py for the convergence study).

Base state (axisymmetric): unknowns (u_r, u_z; p_r, p_z). Axis conditions u_r = 0 and p_z = 0 at
each pole; the rigid z-translation is fixed by u_z = 0 at the top pole (a gauge). Residual, Hessian
and dR/dκ are ``ufl.derivative`` of the energy; κ is a ``fem.Constant``.

Stability. Perturbations U(t) cos mφ e_r + V(t) sin mφ e_φ + W(t) cos mφ e_z about the base
state. For an axisymmetric base state the φ-integral of the second-variation density Q equals
π [Q(mφ = 0) + Q(mφ = π/2)] for m ≥ 1 and 2π Q for m = 0, so one UFL form (the second derivative
of the density at base + perturbation, at two phases) with m and the phases as Constants gives
every Hessian H_m: one compilation, no recompiles. The unknowns are (S, D, W) with U = S + D,
V = S - D for m ≥ 1 (U = S, V = D for m = 0), which turns the axis conditions into Dirichlet
conditions on each pole (∂: the slope field): m = 0: S = D = 0, ∂W = 0; m = 1: S = 0, W = 0,
∂S = ∂D = 0; m = 2: S = D = W = 0, ∂S = ∂W = 0; m ≥ 3: all values and slopes zero. A free
rim needs no condition. Rigid motions are exact null vectors of the continuum Hessians and
are removed by value constraints that they violate (restriction to such a hyperplane keeps the
inertia): m = 0: W = 0 at the top pole (z-translation), D = 0 on the widest parallel (rotation
about z); m = 1: D = 0 at the top pole (translation) and W = 0 on the widest parallel (tilt). A
slope constraint at the pole would do for the tilt in principle, but a point has no capacity
for slopes in 2D: it leaves a spurious near-zero eigenvalue. Inertia per m by MUMPS LDLᵀ.

Public API: ``AxisymModel`` (a ``shells.problem.Problem``: the algorithm layer's continuation,
Newton and ``shells.stability.Stability`` run on it; its stability blocks are the modes m),
``ModeForms`` (the H_m forms), ``branch(...)`` (generator of point records with per-m negative
counts) and ``critical(...)`` (first critical point and all critical points up to the first fold).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.formproblem import FormProblem
from shells.geometry import Disk, EllipsoidalCap, Shape, SphericalCap
from shells.problem import ModeInfo

__all__ = ["AxisymParameters", "AxisymModel", "ModeForms", "RunConfig", "branch", "critical",
           "default_settings", "make_meridian_nodes", "sphere_kappa_b_h", "sphere_mode_n"]

#: the mode Hessian's kernel is long (the second variation of the whole density at two phases)
JIT_OPTIONS: dict[str, Any] = {"timeout": 300}


# ------------------------------------------------------------------------------------------------
# parameters and mesh
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AxisymParameters:
    """Material and discretisation parameters of the axisymmetric model.

    Attributes:
        h: thickness (absolute, in the shape's length unit).
        nu: Poisson ratio in (-1, 1/2].
        cells: cells along the whole meridian at the bulk size (uniform for closed shapes).
        layer_cells: cells per boundary-layer width sqrt(R h) at a free rim.
        grading: size ratio of neighbouring cells in the graded zone (> 1).
        penalty: weight of |p - ∂_t u|² / g² tying the slope fields to the derivatives.
        quadrature_degree: quadrature degree of the energy.
        slope_bending: the curvature b from the slope fields alone (x_t ≈ x°_t + p in the
            normal and in ∂_t∂_φ x; the metric always uses ∂_t u); False: from ∂_t u.
    """

    h: float
    nu: float = 0.5
    cells: int = 200
    layer_cells: float = 8.0
    grading: float = 1.1
    penalty: float = 1.0e4
    quadrature_degree: int = 8
    slope_bending: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.h, (int, float)) and math.isfinite(self.h) and self.h > 0):
            raise InputError(f"thickness h must be positive, got {self.h!r}")
        if not (isinstance(self.nu, (int, float)) and -1.0 < self.nu <= 0.5):
            raise InputError(f"Poisson ratio nu must lie in (-1, 0.5], got {self.nu!r}")
        if not (isinstance(self.cells, int) and 4 <= self.cells <= 100000):
            raise InputError(f"cells must be an integer in [4, 100000], got {self.cells!r}")
        if not (math.isfinite(self.layer_cells) and self.layer_cells > 0):
            raise InputError(f"layer_cells must be positive, got {self.layer_cells!r}")
        if not (math.isfinite(self.grading) and 1.0 < self.grading <= 2.0):
            raise InputError(f"grading must lie in (1, 2], got {self.grading!r}")
        if not (math.isfinite(self.penalty) and self.penalty > 0):
            raise InputError(f"penalty must be positive, got {self.penalty!r}")
        if self.quadrature_degree not in range(2, 21):
            raise InputError(f"quadrature_degree must be in [2, 20], got "
                             f"{self.quadrature_degree!r}")


def _supported(shape: Any) -> None:
    if not isinstance(shape, (SphericalCap, EllipsoidalCap, Disk)):
        raise InputError(f"the axisymmetric model needs a sphere, cap, ellipsoid or disk, "
                         f"got {type(shape).__name__}")


def _arclength_table(shape: Shape, n: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """(t, s(t)) on a fine grid: the meridian's arclength from the top pole."""
    t = np.linspace(0.0, shape.t_max, n)
    dr, dz = shape.meridian_derivative(t)
    g = np.hypot(dr, dz)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t))])
    return t, s


def make_meridian_nodes(shape: Shape, h: float, cells: int, layer_cells: float,
                        grading: float) -> np.ndarray:
    """Sorted nodes in t of the meridian mesh.

    Closed shapes: uniform in arclength. A free rim: from the rim inwards, cells of arclength
    ``sqrt(R h) / layer_cells`` growing by ``grading`` up to the bulk size S / cells (S: the
    meridian's length), then uniform; the nodes are mapped back to t through s(t).
    """
    t_tab, s_tab = _arclength_table(shape)
    S = float(s_tab[-1])
    if shape.closed:
        s_nodes = np.linspace(0.0, S, cells + 1)
    else:
        R = shape.R if math.isfinite(shape.R) else shape.characteristic_size()
        ell = math.sqrt(R * h)
        bulk = S / cells
        size = min(ell / layer_cells, bulk)
        sizes, d = [], 0.0
        while d < S:
            sizes.append(size)
            d += size
            size = min(size * grading, bulk)
        sizes = np.array(sizes)
        sizes *= S / sizes.sum()  # fit exactly (the last, bulk-sized cells absorb the change)
        d_from_rim = np.concatenate([[0.0], np.cumsum(sizes)])
        s_nodes = np.sort(S - d_from_rim)
        s_nodes[0], s_nodes[-1] = 0.0, S
    t_nodes = np.interp(s_nodes, s_tab, t_tab)
    t_nodes[0], t_nodes[-1] = 0.0, shape.t_max
    return t_nodes


@dataclass
class MeridianMesh:
    """The 1D mesh of the meridian, on ``comm`` (MPI.COMM_SELF: every rank holds all of it)."""

    shape: Shape
    nodes: np.ndarray
    comm: Any = None
    mesh: Any = field(init=False)

    def __post_init__(self) -> None:
        from dolfinx import mesh as dmesh
        from mpi4py import MPI

        if self.comm is None:
            self.comm = MPI.COMM_SELF
        if self.comm.size != 1:
            raise InputError("the axisymmetric model runs on one process per communicator "
                             "(use MPI.COMM_SELF)")
        n = len(self.nodes) - 1
        self.mesh = dmesh.create_interval(self.comm, n, [0.0, float(self.nodes[-1])])
        self.mesh.topology.create_connectivity(0, 1)
        x = self.mesh.geometry.x
        idx = np.rint(x[:, 0] / float(self.nodes[-1]) * n).astype(int)
        x[:, 0] = self.nodes[idx]


# ------------------------------------------------------------------------------------------------
# the energy density of a displacement jet
# ------------------------------------------------------------------------------------------------
@dataclass
class Jet:
    """Cylindrical components (r, φ, z) of a displacement and its derivatives at a point (UFL).

    ``val``, ``t``, ``ph``, ``tph``, ``phph``: u, ∂_t u, ∂_φ u, ∂_t∂_φ u, ∂_φφ u; ``p``: the slope
    field (≈ ∂_t u) and ``pt`` = ∂_t p, which replaces ∂_tt u (C1 by penalty).
    """

    val: tuple
    t: tuple
    ph: tuple
    tph: tuple
    phph: tuple
    p: tuple
    pt: tuple
    pph: tuple

    def __add__(self, other: Jet) -> Jet:
        return Jet(*(tuple(a + b for a, b in zip(x, y, strict=True)) for x, y in
                     zip(self.fields(), other.fields(), strict=True)))

    def fields(self) -> tuple:
        return (self.val, self.t, self.ph, self.tph, self.phph, self.p, self.pt, self.pph)


def _meridian_ufl(shape: Shape, t: Any) -> tuple:
    """r°, z° and their first and second t-derivatives as UFL expressions of t."""
    import ufl

    if isinstance(shape, Disk):
        return t, 0.0 * t, 1.0 + 0.0 * t, 0.0 * t, 0.0 * t, 0.0 * t
    if isinstance(shape, EllipsoidalCap):
        a, c = shape.radius, shape.r3
    else:
        a = c = shape.radius
    s, co = ufl.sin(t), ufl.cos(t)
    return a * s, c * co, a * co, -c * s, -a * s, -c * co


def _dot(a: tuple, b: tuple) -> Any:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: tuple, b: tuple) -> tuple:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


# ------------------------------------------------------------------------------------------------
# the model
# ------------------------------------------------------------------------------------------------
class AxisymModel(FormProblem):
    """Axisymmetric shell model, a ``shells.problem.Problem``.

    Attributes: ``shape``, ``shell`` (the ``MeridianMesh``; ``shell.comm``), ``W``, ``w`` (state
    (u_r, u_z; p_r, p_z)), ``kappa``, ``h``, ``nu`` (Constants), ``residual``, ``hessian``,
    ``dres_dkappa`` (compiled forms), ``bcs``, ``mass``; methods ``scalars()``, ``num_dofs()``,
    ``energy_density(jet)``. Assembly from ``FormProblem``; the stability blocks are the Fourier
    modes m of ``modes`` (default 0..12), each with its Hessian H_m (``ModeForms``, compiled on
    first use).
    """

    modes: tuple[int, ...] = tuple(range(13))

    def __init__(self, shape: Shape, params: AxisymParameters, comm: Any = None) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        _supported(shape)
        self.shape = shape
        self.params = params
        nodes = make_meridian_nodes(shape, params.h, params.cells, params.layer_cells,
                                    params.grading)
        self.shell = MeridianMesh(shape, nodes, comm)
        mesh = self.shell.mesh
        self.mesh = mesh
        cell = mesh.basix_cell()
        self._P3 = basix.ufl.element("Lagrange", cell, 3, shape=(2,))
        self._P2 = basix.ufl.element("Lagrange", cell, 2, shape=(2,))
        self.W = fem.functionspace(mesh, basix.ufl.mixed_element([self._P3, self._P2]))
        self.w = fem.Function(self.W, name="state")
        self.kappa = fem.Constant(mesh, default_scalar_type(0.0))
        self.h = fem.Constant(mesh, default_scalar_type(params.h))
        self.nu = fem.Constant(mesh, default_scalar_type(params.nu))
        self.pen = fem.Constant(mesh, default_scalar_type(params.penalty))
        self.dx = ufl.Measure("dx", domain=mesh,
                              metadata={"quadrature_degree": params.quadrature_degree})
        self.t = ufl.SpatialCoordinate(mesh)[0]
        (self.r0, self.z0, self.r0t, self.z0t,
         self.r0tt, self.z0tt) = _meridian_ufl(shape, self.t)
        self.g = ufl.sqrt(self.r0t**2 + self.z0t**2)
        self.area_density = 2 * math.pi * self.r0 * self.g  # dω = area_density dt
        self._build_forms()
        self.bcs = self._axis_conditions()
        self._degree_forms: dict[Any, tuple] = {}

    # -- kinematics ------------------------------------------------------------------------------
    def base_jet(self, w: Any) -> Jet:
        import ufl

        u, p = ufl.split(w)
        z = 0.0 * self.t
        return Jet(val=(u[0], z, u[1]), t=(u[0].dx(0), z, u[1].dx(0)), ph=(z, z, z),
                   tph=(z, z, z), phph=(z, z, z), p=(p[0], z, p[1]),
                   pt=(p[0].dx(0), z, p[1].dx(0)), pph=(z, z, z))

    def zero_jet(self) -> Jet:
        z = (0.0 * self.t,) * 3
        return Jet(z, z, z, z, z, z, z, z)

    def strains(self, j: Jet) -> dict[str, Any]:
        """a - a°, b - b° (orthonormal reference frame, components 11, 12, 22) of a jet."""
        r0, g = self.r0, self.g

        def geo(j: Jet) -> tuple:
            ur, uph, uz = j.val
            xt = (self.r0t + j.t[0], j.t[1], self.z0t + j.t[2])
            xph = (j.ph[0] - uph, r0 + ur + j.ph[1], j.ph[2])
            xtt = (self.r0tt + j.pt[0], j.pt[1], self.z0tt + j.pt[2])
            xphph = (j.phph[0] - 2 * j.ph[1] - r0 - ur, j.phph[1] + 2 * j.ph[0] - uph, j.phph[2])
            if self.params.slope_bending:  # bending from the slope fields: x_t ≈ x°_t + p
                xtb = (self.r0t + j.p[0], j.p[1], self.z0t + j.p[2])
                xtph = (j.pph[0] - j.p[1], j.pph[1] + self.r0t + j.p[0], j.pph[2])
            else:
                xtb = xt
                xtph = (j.tph[0] - j.t[1], j.tph[1] + self.r0t + j.t[0], j.tph[2])
            import ufl

            c = _cross(xtb, xph)
            nn = ufl.sqrt(_dot(c, c))
            n = tuple(ci / nn for ci in c)
            a = (_dot(xt, xt) / g**2, _dot(xt, xph) / (g * r0), _dot(xph, xph) / r0**2)
            b = (_dot(n, xtt) / g**2, _dot(n, xtph) / (g * r0), _dot(n, xphph) / r0**2)
            return a, b

        a, b = geo(j)
        a0, b0 = geo(self.zero_jet())
        return {"a": tuple(x - y for x, y in zip(a, a0, strict=True)),
                "b": tuple(x - y for x, y in zip(b, b0, strict=True)),
                "slope_gap": tuple(pi - ti for pi, ti in zip(j.p, j.t, strict=True))}

    def _quad(self, A: tuple) -> Any:
        """(1-ν)|A|² + ν tr²A of a symmetric 2x2 tensor given as (A11, A12, A22)."""
        return ((1 - self.nu) * (A[0] ** 2 + 2 * A[1] ** 2 + A[2] ** 2)
                + self.nu * (A[0] + A[2]) ** 2)

    def energy_density(self, j: Jet) -> dict[str, Any]:
        """Energy densities per reference area dω of a jet (``total`` is minimised)."""
        e = self.strains(j)
        Ea, Eb = e["a"], e["b"]
        gap = (Eb[0] - self.kappa, Eb[1], Eb[2] - self.kappa)  # b - b̄
        stretch = self._quad(Ea)
        bend_nat = self.h**2 / 3 * self._quad(gap)
        pen = self.pen * _dot(e["slope_gap"], e["slope_gap"]) / self.g**2
        return {"total": stretch + bend_nat + pen, "stretching": stretch,
                "bending": self.h**2 / 3 * self._quad(Eb),
                "curvature_potential": -2 * (1 + self.nu) / 3 * self.h**2 * self.kappa
                * (Eb[0] + Eb[2]),
                "penalty": pen}

    # -- forms -----------------------------------------------------------------------------------
    def _build_forms(self) -> None:
        import ufl
        from dolfinx import fem

        dens = self.energy_density(self.base_jet(self.w))
        dw, w_ = ufl.TestFunction(self.W), ufl.TrialFunction(self.W)
        self.energy_ufl = dens["total"] * self.area_density * self.dx
        self.residual_ufl = ufl.derivative(self.energy_ufl, self.w, dw)
        self.hessian_ufl = ufl.derivative(self.residual_ufl, self.w, w_)
        # the residual is affine in κ: R(κ=1) - R(κ=0) is dR/dκ exactly
        self.dres_dkappa_ufl = (ufl.replace(self.residual_ufl, {self.kappa: ufl.as_ufl(1.0)})
                                - ufl.replace(self.residual_ufl, {self.kappa: ufl.as_ufl(0.0)}))
        self.residual = fem.form(self.residual_ufl)
        self.hessian = fem.form(self.hessian_ufl)
        self.dres_dkappa = fem.form(self.dres_dkappa_ufl)
        self.mass = fem.form(ufl.inner(w_, dw) * self.area_density * self.dx)
        u, _ = ufl.split(self.w)
        n0r, n0z = -self.z0t / self.g, self.r0t / self.g
        ad = self.area_density
        sf = {k: v * ad * self.dx for k, v in dens.items()}
        sf["psi3_integral"] = (u[0] * n0r + u[1] * n0z) * ad * self.dx
        sf["uz_integral"] = u[1] * ad * self.dx
        sf["nz_integral"] = n0z * ad * self.dx
        sf["area"] = ad * self.dx
        self._scalar_forms = {k: fem.form(v) for k, v in sf.items()}

    def _axis_conditions(self) -> list[Any]:
        """u_r = 0 and p_z = 0 on the axis (each pole); u_z = 0 at the top pole (gauge)."""
        W = self.W
        ur, uz, pz = W.sub(0).sub(0), W.sub(0).sub(1), W.sub(1).sub(1)
        poles = self.axis_vertices()
        top = self.vertices_at(0.0)
        return (_dirichlet(ur, poles) + _dirichlet(pz, poles) + _dirichlet(uz, top))

    def axis_vertices(self) -> np.ndarray:
        pts = [0.0] + ([self.shape.t_max] if self.shape.closed else [])
        return np.concatenate([self.vertices_at(t) for t in pts])

    def widest_vertex(self) -> np.ndarray:
        """The vertex of largest r° (rim of a cap up to a hemisphere, else the equator)."""
        x = self.mesh.geometry.x[:, 0]
        r0 = self.shape.meridian(x)[0]
        return self.vertices_at(float(x[np.argmax(r0)]))

    def vertices_at(self, t: float) -> np.ndarray:
        from dolfinx import mesh as dmesh

        tol = 1e-10 * max(1.0, self.shape.t_max)
        return dmesh.locate_entities(self.mesh, 0, lambda x: np.abs(x[0] - t) < tol)

    # -- scalars ---------------------------------------------------------------------------------
    def assemble(self, name: str) -> float:
        from dolfinx import fem

        return float(fem.assemble_scalar(self._scalar_forms[name]))

    def scalars(self) -> dict[str, float]:
        """Energy split, Ψ3/h (mean normal displacement, translation-free), apex u_z/h, and the
        pole's normal displacement Ψ3(pole)/h = (u_z(pole) - ū_z)/h (ū: the mean displacement,
        i.e. relative to the centroid's translation)."""
        out = {k: self.assemble(k) for k in ("total", "stretching", "bending",
                                             "curvature_potential", "penalty")}
        out["energy"] = out.pop("total")
        area = self.assemble("area")
        psi3 = (self.assemble("psi3_integral") / area
                - self.assemble("uz_integral") * self.assemble("nz_integral") / area**2)
        h = float(self.h.value)
        out["psi3_over_h"] = psi3 / h
        uz = self.uz_at(np.array([0.0, self.shape.t_max]))
        disp = 0.5 * (uz[0] - uz[1]) if self.shape.closed else uz[0] - uz[1]
        out["apex_uz_over_h"] = float(disp) / h
        out["psi3_pole_over_h"] = float(uz[0] - self.assemble("uz_integral") / area) / h
        return out

    def meridian_profile(self) -> dict[str, np.ndarray]:
        """The state on the meridian at the mesh vertices, pole to pole/rim: reference t, r°,
        z° and displacement u_r, u_z (the mean u_z removed: no rigid translation)."""
        Vu, dofs = self.W.sub(0).collapse()
        t = Vu.tabulate_dof_coordinates()[:, 0]
        u = self.w.x.array[np.asarray(dofs)].reshape(-1, 2)
        verts = np.unique(self.mesh.geometry.x[:, 0])
        idx = np.array([int(np.argmin(np.abs(t - tv))) for tv in verts])
        r0, z0 = self.shape.meridian(verts)
        area = self.assemble("area")
        uz = u[idx, 1] - self.assemble("uz_integral") / area
        return {"t": verts, "r0": np.asarray(r0), "z0": np.asarray(z0), "ur": u[idx, 0],
                "uz": uz}

    def uz_at(self, t: np.ndarray) -> np.ndarray:
        """u_z at mesh nodes t (values of the P3 field at vertices)."""
        Vz, dofs = self.W.sub(0).sub(1).collapse()
        x = Vz.tabulate_dof_coordinates()[:, 0]
        vals = self.w.x.array[dofs]
        return np.array([vals[np.argmin(np.abs(x - ti))] for ti in np.atleast_1d(t)])

    def num_dofs(self) -> int:
        im = self.W.dofmap.index_map
        return int(im.size_global * self.W.dofmap.index_map_bs)

    # -- stability blocks: the Fourier modes m (shells.problem.Problem) ---------------------------
    @property
    def mode_forms(self) -> ModeForms:
        if not hasattr(self, "_mode_forms"):
            self._mode_forms = ModeForms(self)
        return self._mode_forms

    # Block None is the Jacobian itself: the Hessian of the axisymmetric unknowns, i.e. H_0
    # without the torsion D (the stability within rotational symmetry: folds and axisymmetric
    # bifurcations, the block branch switching on the 1D model uses).
    def stability_blocks(self) -> tuple[int, ...]:
        return tuple(self.modes)

    def block_layout(self, block: Any) -> str:
        return "axisymmetric" if block is None else "modes"  # one form for every m

    def create_hessian(self, block: Any) -> Any:
        if block is None:
            return self.create_jacobian()
        from dolfinx.fem.petsc import create_matrix

        return create_matrix(self.mode_forms.form)

    def assemble_hessian(self, block: Any, H: Any) -> None:
        if block is None:
            self._assemble_symmetric(H, self.hessian, self.bcs)
            return
        bcs = self.mode_forms.set_mode(block)
        self._assemble_symmetric(H, self.mode_forms.form, bcs)

    def assemble_mass(self, block: Any) -> Any:
        if block is None:
            return self._assemble_mass(self.mass, self.bcs)
        return self._assemble_mass(self.mode_forms.mass, self.mode_forms.conditions(block))

    def classify_mode(self, vec: Any, block: Any) -> ModeInfo:
        """m = the block's wavenumber (0 for the Jacobian); on a closed sphere also the degree
        n of the mode from the Rayleigh quotient R² ∫ |∇w|² / ∫ w² = n(n+1) of its normal
        component w, |∇w|² = (∂_s w)² + m² w² / r² (exact for the spherical harmonic Y_n^m)."""
        m = 0 if block is None else int(block)
        if not _is_sphere(self.shape):
            return ModeInfo(m=m, n=None)
        if block is None:
            key, space, ur_uz = None, self.W, self._radial_axial
        else:
            mf = self.mode_forms
            mf.set_mode(m)
            key, space, ur_uz = "mode", mf.V, mf.radial_axial
        if key not in self._degree_forms:
            self._degree_forms[key] = self._degree_form(space, ur_uz, block is not None)
        f, shift, m_c, forms = self._degree_forms[key]
        m_c.value = float(m)
        vec.copy(f.x.petsc_vec)
        f.x.scatter_forward()
        from dolfinx import fem

        g2, w2, uz, area = forms
        # the gauge u_z(pole) = 0 adds a translation (degree 1) to every axisymmetric mode:
        # removed (m ≥ 1 modes vanish on the axis and have no such gauge)
        shift.value = (float(fem.assemble_scalar(uz)) / float(fem.assemble_scalar(area))
                       if m == 0 else 0.0)
        x = (float(fem.assemble_scalar(g2)) / max(float(fem.assemble_scalar(w2)), 1e-300)
             * self.shape.R ** 2)
        n = int(round((-1 + math.sqrt(1 + 4 * max(x, 0.0))) / 2))
        return ModeInfo(m=m, n=n, rayleigh={"x": x})

    @staticmethod
    def _radial_axial(f: Any) -> tuple[Any, Any]:
        import ufl

        u, _ = ufl.split(f)
        return u[0], u[1]

    def _degree_form(self, space: Any, ur_uz: Any, fourier: bool) -> tuple:
        """(function, shift, m, forms) of the Rayleigh quotient of a mode in ``space``."""
        from dolfinx import default_scalar_type, fem

        f = fem.Function(space)
        shift = fem.Constant(self.mesh, default_scalar_type(0.0))
        m_c = fem.Constant(self.mesh, default_scalar_type(0.0))
        ur, uz = ur_uz(f)
        uz_s = uz - shift
        wn = (ur * (-self.z0t) + uz_s * self.r0t) / self.g
        grad2 = (wn.dx(0) / self.g) ** 2
        if fourier:
            grad2 = grad2 + (m_c * wn / self.r0) ** 2
        ad = self.area_density
        forms = (fem.form(grad2 * ad * self.dx), fem.form(wn * wn * ad * self.dx),
                 fem.form(uz * ad * self.dx), fem.form(ad * self.dx))
        return f, shift, m_c, forms


def _dirichlet(V: Any, vertices: np.ndarray) -> list[Any]:
    from dolfinx import default_scalar_type, fem

    if len(vertices) == 0:
        return []
    dofs = fem.locate_dofs_topological(V, 0, vertices)
    return [fem.dirichletbc(default_scalar_type(0.0), dofs, V)]


# ------------------------------------------------------------------------------------------------
# stability against Fourier modes
# ------------------------------------------------------------------------------------------------
class ModeForms:
    """The Fourier-mode Hessians H_m of the energy about the model's (axisymmetric) state.

    Unknowns (S, D, W; P_S, P_D, P_W) in P3³ x P2³: U = S + D, V = S - D for m ≥ 1 and U = S,
    V = D for m = 0 (see the module docstring for the axis conditions). One compiled form for
    every m: m and the phases are Constants (``set_mode``).
    """

    def __init__(self, model: AxisymModel) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        self.model = model
        mesh = model.mesh
        cell = mesh.basix_cell()
        P3 = basix.ufl.element("Lagrange", cell, 3, shape=(3,))
        P2 = basix.ufl.element("Lagrange", cell, 2, shape=(3,))
        self.V = fem.functionspace(mesh, basix.ufl.mixed_element([P3, P2]))
        self.pert = fem.Function(self.V)  # stays zero: the Hessian is taken at the base state
        c = {k: fem.Constant(mesh, default_scalar_type(0.0))
             for k in ("m", "a0", "b0", "a1", "b1", "cSU", "cDU", "cSV", "cDV")}
        self.c = c
        q, Pq = ufl.split(self.pert)
        S, D, W = q[0], q[1], q[2]
        PS, PD, PW = Pq[0], Pq[1], Pq[2]
        U, V = c["cSU"] * S + c["cDU"] * D, c["cSV"] * S + c["cDV"] * D
        PU, PV = c["cSU"] * PS + c["cDU"] * PD, c["cSV"] * PS + c["cDV"] * PD
        m = c["m"]

        def jet(a: Any, b: Any) -> Jet:
            d = lambda f: f.dx(0)  # noqa: E731
            return Jet(val=(U * a, V * b, W * a), t=(d(U) * a, d(V) * b, d(W) * a),
                       ph=(-m * U * b, m * V * a, -m * W * b),
                       tph=(-m * d(U) * b, m * d(V) * a, -m * d(W) * b),
                       phph=(-m**2 * U * a, -m**2 * V * b, -m**2 * W * a),
                       p=(PU * a, PV * b, PW * a), pt=(d(PU) * a, d(PV) * b, d(PW) * a),
                       pph=(-m * PU * b, m * PV * a, -m * PW * b))

        base = model.base_jet(model.w)
        dens = (model.energy_density(base + jet(c["a0"], c["b0"]))["total"]
                + model.energy_density(base + jet(c["a1"], c["b1"]))["total"])
        energy = math.pi * dens * model.r0 * model.g * model.dx
        v, v_ = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        self.hessian_ufl = ufl.derivative(ufl.derivative(energy, self.pert, v), self.pert, v_)
        self.form = fem.form(self.hessian_ufl, jit_options=JIT_OPTIONS)
        self.mass = fem.form(ufl.inner(v_, v) * model.r0 * model.g * model.dx)
        self._bcs = {k: self._conditions(k) for k in (0, 1, 2, 3)}

    def radial_axial(self, f: Any) -> tuple[Any, Any]:
        """(u_r, u_z) amplitudes of a mode ``f`` in ``V`` (U and W; phases as last set)."""
        import ufl

        q, _ = ufl.split(f)
        return self.c["cSU"] * q[0] + self.c["cDU"] * q[1], q[2]

    def _conditions(self, mclass: int) -> list[Any]:
        V, model = self.V, self.model
        S, D, W = V.sub(0).sub(0), V.sub(0).sub(1), V.sub(0).sub(2)
        PS, PD, PW = V.sub(1).sub(0), V.sub(1).sub(1), V.sub(1).sub(2)
        poles, top = model.axis_vertices(), model.vertices_at(0.0)
        widest = model.widest_vertex()
        if mclass == 0:
            pairs = [(S, poles), (D, poles), (PW, poles), (W, top), (D, widest)]
        elif mclass == 1:
            pairs = [(S, poles), (PS, poles), (PD, poles), (W, poles), (D, top), (W, widest)]
        elif mclass == 2:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PW, poles)]
        else:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PD, poles), (PW, poles)]
        return [bc for sub, verts in pairs for bc in _dirichlet(sub, verts)]

    def conditions(self, m: int) -> list[Any]:
        """The Dirichlet conditions of mode m (axis conditions and rigid-motion gauges)."""
        return self._bcs[min(int(m), 3)]

    def set_mode(self, m: int) -> list[Any]:
        """Set the Constants of mode m; returns its Dirichlet conditions."""
        if not (isinstance(m, (int, np.integer)) and m >= 0):
            raise InputError(f"the azimuthal wavenumber m must be a non-negative integer, "
                             f"got {m!r}")
        c = self.c
        c["m"].value = float(m)
        if m == 0:
            vals = dict(a0=1.0, b0=1.0, a1=1.0, b1=1.0, cSU=1.0, cDU=0.0, cSV=0.0, cDV=1.0)
        else:
            vals = dict(a0=1.0, b0=0.0, a1=0.0, b1=1.0, cSU=1.0, cDU=1.0, cSV=1.0, cDV=-1.0)
        for k, v in vals.items():
            c[k].value = v
        return self.conditions(m)


# ------------------------------------------------------------------------------------------------
# asymptotics of the closed sphere (paper, supplement): for defaults and tests
# ------------------------------------------------------------------------------------------------
def sphere_kappa_b_h(nu: float) -> float:
    """κ_b h = 4 sqrt(3 (1-ν) / ((1+ν)(5+4ν))) (thin-shell limit)."""
    return 4.0 * math.sqrt(3.0 * (1.0 - nu) / ((1.0 + nu) * (5.0 + 4.0 * nu)))


def sphere_mode_n(h_over_r: float, nu: float) -> float:
    """The real n with n(n+1) = 2/(1+2ν) (R/h) sqrt(3 (5+4ν)(1-ν²))."""
    x = 2.0 / (1.0 + 2.0 * nu) / h_over_r * math.sqrt(3.0 * (5.0 + 4.0 * nu) * (1.0 - nu**2))
    return 0.5 * (math.sqrt(1.0 + 4.0 * x) - 1.0)


# ------------------------------------------------------------------------------------------------
# numerics of a run
# ------------------------------------------------------------------------------------------------
SNES_OPTIONS: dict[str, Any] = {"snes_rtol": 1.0e-9, "snes_atol": 1.0e-12, "snes_stol": 1.0e-10,
                                "snes_max_it": 25}


def _is_sphere(shape: Shape) -> bool:
    return isinstance(shape, SphericalCap) and shape.closed


def default_cells(shape: Shape, h_over_r: float) -> int:
    """Bulk cells: 200, and at least 5 per degree of the sphere's critical mode."""
    if _is_sphere(shape):
        return max(200, int(math.ceil(5 * sphere_mode_n(h_over_r, 0.0))))
    return 200


def default_settings(shape: Shape, h_over_r: float, **overrides: Any) -> Any:
    """Continuation settings scaled to the problem: on a closed shell κ scales with 1/h."""
    from shells.continuation import ContinuationSettings

    scale = 1.0 / h_over_r if shape.closed else 1.0  # in λ = κ L
    base = dict(method="arclength", ds=0.5 * scale if shape.closed else 0.05,
                ds_max=1.0 * scale if shape.closed else 0.2, ds_min=1e-7 * scale,
                target_newton_its=4, max_newton_its=12, newton_tol=1e-8)
    base.update(overrides)
    return ContinuationSettings(**base)


def _check_common(shape: Any, h_over_r: Any, nu: Any) -> None:
    if not isinstance(shape, Shape):
        raise InputError(f"shape must be a shells.geometry shape, got {shape!r}")
    _supported(shape)
    if not (isinstance(h_over_r, (int, float)) and math.isfinite(h_over_r)
            and 0 < h_over_r < 1):
        raise InputError(f"h/R must lie in (0, 1), got {h_over_r!r}")
    if not (isinstance(nu, (int, float)) and -1.0 < nu <= 0.5):
        raise InputError(f"nu must lie in (-1, 0.5], got {nu!r}")


def _length(shape: Shape) -> float:
    """The length of κR: the pole radius R, the disk's radius."""
    return shape.R if math.isfinite(shape.R) else shape.characteristic_size()


# ------------------------------------------------------------------------------------------------
# the branch with per-m stability, and critical points
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunConfig:
    """One axisymmetric run (validated).

    Attributes:
        shape: a Sphere, SphericalCap, EllipsoidalCap or Disk.
        h_over_r: thickness over the shape's length scale L (``characteristic_size``).
        nu: Poisson ratio.
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: Fourier modes 0..m_max are checked at every point.
        kappa_max: end of the range, |κ| R (R: pole radius; the disk's radius).
        cells, layer_cells, grading, penalty: discretisation (``AxisymParameters``).
        rel_tol: location accuracy of critical points, relative in κ.
        max_critical: stop after this many critical points (None: up to the first fold or the
            end of range).
        settings: continuation settings (None: ``default_settings``).
    """

    shape: Shape
    h_over_r: float
    nu: float = 0.5
    direction: str = "up"
    m_max: int | None = None
    kappa_max: float | None = None
    cells: int | None = None
    layer_cells: float = 8.0
    grading: float = 1.1
    penalty: float = 1.0e4
    rel_tol: float = 1.0e-4
    max_critical: int | None = None
    settings: Any = None

    def __post_init__(self) -> None:
        _check_common(self.shape, self.h_over_r, self.nu)
        if self.direction not in ("up", "down"):
            raise InputError(f"direction must be 'up' or 'down', got {self.direction!r}")
        if self.m_max is not None and not (isinstance(self.m_max, (int, np.integer))
                                           and 0 <= self.m_max <= 2000):
            raise InputError(f"m_max must be an integer in [0, 2000], got {self.m_max!r}")
        if self.kappa_max is not None and not (isinstance(self.kappa_max, (int, float))
                                               and math.isfinite(self.kappa_max)
                                               and self.kappa_max > 0):
            raise InputError(f"kappa_max must be a positive number (|kappa| R at the end of "
                             f"the range), got {self.kappa_max!r}")
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol!r}")
        if self.max_critical is not None and not (isinstance(self.max_critical, int)
                                                  and self.max_critical >= 1):
            raise InputError(f"max_critical must be a positive integer, got {self.max_critical!r}")
        AxisymParameters(h=self.h, nu=self.nu, cells=self.n_cells, layer_cells=self.layer_cells,
                         grading=self.grading, penalty=self.penalty)

    @property
    def L(self) -> float:  # noqa: N802
        return self.shape.characteristic_size()

    @property
    def h(self) -> float:
        return self.h_over_r * self.L

    @property
    def R(self) -> float:  # noqa: N802
        return _length(self.shape)

    @property
    def n_cells(self) -> int:
        return self.cells if self.cells is not None else default_cells(self.shape, self.h_over_r)

    @property
    def modes(self) -> list[int]:
        if self.m_max is not None:
            return list(range(self.m_max + 1))
        if _is_sphere(self.shape):
            return list(range(int(math.ceil(1.3 * sphere_mode_n(self.h_over_r, self.nu))) + 5))
        return list(range(13))

    @property
    def kappa_end(self) -> float:
        """Signed κ at the end of the range."""
        if self.kappa_max is not None:
            mag = self.kappa_max / self.R
        elif _is_sphere(self.shape):
            mag = 1.25 * sphere_kappa_b_h(self.nu) / self.h
        else:
            tb = getattr(self.shape, "theta", 1.0) / math.sqrt(self.h_over_r)
            mag = (2.0 * tb + 6.0) / self.R
        return mag if self.direction == "up" else -mag

    def params(self) -> AxisymParameters:
        return AxisymParameters(h=self.h, nu=self.nu, cells=self.n_cells,
                                layer_cells=self.layer_cells, grading=self.grading,
                                penalty=self.penalty)


@dataclass
class _Run:
    """The model and Newton solver of a run."""

    cfg: RunConfig
    model: AxisymModel = field(init=False)

    def __post_init__(self) -> None:
        from shells.solvers import NewtonSolver

        self.model = AxisymModel(self.cfg.shape, self.cfg.params())
        self.model.modes = tuple(self.cfg.modes)
        self.ns = NewtonSolver(self.model, options=SNES_OPTIONS)
        # the residual bound is the continuation's own (relative to the κ-load, plus the
        # round-off floor of the penalty-stiff Jacobian): no model-specific tolerance here
        self.settings = self.cfg.settings or default_settings(self.cfg.shape, self.cfg.h_over_r)

    def follow(self, crit: Any = None, locate_points: bool = True) -> Iterator[tuple]:
        """``critical.follow`` over the run's range with the inertia of every H_m."""
        from shells.critical import follow

        return follow(self.model, self.settings, self.cfg.kappa_end, crit, solver=self.ns,
                      blocks=self.model.modes, locate_points=locate_points)

    def record(self, p: Any, counts: dict[int, int]) -> dict[str, Any]:
        d = p.as_dict()
        d["kappa_R"] = p.kappa * self.cfg.R
        d["kappa_h"] = p.kappa * self.cfg.h
        d["negative_counts"] = [counts[m] for m in sorted(counts)]
        d["unstable_modes"] = [m for m in sorted(counts) if counts[m] > 0]
        return d

    def destroy(self) -> None:
        self.ns.destroy()


def branch(shape: Shape, h_over_r: float, nu: float = 0.5, direction: str = "up",
           m_max: int | None = None, kappa_max: float | None = None,
           **numerics: Any) -> Iterator[dict[str, Any]]:
    """Follow the axisymmetric branch from κ = 0 and check modes m = 0..m_max at every point.

    Args:
        shape: a ``shells.geometry`` Sphere, SphericalCap, EllipsoidalCap or Disk.
        h_over_r: thickness over the shape's length scale (``characteristic_size``).
        nu: Poisson ratio in (-1, 1/2].
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: highest Fourier mode checked (default: 12; spheres: 1.3 n + 4).
        kappa_max: end of the range, |κ| R (default: spheres 1.25 κ_b; caps 2 θ̄ + 6).
        **numerics: ``cells``, ``layer_cells``, ``grading``, ``penalty``, ``settings``
            (a ``ContinuationSettings``), see ``RunConfig``.

    Yields:
        One dict per converged point: ``kappa_R``, ``kappa_h``, ``kappa``, ``psi3_over_h`` (mean
        normal displacement over h; the sphere's change of radius), ``apex_uz_over_h``,
        ``energy`` and its split, ``newton_its``, ``dkappa_ds`` (κ-component of the unit
        tangent: its sign change marks a fold), ``negative_counts`` (list indexed by m) and
        ``unstable_modes`` (the m with a negative eigenvalue).

    Raises:
        InputError: bad parameters.
    """
    cfg = RunConfig(shape=shape, h_over_r=h_over_r, nu=nu, direction=direction, m_max=m_max,
                    kappa_max=kappa_max, **_numerics(numerics, ("rel_tol", "max_critical")))
    run = _Run(cfg)
    try:
        for p, res, _ in run.follow(locate_points=False):
            yield run.record(p, res.counts)
    finally:
        run.destroy()


def _numerics(numerics: dict[str, Any], extra: tuple[str, ...] = ()) -> dict[str, Any]:
    allowed = {"cells", "layer_cells", "grading", "penalty", "settings", "rel_tol",
               "max_critical"} - set(extra)
    bad = set(numerics) - allowed
    if bad:
        raise InputError(f"unknown numerics option(s): {', '.join(sorted(bad))} "
                         f"(allowed: {', '.join(sorted(allowed))})")
    return numerics


def critical(shape: Shape, h_over_r: float, nu: float = 0.5, direction: str = "up",
             m_max: int | None = None, kappa_max: float | None = None,
             **numerics: Any) -> dict[str, Any]:
    """Critical points of the axisymmetric branch from κ = 0 (the first one, and all of them up
    to and including the first fold or the end of the range).

    At every branch point the inertia of H_m (m = 0..m_max) is computed; a change of a negative
    count, or a sign change of dκ/ds, between two points is located by bisection along the
    branch (chord-parametrised arclength) to |Δκ|/|κ| < ``rel_tol`` (default 1e-4). Kinds:
    "fold" (dκ/ds changes sign; its mode is m = 0) and "bifurcation" (m ≥ 1, or m = 0 without a
    fold). ``mode_m`` is the lowest m whose count changes at the point; for a closed sphere
    ``mode_n`` is the largest m unstable just past it (the degree: all m ≤ n of Y_n^m share the
    critical value).

    Args:
        shape: Sphere, SphericalCap, EllipsoidalCap or Disk (``shells.geometry``).
        h_over_r: thickness over the shape's length scale (``characteristic_size``).
        nu: Poisson ratio in (-1, 1/2].
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: highest Fourier mode checked (default 12; spheres 1.3 n + 4).
        kappa_max: end of the range in |κ| R (default: spheres 1.25 κ_b, caps 2 θ̄ + 6).
        **numerics: ``cells``, ``layer_cells``, ``grading``, ``penalty``, ``rel_tol``,
            ``settings`` (``ContinuationSettings``), ``max_critical`` (stop after this many
            critical points; default 1 for closed spheres, whose perfect-sphere branch beyond
            the first multiplet is of no interest, else unlimited).

    Returns:
        {"kind": "fold" | "bifurcation" | "none", "kappa_R", "kappa_h", "mode_m", "mode_n",
        "h_over_R", "nu", "theta_deg", "model": "axisym", "dofs", "critical_points": [{"kind",
        "kappa_R", "kappa_h", "mode_m", "mode_n"}, ...]}; the top-level values describe the
        first critical point (None if there is none); ``theta_deg`` is None for a sphere or a
        disk, ``mode_n`` None for non-spheres; ``dofs`` counts the base-state unknowns.

    Raises:
        InputError: bad parameters.
    """
    numerics = dict(_numerics(numerics))
    if isinstance(shape, Shape) and _is_sphere(shape):
        numerics.setdefault("max_critical", 1)
    cfg = RunConfig(shape=shape, h_over_r=h_over_r, nu=nu, direction=direction, m_max=m_max,
                    kappa_max=kappa_max, **numerics)
    from shells.critical import CriticalSettings

    run = _Run(cfg)
    L = run.model.shape.characteristic_size()
    # a closed sphere's axisymmetric modes of neighbouring degrees bifurcate within 1e-4 in κ:
    # there the locator's corrector omits dominant components along the Jacobian's four
    # eigenvectors nearest 0 (else it lands on a branch bifurcating close by). Elsewhere it
    # must not: on a thin disk the soft axisymmetric bending modes are among them, and their
    # components are the corrections Newton needs (measured: with it the h/R = 0.02 disk's
    # m = 2 bifurcation came out 1.3e-3 low, at a state off the branch)
    crit = CriticalSettings(rel_tol=cfg.rel_tol, stop_at_fold=True,
                            max_critical=cfg.max_critical,
                            deflate=0)
    found: list[Any] = []
    last = None
    try:
        for p, _, cps in run.follow(crit):
            last = p
            found.extend(cps)
        stop = bool(found) and (found[-1].kind == "fold" or (
            cfg.max_critical is not None and len(found) >= cfg.max_critical))
        lam_end = cfg.kappa_end * L
        if not stop and (last is None or abs(last.kappa_L - lam_end) > 1e-9 * abs(lam_end)):
            # the continuation gave up (step below ds_min, or max_steps) short of the end:
            # the critical points beyond are unknown, "none" would be a false claim
            reached = None if last is None else last.kappa * cfg.R
            raise RuntimeError(f"the axisymmetric continuation stopped at kappa R = {reached} "
                               f"before the end of the range, kappa R = "
                               f"{cfg.kappa_end * cfg.R:.6g}; critical points beyond it are "
                               "not known")
        dofs = run.model.num_dofs()
    finally:
        run.destroy()
    R, h = cfg.R, cfg.h
    pts = [{"kind": c.kind, "kappa_R": c.kappa * R, "kappa_h": c.kappa * h,
            "mode_m": 0 if c.kind == "fold" else c.mode_m,
            "mode_n": c.mode_n if c.kind != "fold" else None,
            "kappa_R_bracket": [c.kappa_lo * R, c.kappa_hi * R], "accuracy": c.accuracy}
           for c in found]
    first = pts[0] if pts else {"kind": "none", "kappa_R": None, "kappa_h": None,
                                "mode_m": None, "mode_n": None}
    theta = getattr(cfg.shape, "theta", None)
    return {"kind": first["kind"], "kappa_R": first["kappa_R"], "kappa_h": first["kappa_h"],
            "mode_m": first["mode_m"], "mode_n": first["mode_n"], "h_over_R": cfg.h_over_r,
            "nu": cfg.nu, "theta_deg": (None if theta is None or _is_sphere(cfg.shape)
                                        else math.degrees(theta)),
            "model": "axisym", "dofs": dofs, "critical_points": pts}
