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
        n of an axisymmetric mode from the Rayleigh quotient R² ∫(∂_s w)² / ∫ w² = n(n+1) of
        its normal component w (exact for the Legendre polynomial P_n)."""
        if block is not None or not _is_sphere(self.shape):
            return ModeInfo(m=0 if block is None else int(block), n=None)
        from dolfinx import fem

        if not hasattr(self, "_degree_forms"):
            import ufl
            from dolfinx import default_scalar_type

            self._mode_w = fem.Function(self.W)
            self._mode_shift = fem.Constant(self.mesh, default_scalar_type(0.0))
            u, _ = ufl.split(self._mode_w)
            # the gauge u_z(pole) = 0 adds a translation (degree 1) to every mode: removed
            uz = u[1] - self._mode_shift
            wn = (u[0] * (-self.z0t) + uz * self.r0t) / self.g
            ad = self.area_density
            self._degree_forms = (fem.form((wn.dx(0) / self.g) ** 2 * ad * self.dx),
                                  fem.form(wn * wn * ad * self.dx),
                                  fem.form(u[1] * ad * self.dx), fem.form(ad * self.dx))
        vec.copy(self._mode_w.x.petsc_vec)
        self._mode_w.x.scatter_forward()
        f_g2, f_w2, f_uz, f_area = self._degree_forms
        self._mode_shift.value = float(fem.assemble_scalar(f_uz)) / float(
            fem.assemble_scalar(f_area))
        g2, w2 = (float(fem.assemble_scalar(f)) for f in (f_g2, f_w2))
        x = g2 / max(w2, 1e-300) * self.shape.R ** 2
        n = int(round((-1 + math.sqrt(1 + 4 * max(x, 0.0))) / 2))
        return ModeInfo(m=0, n=n, rayleigh={"x": x})


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
# points on the branch between two computed points (chord-parametrised pseudo-arclength)
# ------------------------------------------------------------------------------------------------
class _Chord:
    """Branch points between two converged points A, B, parametrised by σ ∈ [0, 1] along the
    chord c = B - A: the point on the branch in the hyperplane c·(x - (A + σ c)) = 0 (weighted
    as in the continuation norm), by Keller's bordered Newton. Valid for a short step, through
    folds (the chord is transversal to the branch there).

    Near a bifurcation point J is nearly singular and Newton's basin shrinks to nothing, so the
    predictor must be very good: cubic Hermite interpolation (values and branch tangents) between
    the nearest cleanly converged points ("anchors") on either side. If Newton still diverges,
    the predictor is accepted when its residual is below ``accept`` times the κ-load (it is then
    far more accurate than the inertia or a sign of dκ/dσ needs), but not used as an anchor.
    """

    def __init__(self, model: AxisymModel, ns: Any, L: float, A: tuple[np.ndarray, float],
                 B: tuple[np.ndarray, float], newton_tol: float = 1e-10,
                 max_its: int = 15) -> None:
        self.model, self.ns, self.L = model, ns, L
        self.wA, self.lA = A
        self.wB, self.lB = B
        self.cw_vec = self.wB - self.wA
        self.cl = self.lB - self.lA
        h = float(model.h.value)
        self.cw = 1.0 / (self.wA.size * h**2)
        self.C2 = self.cw * self.cw_vec @ self.cw_vec + self.cl**2
        self.tol, self.max_its = newton_tol, max_its
        self.ftol, self.accept = 1e-7, 1e-5
        self.deflate = True
        self._b = model.w.x.petsc_vec.duplicate()
        self._x = model.w.x.petsc_vec.duplicate()
        self.anchors: dict[float, tuple[np.ndarray, float, np.ndarray, float]] = {}
        for sig, (w, lam) in ((0.0, A), (1.0, B)):
            self._set(w, lam)
            self._anchor(sig)

    def _set(self, w: np.ndarray, lam: float) -> None:
        self.model.w.x.array[:] = w
        self.model.kappa.value = lam / self.L

    def _lin(self, rhs: np.ndarray) -> np.ndarray:
        self._b.array_w[:] = rhs
        self.ns.lin_solve(self._b, self._x)
        return self._x.array_r.copy()

    def _dres_dlambda(self) -> np.ndarray:
        self.ns.assemble_dkappa(self._b)
        return self._b.array_r.copy() / self.L

    def _residual(self) -> np.ndarray:
        self.ns.assemble_residual(self._b)
        return self._b.array_r.copy()

    def _anchor(self, sigma: float) -> None:
        """Store the model's state as an anchor at σ, with d(w, λ)/dσ along the branch."""
        self.ns.factor()
        z = self._lin(-self._dres_dlambda())
        den = self.cw * self.cw_vec @ z + self.cl
        alpha = self.C2 / den if den != 0 and math.isfinite(den) else 0.0
        dw, dl = alpha * z, alpha
        # a tangent far from the chord's direction is polluted by a near-null mode of J (a
        # bifurcation point close by): use the chord instead
        if not np.linalg.norm(dw - self.cw_vec) <= 0.5 * np.linalg.norm(self.cw_vec):
            dw, dl = self.cw_vec.copy(), self.cl
        self.anchors[sigma] = (self.model.w.x.array.copy(), self.lam(), dw, dl)

    def predictor(self, sigma: float) -> tuple[np.ndarray, float]:
        s0 = max((s for s in self.anchors if s <= sigma), default=0.0)
        s1 = min((s for s in self.anchors if s >= sigma), default=1.0)
        w0, l0, dw0, dl0 = self.anchors[s0]
        if s1 == s0:
            return w0.copy(), l0
        w1, l1, dw1, dl1 = self.anchors[s1]
        d = s1 - s0
        x = (sigma - s0) / d
        h00, h10 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x
        h01, h11 = -2 * x**3 + 3 * x**2, x**3 - x**2
        w = h00 * w0 + h10 * d * dw0 + h01 * w1 + h11 * d * dw1
        lam = h00 * l0 + h10 * d * dl0 + h01 * l1 + h11 * d * dl1
        return w, lam

    def solve(self, sigma: float) -> bool:
        """Put the branch point at σ into the model (state and κ); False if that fails.

        Bordered Newton from the predictor whose steps omit the components along the four
        eigenvectors v of J nearest 0 when such a component is more than 10 times the rest of
        the step: that is round-off amplified by 1/μ, or the start of a switch to a branch
        bifurcating close by. Only with ``deflate`` (off in a step that contains a fold: there
        the branch turns into the null vector and the bordered system resolves it). The
        residual keeps its (tiny) components along the omitted directions, so convergence is
        judged on the step, or on a stagnating residual below ``accept`` times the κ-load.
        """
        import scipy.sparse as sp
        from scipy.sparse.linalg import eigsh

        m = self.model
        if sigma in self.anchors:
            w, lam, _, _ = self.anchors[sigma]
            self._set(w, lam)
            return True
        wpred, lpred = self.predictor(sigma)
        self._set(wpred, lpred)
        lam = lpred
        wp, lp = self.wA + sigma * self.cw_vec, self.lA + sigma * self.cl
        f_prev, scale, f_pred = math.inf, 0.0, math.inf
        tiny = 1e-14 * float(np.linalg.norm(self.wB)) + 1e-300
        for it in range(self.max_its):
            F = self._residual()
            if not np.all(np.isfinite(F)):
                break
            Fl = self._dres_dlambda()
            fn = float(np.linalg.norm(F))
            if it == 0:
                scale, f_pred = float(np.linalg.norm(Fl)) * max(1.0, abs(lam)), fn
            if fn > 100.0 * min(f_prev, f_pred):
                break
            if it > 0 and fn > 0.9 * f_prev and fn <= self.accept * scale:
                self._anchor(sigma)
                return True  # stagnated at a small residual (round-off, near-null modes)
            f_prev = fn
            self.ns.factor()
            a, b = self._lin(-F), self._lin(-Fl)
            mu, V = np.zeros(0), np.zeros((a.size, 0))
            if self.deflate:
                ai, aj, av = self.ns.A.getValuesCSR()
                J = sp.csr_matrix((av, aj, ai), shape=self.ns.A.getSize())
                try:
                    mu, V = eigsh(J, k=4, sigma=0.0, which="LM")
                except Exception:  # noqa: BLE001 - ARPACK trouble: plain Newton steps
                    pass
            ca, cb = V.T @ a, V.T @ b
            a_reg = float(np.linalg.norm(a - V @ ca))
            b_reg = float(np.linalg.norm(b - V @ cb))
            for i in range(len(mu)):
                if abs(ca[i]) > 10.0 * a_reg + tiny or abs(cb[i]) > 10.0 * b_reg + tiny:
                    a -= ca[i] * V[:, i]
                    b -= cb[i] * V[:, i]
            N = self.cw * self.cw_vec @ (m.w.x.array - wp) + self.cl * (lam - lp)
            den = self.cl + self.cw * self.cw_vec @ b
            if den == 0 or not math.isfinite(den):
                break
            dl = -(N + self.cw * self.cw_vec @ a) / den
            dw = a + dl * b
            m.w.x.array[:] += dw
            lam += dl
            m.kappa.value = lam / self.L
            rms = float(np.linalg.norm(dw)) / math.sqrt(dw.size) / self.L
            if not math.isfinite(rms):
                break
            if rms < self.tol and abs(dl) < self.tol * max(1.0, abs(lam)):
                self._anchor(sigma)
                return True
        if f_pred <= self.accept * scale:
            self._set(wpred, lpred)
            return True
        return False

    def lam(self) -> float:
        return float(self.model.kappa.value) * self.L

    def dlam_sign(self) -> float:
        """Sign of dλ/dσ along the branch at the current point (tangent oriented along c)."""
        self.ns.factor()
        z = self._lin(-self._dres_dlambda())
        return 1.0 if self.cw * self.cw_vec @ z + self.cl >= 0 else -1.0

    def destroy(self) -> None:
        self._b.destroy()
        self._x.destroy()


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
    """The model, solvers and stability objects of a run."""

    cfg: RunConfig
    model: AxisymModel = field(init=False)

    def __post_init__(self) -> None:
        from shells.solvers import NewtonSolver
        from shells.stability import Stability

        self.model = AxisymModel(self.cfg.shape, self.cfg.params())
        self.model.modes = tuple(self.cfg.modes)
        self.ns = NewtonSolver(self.model, options=SNES_OPTIONS)
        self.ns_loc = NewtonSolver(self.model, options=SNES_OPTIONS)
        self.stab = Stability(self.model)
        # the residual bound is the continuation's own (relative to the κ-load, plus the
        # round-off floor of the penalty-stiff Jacobian): no model-specific tolerance here
        self.settings = self.cfg.settings or default_settings(self.cfg.shape, self.cfg.h_over_r)

    def record(self, p: Any, counts: dict[int, int]) -> dict[str, Any]:
        d = p.as_dict()
        d["kappa_R"] = p.kappa * self.cfg.R
        d["kappa_h"] = p.kappa * self.cfg.h
        d["negative_counts"] = [counts[m] for m in sorted(counts)]
        d["unstable_modes"] = [m for m in sorted(counts) if counts[m] > 0]
        return d

    def destroy(self) -> None:
        self.ns.destroy()
        self.ns_loc.destroy()
        self.stab.destroy()


def _follow(run: _Run) -> Iterator[tuple[Any, dict[int, int]]]:
    """The continuation's points with the negative count of every H_m. At κ = 0 the state is
    the stress-free reference, the energy's minimum: every H_m is positive definite there (see
    tests/test_axisym.py), so its counts are zero without factorising."""
    from shells.continuation import continuation

    cfg = run.cfg
    for p in continuation(run.model, run.settings, kappa_start=0.0, kappa_end=cfg.kappa_end,
                          solver=run.ns):
        rest = p.kappa == 0.0 and not np.any(run.model.w.x.array)
        yield p, ({m: 0 for m in cfg.modes} if rest else run.stab.negative_counts(cfg.modes))


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
        for p, counts in _follow(run):
            yield run.record(p, counts)
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


@dataclass
class _Snap:
    w: np.ndarray
    lam: float
    counts: dict[int, int]
    dkds: float


def _solve_at(chord: _Chord, sigma: float) -> float:
    if not chord.solve(sigma):
        raise RuntimeError(f"the branch corrector failed at sigma = {sigma:.6g} while locating "
                           "a critical point")
    return chord.lam()


def _locate_fold(run: _Run, chord: _Chord, rel_tol: float) -> tuple[float, float, float]:
    """(σ_lo, σ_hi, λ at the fold): bisection on the sign of dλ/dσ, then the extremum of λ
    over the last three points (λ is stationary there, the error is O(Δσ²))."""
    s0 = chord.dlam_sign() if chord.solve(0.0) else 1.0
    lo, hi = 0.0, 1.0
    lams = {0.0: chord.lA, 1.0: chord.lB}
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lams[mid] = _solve_at(chord, mid)
        if chord.dlam_sign() == s0:
            lo = mid
        else:
            hi = mid
        lam_ref = max(abs(lams[lo]), 1e-300)
        if hi - lo < 1e-3 and abs(lams[hi] - lams[lo]) < 0.1 * rel_tol * lam_ref:
            break
    near = [lams[s] for s in lams if lo - 1e-12 <= s <= hi + 1e-12]
    mid = 0.5 * (lo + hi)
    near.append(_solve_at(chord, mid))
    lam = max(near) if s0 > 0 else min(near)
    return lo, hi, lam


#: a perfect sphere's critical 2n+1 multiplet is split by the discretisation (by < 1e-4 in κ
#: at the default mesh); neighbouring degrees cross a few 1e-4 apart (the minimum of κ_b(n) is
#: flat), so the degree is read off this far past the first crossing: n is good to ±1
SPHERE_DEGREE_OFFSET = 2.0e-4


def _sphere_degree(run: _Run, chord: _Chord, sigma: float, lam: float, end: float,
                   end_counts: dict[int, int]) -> int | None:
    """n: the largest m unstable at κ (1 + SPHERE_DEGREE_OFFSET) past the crossing at σ."""
    modes = run.cfg.modes
    target = lam * (1.0 + SPHERE_DEGREE_OFFSET * math.copysign(1.0, chord.lB - chord.lA))
    frac = (target - chord.lA) / (chord.lB - chord.lA) if chord.lB != chord.lA else 1.0
    if frac >= end:
        counts = end_counts
    else:
        _solve_at(chord, max(frac, sigma))
        counts = run.stab.negative_counts(modes)
    return max((m for m in modes if counts[m] > 0), default=None)


def _locate_interval(run: _Run, A: _Snap, B: _Snap, rel_tol: float,
                     limit: int | None = None) -> list[dict[str, Any]]:
    """Critical points between two consecutive branch points A and B, in branch order, up to a
    fold in the interval (inclusive), at most ``limit`` bifurcations before it."""
    model, cfg = run.model, run.cfg
    L = model.shape.characteristic_size()
    chord = _Chord(model, run.ns_loc, L, (A.w, A.lam), (B.w, B.lam))
    events: list[dict[str, Any]] = []
    try:
        end, end_counts = 1.0, dict(B.counts)
        fold = A.dkds * B.dkds < 0
        chord.deflate = not fold
        if fold:
            lo, hi, lam_f = _locate_fold(run, chord, rel_tol)
            _solve_at(chord, lo)  # the fundamental side of the fold
            end, end_counts = lo, run.stab.negative_counts(cfg.modes)
            events.append(dict(kind="fold", sigma=0.5 * (lo + hi), lam=lam_f, mode_m=0,
                               mode_n=None))
        base = dict(A.counts)
        lo, lam_lo = 0.0, A.lam
        while True:
            cand = {m for m in cfg.modes if end_counts[m] != base[m]}
            if not cand:
                break
            hi, lam_hi = end, _solve_at(chord, end)
            lo0, lam_lo0 = lo, lam_lo  # all counts are those of ``base`` here
            # the first crossing among the candidates: bisect one of them, then check that no
            # other one crossed before its bracket (else continue with those, further left)
            while True:
                m0 = min(cand)
                while abs(lam_hi - lam_lo) > rel_tol * max(abs(lam_hi), abs(lam_lo)):
                    mid = 0.5 * (lo + hi)
                    lam_mid = _solve_at(chord, mid)
                    if run.stab.negative_count(m0) != base[m0]:
                        hi, lam_hi = mid, lam_mid
                    else:
                        lo, lam_lo = mid, lam_mid
                _solve_at(chord, lo)
                earlier = {m for m in cand - {m0} if run.stab.negative_count(m) != base[m]}
                if not earlier:
                    break
                cand, hi, lam_hi = earlier, lo, lam_lo
                lo, lam_lo = lo0, lam_lo0
            mode_n = _sphere_degree(run, chord, hi, lam_hi, end, end_counts) \
                if _is_sphere(cfg.shape) else None
            events.append(dict(kind="bifurcation", sigma=0.5 * (lo + hi),
                               lam=0.5 * (lam_lo + lam_hi), mode_m=m0, mode_n=mode_n))
            if hi >= end or (limit is not None and len(events) >= limit):
                break
            _solve_at(chord, hi)
            base = run.stab.negative_counts(cfg.modes)
            lo, lam_lo = hi, lam_hi
    finally:
        chord.destroy()
        model.w.x.array[:] = B.w
        model.kappa.value = B.lam / L
    events.sort(key=lambda e: e["sigma"])
    return events


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
    run = _Run(cfg)
    L = run.model.shape.characteristic_size()
    found: list[dict[str, Any]] = []
    try:
        prev: _Snap | None = None
        stop = False
        for p, counts in _follow(run):
            cur = _Snap(run.model.w.x.array.copy(), p.kappa_L, counts, p.dkappa_ds)
            if prev is not None:
                fold = prev.dkds * cur.dkds < 0
                if fold or cur.counts != prev.counts:
                    left = None if cfg.max_critical is None else cfg.max_critical - len(found)
                    for ev in _locate_interval(run, prev, cur, cfg.rel_tol, left):
                        found.append(ev)
                        if ev["kind"] == "fold" or (cfg.max_critical is not None
                                                    and len(found) >= cfg.max_critical):
                            stop = True
                            break
            if stop:
                break
            prev = cur
        lam_end = cfg.kappa_end * L
        if not stop and (prev is None or abs(prev.lam - lam_end) > 1e-9 * abs(lam_end)):
            # the continuation gave up (step below ds_min, or max_steps) short of the end:
            # the critical points beyond are unknown, "none" would be a false claim
            reached = None if prev is None else prev.lam / L * cfg.R
            raise RuntimeError(f"the axisymmetric continuation stopped at kappa R = {reached} "
                               f"before the end of the range, kappa R = "
                               f"{cfg.kappa_end * cfg.R:.6g}; critical points beyond it are "
                               "not known")
        dofs = run.model.num_dofs()
    finally:
        run.destroy()
    R, h = cfg.R, cfg.h
    pts = [{"kind": e["kind"], "kappa_R": e["lam"] / L * R, "kappa_h": e["lam"] / L * h,
            "mode_m": e["mode_m"], "mode_n": e["mode_n"]} for e in found]
    first = pts[0] if pts else {"kind": "none", "kappa_R": None, "kappa_h": None,
                                "mode_m": None, "mode_n": None}
    theta = getattr(cfg.shape, "theta", None)
    return {"kind": first["kind"], "kappa_R": first["kappa_R"], "kappa_h": first["kappa_h"],
            "mode_m": first["mode_m"], "mode_n": first["mode_n"], "h_over_R": cfg.h_over_r,
            "nu": cfg.nu, "theta_deg": (None if theta is None or _is_sphere(cfg.shape)
                                        else math.degrees(theta)),
            "model": "axisym", "dofs": dofs, "critical_points": pts}
