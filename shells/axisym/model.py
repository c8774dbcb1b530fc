"""The axisymmetric model's kinematics and energy (problem layer): ``AxisymModel``, a
``shells.problem.interface.Problem`` whose stability blocks are the Fourier modes m
(``shells.axisym.modes``).

Energy (same normalisation as ``shells.surface.model``, Young's modulus scaled out, per reference
area)::

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from shells.axisym.kinematics import (
    JIT_OPTIONS,
    Jet,
    cross,
    dirichlet,
    dot,
    is_sphere,
    meridian_ufl,
    read_inputs,
    same_inputs,
)
from shells.axisym.mesh import MeridianMesh, check_supported, make_meridian_nodes
from shells.errors import InputError
from shells.geometry.shapes import Shape
from shells.geometry.stimulus import UNIFORM, CurvatureField, field_radius
from shells.parameters import check_nu
from shells.problem.formcache import compiled_derived, file_tag
from shells.problem.forms import FormProblem, assemble_symmetric, dkappa_ufl
from shells.problem.interface import ModeInfo, orbit_cosine

if TYPE_CHECKING:
    from shells.axisym.modes import ModeForms

__all__ = ["SNES_OPTIONS", "AxisymModel", "AxisymParameters"]

#: what the load parameter ``kappa`` imposes (``AxisymParameters.load``)
LOADS = ("curvature", "pressure", "equivalent", "equivalent_normal", "local_pressure")

#: names this module's derivations of forms in the form cache (``shells.problem.formcache``)
_DERIVATION = file_tag(__file__)


#: Newton (SNES) options of the 1D model's solves: its residual is assembled to round-off, so
#: tight relative and absolute tolerances are reachable
SNES_OPTIONS: dict[str, Any] = {"snes_rtol": 1.0e-9, "snes_atol": 1.0e-12, "snes_stol": 1.0e-10,
                                "snes_max_it": 25}


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
        load: what the load parameter (the Constant ``kappa``) imposes: "curvature" (the
            natural curvature κ, b̄ = b° + κ a°) or "pressure" (a dead external pressure p,
            normal to the reference surface, given as its equivalent curvature of the paper's
            Eq. (5), κ_p h = 6 (1-ν) (R/h)² p/E, R the shape's length scale; no natural
            curvature): one parameter, so that both loads go through the same algorithms.
            Three dead loads equivalent to the stimulus at first order (the paper's Eqs. (2)
            and its outlook's hypothesis; docs/kappa-fields.md), all with b̄ = b°:
            "equivalent" (the curvature potential linearised at the reference state: bulk
            normal and tangential forces and edge terms), "equivalent_normal" (closed spheres:
            its bulk normal part alone, the normal load -(2/3)(1+ν) h² κ (Δf - 2f/R²) Ψ3)
            and "local_pressure" (closed spheres: Eq. (5)'s pressure with the local stimulus,
            (4/3)(1+ν)(h/R)² κ f Ψ3); the last two with a uniform axial body force that
            balances their resultant (inertia relief).
        kappa_field: the natural-curvature stimulus K of b̄ = b° + κ K
            (``shells.geometry.stimulus``): an axisymmetric f and factors (f1, f2) on e_s⊗e_s and
            e_φ⊗e_φ; default K = a°.
    """

    h: float
    nu: float = 0.5
    cells: int = 200
    layer_cells: float = 8.0
    grading: float = 1.1
    penalty: float = 1.0e4
    quadrature_degree: int = 8
    slope_bending: bool = True
    load: str = "curvature"
    kappa_field: CurvatureField = UNIFORM

    def __post_init__(self) -> None:
        if self.load not in LOADS:
            raise InputError(f"load must be one of {', '.join(LOADS)}, got {self.load!r}")
        if not isinstance(self.kappa_field, CurvatureField):
            raise InputError(f"kappa_field must be a CurvatureField, got {self.kappa_field!r}")
        if self.load == "pressure" and not self.kappa_field.uniform:
            raise InputError("a natural-curvature field has no meaning under the pressure load")
        if self.load in ("equivalent_normal", "local_pressure") and not \
                self.kappa_field.isotropic:
            raise InputError(f"the {self.load} load is derived for an isotropic stimulus")
        if not (isinstance(self.h, (int, float)) and math.isfinite(self.h) and self.h > 0):
            raise InputError(f"thickness h must be positive, got {self.h!r}")
        check_nu(self.nu, "Poisson ratio nu")
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


# ------------------------------------------------------------------------------------------------
# the model
# ------------------------------------------------------------------------------------------------
class AxisymModel(FormProblem):
    """Axisymmetric shell model, a ``shells.problem.interface.Problem``.

    Attributes: ``shape``, ``shell`` (the ``MeridianMesh``; ``shell.comm``), ``W``, ``w`` (state
    (u_r, u_z; p_r, p_z)), ``kappa``, ``h``, ``nu`` (Constants), ``residual``, ``hessian``,
    ``dres_dkappa`` (compiled forms), ``bcs``, ``mass``; methods ``scalars()``, ``num_dofs()``,
    ``energy_density(jet)``. Assembly from ``FormProblem``; the stability blocks are the Fourier
    modes m of ``modes`` (default 0..12), each with its Hessian H_m (``ModeForms``, compiled on
    first use; for m ≥ 1 a polynomial in m whose coefficient matrices are assembled once per
    state).
    """

    modes: tuple[int, ...] = tuple(range(13))

    def __init__(self, shape: Shape, params: AxisymParameters, comm: Any = None) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        check_supported(shape)
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
         self.r0tt, self.z0tt) = meridian_ufl(shape, self.t, mesh)
        self.g = ufl.sqrt(self.r0t**2 + self.z0t**2)
        self.area_density = 2 * math.pi * self.r0 * self.g  # dω = area_density dt
        params.kappa_field.check_on(shape, axisymmetric=True)
        if params.load in ("equivalent_normal", "local_pressure") and not is_sphere(shape):
            raise InputError(f"the {params.load} load is derived for a closed sphere (an open "
                             "shell adds edge terms: use the equivalent load)")
        self.K = self._natural_factors()
        self._build_forms()
        self.bcs = self._axis_conditions()
        self._degree_forms: dict[Any, tuple] = {}
        self._jacobian_fast: Any = None  # ``jacobian_elements``
        self._pair: Any = None  # ``_paired``
        self.dkappa_kept: Any = None  # dR/dκ from the last paired pass, and its inputs
        self._uz_dofs: tuple[np.ndarray, np.ndarray] | None = None  # ``uz_at``'s

    # -- kinematics ------------------------------------------------------------------------------
    def base_jet(self, w: Any) -> Jet:
        """The jet of an axisymmetric state ``w`` (u_r, u_z; p_r, p_z): no φ-dependence."""
        import ufl

        u, p = ufl.split(w)
        z = 0.0 * self.t
        return Jet(val=(u[0], z, u[1]), t=(u[0].dx(0), z, u[1].dx(0)), ph=(z, z, z),
                   tph=(z, z, z), phph=(z, z, z), p=(p[0], z, p[1]),
                   pt=(p[0].dx(0), z, p[1].dx(0)), pph=(z, z, z))

    def zero_jet(self) -> Jet:
        """The jet of the reference state (every component zero)."""
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

            c = cross(xtb, xph)
            nn = ufl.sqrt(dot(c, c))
            n = tuple(ci / nn for ci in c)
            a = (dot(xt, xt) / g**2, dot(xt, xph) / (g * r0), dot(xph, xph) / r0**2)
            b = (dot(n, xtt) / g**2, dot(n, xtph) / (g * r0), dot(n, xphph) / r0**2)
            return a, b

        a, b = geo(j)
        a0, b0 = geo(self.zero_jet())
        return {"a": tuple(x - y for x, y in zip(a, a0, strict=True)),
                "b": tuple(x - y for x, y in zip(b, b0, strict=True)),
                "slope_gap": tuple(pi - ti for pi, ti in zip(j.p, j.t, strict=True))}

    def _tangents(self, j: Jet) -> tuple[tuple, tuple]:
        """x_t (from the slope fields with ``slope_bending``, as the curvature reads it) and
        x_φ of the deformed surface at a jet, cylindrical components."""
        ur, uph, _ = j.val
        xph = (j.ph[0] - uph, self.r0 + ur + j.ph[1], j.ph[2])
        src = j.p if self.params.slope_bending else j.t
        return (self.r0t + src[0], src[1], self.z0t + src[2]), xph

    def normal_rate(self, base: Jet, rate: Jet) -> tuple:
        """ṅ = Dn(base)[rate]: the rate of the unit normal n = c/|c|, c = x_t × x_φ, at the
        state ``base`` under the velocity jet ``rate``: (I - n⊗n) ċ / |c|, ċ = ẋ_t × x_φ +
        x_t × ẋ_φ (linear in ``rate``)."""
        import ufl

        xt, xph = self._tangents(base)
        c = cross(xt, xph)
        nn = ufl.sqrt(dot(c, c))
        n = tuple(ci / nn for ci in c)
        ur, uph, _ = rate.val
        dxph = (rate.ph[0] - uph, ur + rate.ph[1], rate.ph[2])
        dxt = rate.p if self.params.slope_bending else rate.t
        dc = tuple(a + b for a, b in zip(cross(dxt, xph), cross(xt, dxph), strict=True))
        dn = dot(n, dc)
        return tuple((dci - dn * ni) / nn for dci, ni in zip(dc, n, strict=True))

    def kinetic_density(self, base: Jet, a: Jet, b: Jet) -> Any:
        """The kinetic energy's bilinear density per reference area, rates ``a`` and ``b`` (jets
        of velocities) about the state ``base``, in units of the energy (time in L √(ρ/E)):
        (8 (1-ν²)/L²) [u̇_a·u̇_b + (h²/12) (ṅ_a·ṅ_b + (ṗ_a - ∂_t u̇_a)·(ṗ_b - ∂_t u̇_b) / g²)],
        ṅ the normal's rate (``normal_rate``). The last term is the rotary inertia of the slope
        fields' departure from ∂_t u, which the penalty keeps at zero: it vanishes on every
        Kirchhoff-Love motion and gives the slope fields' tangential part, which turns no
        normal, a mass (a stiff mode of the penalty instead of an algebraic unknown)."""

        def gap(j: Jet) -> tuple:
            return tuple(pi - ti for pi, ti in zip(j.p, j.t, strict=True))

        L = self.shape.characteristic_size()
        c = 8 * (1 - self.nu**2) / L**2
        rot = dot(self.normal_rate(base, a), self.normal_rate(base, b))
        return c * (dot(a.val, b.val) + self.h**2 / 12 * (rot + dot(gap(a), gap(b)) / self.g**2))

    def _quad(self, A: tuple) -> Any:
        """(1-ν)|A|² + ν tr²A of a symmetric 2x2 tensor given as (A11, A12, A22)."""
        return ((1 - self.nu) * (A[0] ** 2 + 2 * A[1] ** 2 + A[2] ** 2)
                + self.nu * (A[0] + A[2]) ** 2)

    def energy_density(self, j: Jet) -> dict[str, Any]:
        """Energy densities per reference area dω of a jet (``total`` is minimised)."""
        e = self.strains(j)
        Ea, Eb = e["a"], e["b"]
        load = self.params.load
        kn = self.kappa if load == "curvature" else 0.0  # the natural curvature
        gap, potential = self._natural_gap(Eb, kn)
        stretch = self._quad(Ea)
        bend_nat = self.h**2 / 3 * self._quad(gap)
        pen = self.pen * dot(e["slope_gap"], e["slope_gap"]) / self.g**2
        out = {"total": stretch + bend_nat + pen, "stretching": stretch,
               "bending": self.h**2 / 3 * self._quad(Eb),
               "curvature_potential": potential,
               "penalty": pen}
        un = (j.val[0] * (-self.z0t) + j.val[2] * self.r0t) / self.g  # Ψ3
        if load == "pressure":
            # + 8 (1-ν²) p/(E h) u·n° (energy per E h / (8 (1-ν²))), p/E from κ_p by Eq. (5)
            L = self.shape.characteristic_size()
            out["pressure_work"] = 4 * (1 + self.nu) / 3 * (self.h / L) ** 2 * self.kappa * un
        elif load == "equivalent":
            # the curvature potential's first variation at the reference state, a dead load:
            # d/dε P(ε j) at ε = 0 (ε a Constant 0 made a UFL variable)
            import ufl
            from dolfinx import default_scalar_type, fem

            eps = ufl.variable(fem.Constant(self.mesh, default_scalar_type(0.0)))
            scaled = Jet(*(tuple(eps * c for c in f) for f in j.fields()))
            out["pressure_work"] = ufl.diff(
                self._natural_gap(self.strains(scaled)["b"], self.kappa)[1], eps)
        elif load in ("equivalent_normal", "local_pressure"):
            # normal forces alone have a resultant along the axis, -c ∫ q n_z dω (the
            # tangential part they omit carries its opposite): balanced by a uniform body force
            # (inertia relief), else the gauge point would carry it as a point load
            c = -2 * (1 + self.nu) / 3 * self.h**2 * self.kappa
            q, q_z = self.normal_load()
            out["pressure_work"] = c * (q * un - q_z * j.val[2])
        if "pressure_work" in out:
            out["total"] = out["total"] + out["pressure_work"]
        return out

    def _natural_gap(self, Eb: tuple, kn: Any) -> tuple[tuple, Any]:
        """b - b̄ (components 11, 12, 22) and the curvature potential's density
        -(2/3) h² [(1-ν) κK:(b-b°) + ν tr κK tr(b-b°)] for the natural curvature ``kn`` (κ, or
        0 under a dead load)."""
        if self.K is None:  # the paper's K = a°
            gap = (Eb[0] - kn, Eb[1], Eb[2] - kn)
            return gap, -2 * (1 + self.nu) / 3 * self.h**2 * kn * (Eb[0] + Eb[2])
        k1, k2 = kn * self.K[0], kn * self.K[1]  # K = f (f1 e_s⊗e_s + f2 e_φ⊗e_φ)
        gap = (Eb[0] - k1, Eb[1], Eb[2] - k2)
        return gap, -2 / 3 * self.h**2 * ((1 - self.nu) * (k1 * Eb[0] + k2 * Eb[2])
                                          + self.nu * (k1 + k2) * (Eb[0] + Eb[2]))

    def normal_load(self) -> tuple[Any, float]:
        """q of the normal load c q Ψ3 ("equivalent_normal": Δf - 2f/R²; "local_pressure":
        -2f/R²) and the mean ∫ q n_z dω / A of its axial component."""
        from dolfinx import fem

        if not hasattr(self, "_q"):
            f = 1.0 if self.K is None else self.K[0]
            q = -2 * f / self.shape.R ** 2
            if self.params.load == "equivalent_normal" and self.K is not None:
                q = q + self._laplacian(f)
            ad, nz = self.area_density, self.r0t / self.g
            qz = (fem.assemble_scalar(fem.form(q * nz * ad * self.dx, jit_options=JIT_OPTIONS))
                  / fem.assemble_scalar(fem.form(ad * self.dx, jit_options=JIT_OPTIONS)))
            self._q = (q, float(qz))
        return self._q

    def _laplacian(self, f: Any) -> Any:
        """The surface Laplacian of an axisymmetric f(t): (r° f_t / g)_t / (r° g)."""
        return (self.r0 * f.dx(0) / self.g).dx(0) / (self.r0 * self.g)

    def _natural_factors(self) -> tuple[Any, Any] | None:
        """(K_ss, K_φφ) = (f1 f, f2 f) of the stimulus, f a P3 function of t and (f1, f2)
        Constants (one kernel for every field); None for the paper's K = a° (the forms are
        then exactly those without a field)."""
        from dolfinx import default_scalar_type, fem

        fld = self.params.kappa_field
        if fld.uniform:
            return None

        def position(p: np.ndarray) -> tuple:
            r, z = self.shape.meridian(p[0])
            return np.asarray(r, dtype=float), 0.0 * p[0], np.asarray(z, dtype=float)

        self.kappa_f = fld.interpolate(fem.functionspace(self.mesh, ("Lagrange", 3)), position,
                                       field_radius(self.shape), axisymmetric=True)
        self.kappa_anisotropy = fem.Constant(self.mesh, np.array(fld.anisotropy,
                                                                 dtype=default_scalar_type))
        return self.kappa_anisotropy[0] * self.kappa_f, self.kappa_anisotropy[1] * self.kappa_f

    # -- forms -----------------------------------------------------------------------------------
    def _build_forms(self) -> None:
        import ufl
        from dolfinx import fem

        dens = self.energy_density(self.base_jet(self.w))
        self._derive_forms(dens["total"] * self.area_density * self.dx, JIT_OPTIONS)
        dw, w_ = ufl.TestFunction(self.W), ufl.TrialFunction(self.W)
        self.mass = fem.form(ufl.inner(w_, dw) * self.area_density * self.dx,
                             jit_options=JIT_OPTIONS)
        u, _ = ufl.split(self.w)
        n0r, n0z = -self.z0t / self.g, self.r0t / self.g
        ad = self.area_density
        sf = {k: v * ad * self.dx for k, v in dens.items()}
        sf["psi3_integral"] = (u[0] * n0r + u[1] * n0z) * ad * self.dx
        sf["uz_integral"] = u[1] * ad * self.dx
        self._uz_integral = sf["uz_integral"]  # its derivative: ``pole_functional``
        sf["nz_integral"] = n0z * ad * self.dx
        sf["area"] = ad * self.dx
        # compiled on first use (``assemble``): a run that only locates critical points asks
        # for none of them, and each form costs its signature and a cache lookup
        self._scalar_ufl = sf
        self._scalar_forms: dict[str, Any] = {}

    def _axis_conditions(self) -> list[Any]:
        """u_r = 0 and p_z = 0 on the axis (each pole); u_z = 0 at the top pole (gauge)."""
        W = self.W
        ur, uz, pz = W.sub(0).sub(0), W.sub(0).sub(1), W.sub(1).sub(1)
        poles = self.axis_vertices()
        top = self.vertices_at(0.0)
        return (dirichlet(ur, poles) + dirichlet(pz, poles) + dirichlet(uz, top))

    def axis_vertices(self) -> np.ndarray:
        """The mesh vertices on the axis: the top pole, and the bottom one if closed."""
        pts = [0.0] + ([self.shape.t_max] if self.shape.closed else [])
        return np.concatenate([self.vertices_at(t) for t in pts])

    def widest_vertex(self) -> np.ndarray:
        """The vertex of largest r° (rim of a cap up to a hemisphere, else the equator)."""
        x = self.mesh.geometry.x[:, 0]
        r0 = self.shape.meridian(x)[0]
        return self.vertices_at(float(x[np.argmax(r0)]))

    def vertices_at(self, t: float) -> np.ndarray:
        """The local mesh vertices at meridian coordinate ``t``."""
        from dolfinx import mesh as dmesh

        tol = 1e-10 * max(1.0, self.shape.t_max)
        return dmesh.locate_entities(self.mesh, 0, lambda x: np.abs(x[0] - t) < tol)

    # -- scalars ---------------------------------------------------------------------------------
    def assemble(self, name: str) -> float:
        """The scalar functional ``name`` (energy parts, integrals) at the current state.

        Its form is compiled on first use.
        """
        from dolfinx import fem

        if name not in self._scalar_forms:
            self._scalar_forms[name] = fem.form(self._scalar_ufl[name], jit_options=JIT_OPTIONS)
        return float(fem.assemble_scalar(self._scalar_forms[name]))

    def total_energy(self) -> float:
        """The energy whose gradient is the residual, at the current state (``Energy``)."""
        return self.assemble("total")

    def scalars(self) -> dict[str, float]:
        """Energy split, Ψ3/h (mean normal displacement, translation-free), apex u_z/h, and the
        pole's normal displacement Ψ3(pole)/h = (u_z(pole) - ū_z)/h (ū: the mean displacement,
        i.e. relative to the centroid's translation)."""
        out = {k: self.assemble(k) for k in ("total", "stretching", "bending",
                                             "curvature_potential", "penalty")}
        out["energy"] = out.pop("total")
        area = self.assemble("area")
        uz_integral = self.assemble("uz_integral")
        psi3 = (self.assemble("psi3_integral") / area
                - uz_integral * self.assemble("nz_integral") / area**2)
        h = float(self.h.value)
        out["psi3_over_h"] = psi3 / h
        uz = self.uz_at(np.array([0.0, self.shape.t_max]))
        disp = 0.5 * (uz[0] - uz[1]) if self.shape.closed else uz[0] - uz[1]
        out["apex_uz_over_h"] = float(disp) / h
        out["psi3_pole_over_h"] = float(uz[0] - uz_integral / area) / h
        return out

    def pole_functional(self) -> Any:
        """The state-shaped vector e with e·w = Ψ3(pole)/h, the ``psi3_pole_over_h`` of
        ``scalars`` (exactly: it is linear in w), zero on the constrained DOFs: the normal
        displacement of the top pole (t = 0) relative to the centroid's, (u_z(0) - ū_z)/h
        with u_z(0) = 0 (the gauge), i.e. -∂/∂w ∫ u_z dA / (A h). The parameter of a closed
        sphere's dimple branch (``shells.analyses.postbuckle``)."""
        import ufl
        from dolfinx import fem
        from dolfinx.fem.petsc import assemble_vector
        from petsc4py import PETSc

        form = fem.form(ufl.derivative(self._uz_integral, self.w, ufl.TestFunction(self.W)),
                        jit_options=JIT_OPTIONS)
        e = assemble_vector(form)  # the residual's layout, as ``create_vector``
        e.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        e.scale(-1.0 / (self.assemble("area") * float(self.h.value)))
        self.zero_constrained(e)
        return e

    def meridian_profile(self) -> dict[str, np.ndarray]:
        """The state on the meridian at the mesh vertices, pole to pole/rim: reference t, r°,
        z° and displacement u_r, u_z (the mean u_z removed: no rigid translation); the energy
        densities per reference area ``eb`` (bending, the last two terms of Eq. (S-energy)) and
        ``es`` (stretching), cell averages (midpoint values) averaged onto the vertices."""
        Vu, dofs = self.W.sub(0).collapse()
        t = Vu.tabulate_dof_coordinates()[:, 0]
        u = self.w.x.array[np.asarray(dofs)].reshape(-1, 2)
        verts = np.unique(self.mesh.geometry.x[:, 0])
        idx = np.array([int(np.argmin(np.abs(t - tv))) for tv in verts])
        r0, z0 = self.shape.meridian(verts)
        area = self.assemble("area")
        uz = u[idx, 1] - self.assemble("uz_integral") / area
        out = {"t": verts, "r0": np.asarray(r0), "z0": np.asarray(z0), "ur": u[idx, 0],
               "uz": uz}
        out.update(self._vertex_densities(verts))
        return out

    def _vertex_densities(self, verts: np.ndarray) -> dict[str, np.ndarray]:
        """e_b and e_s at the vertices ``verts`` (sorted): the densities at the cells'
        midpoints (no vertex evaluation: the pole has r° = 0), averaged over neighbouring
        cells."""
        from dolfinx import fem

        if not hasattr(self, "_density_fns"):
            V0 = fem.functionspace(self.mesh, ("DG", 0))
            dens = self.energy_density(self.base_jet(self.w))
            pts = V0.element.interpolation_points()
            self._density_fns = {
                k: (fem.Function(V0), fem.Expression(e, pts))
                for k, e in (("eb", dens["bending"] + dens["curvature_potential"]),
                             ("es", dens["stretching"]))}
            self._density_mid = V0.tabulate_dof_coordinates()[:, 0]
        order = np.argsort(self._density_mid)
        out = {}
        for k, (f, e) in self._density_fns.items():
            f.interpolate(e)
            cells = f.x.array[order]  # cell j spans verts j, j + 1
            v = np.empty(len(verts))
            v[0], v[-1] = cells[0], cells[-1]
            v[1:-1] = 0.5 * (cells[:-1] + cells[1:])
            out[k] = v
        return out

    def uz_at(self, t: np.ndarray) -> np.ndarray:
        """u_z at mesh nodes t (values of the P3 field at vertices)."""
        if self._uz_dofs is None:  # the space's, not the state's: once
            Vz, dofs = self.W.sub(0).sub(1).collapse()
            self._uz_dofs = (Vz.tabulate_dof_coordinates()[:, 0], np.asarray(dofs))
        x, dofs = self._uz_dofs
        vals = self.w.x.array[dofs]
        return np.array([vals[np.argmin(np.abs(x - ti))] for ti in np.atleast_1d(t)])

    def num_dofs(self) -> int:
        """The global number of unknowns of the axisymmetric state."""
        im = self.W.dofmap.index_map
        return int(im.size_global * self.W.dofmap.index_map_bs)

    def create_jacobian(self) -> Any:
        """The Jacobian's matrix; on one process one whose values ``assemble_jacobian``
        writes in place (``chain.ElementAssembler.create_matrix``)."""
        fast = self.jacobian_elements()
        if fast is None:
            return FormProblem.create_jacobian(self)
        return fast[1].create_matrix()

    def assemble_jacobian(self, A: Any) -> None:
        """The Jacobian (``FormProblem``'s), on one process from its element matrices
        (``chain.CellTabulator``, ``chain.ElementAssembler``): the same values, added in the
        same order, without dolfinx's per-cell insertion, into a matrix of
        ``create_jacobian`` (Newton assembles it at every iteration; docs/model.md,
        "Stability and critical points")."""
        fast = self.jacobian_elements()
        if fast is None:
            FormProblem.assemble_jacobian(self, A)
            return
        tab, assembler, constrained = fast
        assembler.set(A, tab.tabulate()[0], constrained)

    def assemble_residual(self, b: Any) -> None:
        """R (``FormProblem``'s); on one process R and dR/dκ in one pass of one kernel
        (``_paired``, cheaper than the two forms' kernels), dR/dκ kept for ``assemble_dkappa``
        at the same state (the corrector asks for both at every iterate)."""
        pair = self._paired()
        if pair is None:
            FormProblem.assemble_residual(self, b)
            return
        from dolfinx.fem.assemble import assemble_vector
        from dolfinx.fem.petsc import apply_lifting, set_bc
        from petsc4py import PETSc

        form, first, second, both, reads = pair
        inputs = [a.copy() for a in read_inputs(*reads, self.mesh)]
        both.fill(0.0)
        assemble_vector(both, form)
        b.array_w[:] = both[first]
        apply_lifting(b, [self.hessian], bcs=[self.bcs], x0=[self.state], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, self.bcs, self.state, -1.0)
        self.dkappa_kept = (inputs, both[second])

    def assemble_dkappa(self, b: Any) -> None:
        """dR/dκ (``FormProblem``'s), from ``assemble_residual``'s pass where that was at the
        same state (every coefficient, Constant and the geometry compared exactly)."""
        kept, pair = self.dkappa_kept, self._paired()
        if kept is None or pair is None or not same_inputs(kept[0],
                                                           read_inputs(*pair[4], self.mesh)):
            FormProblem.assemble_dkappa(self, b)
            return
        from dolfinx.fem.petsc import set_bc

        b.array_w[:] = kept[1]
        set_bc(b, self.bcs, alpha=0.0)

    def _paired(self) -> Any:
        """(form, W's DOFs in it as R's and as dR/dκ's, its work array, its reads): the form
        R(v_1) + dR/dκ(v_2) on W x W (through the form cache), made on first use; None in
        parallel or where it cannot be made (then each has its own assembly)."""
        if self.comm.size > 1 or self._pair is False:
            return None
        if self._pair is None:
            try:
                self._pair = self._make_paired()
            except Exception as e:  # the two assemblies instead
                import logging

                logging.getLogger("shells").debug("paired residual not available: %s", e)
                self._pair = False
                return None
        return self._pair

    def _make_paired(self) -> tuple:
        import basix.ufl
        import ufl
        from dolfinx import fem

        W = self.W
        W2 = fem.functionspace(self.mesh, basix.ufl.mixed_element([W.ufl_element()] * 2))
        R, kappa = self.residual_ufl, self.kappa
        v = R.arguments()[0]

        def derive() -> list[Any]:
            v1, v2 = ufl.split(ufl.TestFunction(W2))
            return [ufl.replace(R, {v: v1}) + ufl.replace(dkappa_ufl(R, kappa), {v: v2})]

        forms, reads = compiled_derived(R, f"{_DERIVATION} R and dR/dkappa", derive,
                                        JIT_OPTIONS, spaces=(W2,))
        cells = np.asarray(W.dofmap.list)
        maps = []
        for k in (0, 1):  # W's DOF i is W2's DOF maps[k][i] in copy k
            out = np.full(W.dofmap.index_map.size_local + W.dofmap.index_map.num_ghosts, -1)
            out[cells] = np.asarray(W2.sub(k).dofmap.list)
            if (out < 0).any():
                raise ValueError("a DOF of W in no cell")
            maps.append(out[: W.dofmap.index_map.size_local])
        size = W2.dofmap.index_map.size_local + W2.dofmap.index_map.num_ghosts
        return forms[0], maps[0], maps[1], np.zeros(size), reads[0]

    def jacobian_elements(self) -> Any:
        """(tabulator, assembler, constrained DOFs) of the Jacobian, made on first use; None
        in parallel or where the C loop is not available (then dolfinx assembles it)."""
        if self.comm.size > 1 or self._jacobian_fast is False:
            return None
        if self._jacobian_fast is None:
            try:
                from shells.axisym.chain import CellTabulator, ElementAssembler

                owned = [np.zeros(0, dtype=np.int32)]
                for bc in self.bcs:
                    dofs, first_ghost = bc.dof_indices()
                    owned.append(np.asarray(dofs[:first_ghost]))
                cons = np.unique(np.concatenate(owned))
                self._jacobian_fast = (CellTabulator([self.hessian]),
                                       ElementAssembler(self.hessian), cons)
            except Exception as e:  # dolfinx's assembly instead
                import logging

                logging.getLogger("shells").debug("Jacobian from element matrices not "
                                                  "available: %s", e)
                self._jacobian_fast = False
                return None
        return self._jacobian_fast

    @property
    def factor_options(self) -> dict[str, Any]:
        """The Jacobian's factorisation (``shells.problem.interface``): on one process PETSc's own
        LU in reverse Cuthill-McKee order. The meridian's matrices are banded (half-bandwidth
        about 20 after the ordering), where MUMPS' per-factorisation overhead dominates
        (docs/model.md, "Solvers"; benchmarks/axisym_speed.py). That LU does not pivot: a zero
        pivot makes ``shells.algorithms.newton`` fall back to MUMPS for the rest of the run. In
        parallel: MUMPS (the default)."""
        if self.comm.size > 1:
            return {}
        return {"pc_factor_mat_solver_type": "petsc", "pc_factor_mat_ordering_type": "rcm"}

    # -- stability blocks: the Fourier modes m (shells.problem.interface.Problem)
    # ---------------------------
    @property
    def mode_forms(self) -> ModeForms:
        """The Fourier-mode Hessians (``ModeForms``), built on first use."""
        from shells.axisym.modes import ModeForms

        if not hasattr(self, "_mode_forms"):
            self._mode_forms = ModeForms(self)
        return self._mode_forms

    # Block None is the Jacobian itself: the Hessian of the axisymmetric unknowns, i.e. H_0
    # without the torsion D (the stability within rotational symmetry: folds and axisymmetric
    # bifurcations, the block branch switching on the 1D model uses).
    def stability_blocks(self) -> tuple[int, ...]:
        """The Fourier modes m of ``modes`` (``Problem.stability_blocks``)."""
        return tuple(self.modes)

    def block_layout(self, block: Any) -> str:
        """One layout for every H_m, another for the Jacobian (``Problem.block_layout``)."""
        return "axisymmetric" if block is None else "modes"  # one form for every m

    def create_hessian(self, block: Any) -> Any:
        """A matrix for ``block``: the Jacobian's, or one of every H_m's pattern."""
        if block is None:
            return self.create_jacobian()
        return self.mode_forms.create_matrix()

    def assemble_hessian(self, block: Any, H: Any) -> None:
        """The Jacobian (block None) or H_m at the current state into ``H``."""
        if block is None:
            assemble_symmetric(H, self.hessian, self.bcs)
            return
        self.mode_forms.assemble_hessian(block, H)  # m ≥ 1: Σ m^k C_k, C_k once per state

    def definite_blocks(self, blocks: Any, margin: float) -> dict[Any, bool] | None:
        """Whether H_m - ``margin`` diag(H_m) has a Cholesky factor, for each m of ``blocks``
        (``ModeForms.definite``, one process; block None is left out), for
        ``shells.algorithms.stability``'s test of definiteness."""
        return self.mode_forms.definite([b for b in blocks if b is not None], margin)

    def block_inertia(self, block: Any, growth: float) -> tuple[int, int, int] | None:
        """H_m's inertia by an LDLᵀ of its condensed form that vouches for it
        (``ModeForms.inertia``), for ``shells.algorithms.stability``'s exact counts; None for block
        None, in parallel, or where that factorisation cannot vouch for the count."""
        return None if block is None else self.mode_forms.inertia(block, growth)

    def block_inertias(self, blocks: list[Any], growth: float
                       ) -> dict[Any, tuple[int, int, int] | None] | None:
        """``block_inertia`` of several blocks at once (``ModeForms.inertias``: their
        condensations in one C call); None in parallel."""
        ms = [b for b in blocks if b is not None]
        out = self.mode_forms.inertias(ms, growth) if ms else {}
        if out is None:
            return None
        return {b: (None if b is None else out[int(b)]) for b in blocks}

    def hessian_quadratic(self, block: Any, v: Any) -> float:
        """vᵀ H v of block None (the Jacobian) or H_m at the current state, by quadrature of
        the second variation d²E(v, v) (``FormProblem._quadratic``: H_m's from the direct form
        of mode m), the block's constrained DOFs of v taken as zero; for
        ``shells.algorithms.stability``'s Rayleigh quotients."""
        if block is None:
            return self._quadratic(None, self.hessian_ufl, self.bcs, v, JIT_OPTIONS)
        mf = self.mode_forms
        bcs = mf.set_mode(int(block))
        cls = min(int(block), 1)  # one functional for m = 0, one for every m ≥ 1
        return self._quadratic(("mode", cls), mf.hessian_ufl, bcs, v, JIT_OPTIONS,
                               derived=(f"{mf.derivation} phases {cls}",
                                        lambda: mf.fixed_phase_ufl(cls)))

    def block_factor(self, block: Any) -> Any:
        """H_m factored on the chain of cells (``ModeForms.factor``), for
        ``shells.algorithms.stability``'s shift-invert eigensolves; None for block None, in
        parallel, or where it fails."""
        return None if block is None else self.mode_forms.factor(block)

    def condensed_hessian(self, block: Any) -> tuple[Any, int] | None:
        """H_m with its cells' interior DOFs eliminated (``ModeForms.condensed_hessian``): a
        smaller matrix of the same inertia but for the returned number of positive
        eigenvalues, for ``shells.algorithms.stability``'s exact counts; None for block None, in
        parallel, or where it does not apply."""
        return None if block is None else self.mode_forms.condensed_hessian(block)

    def assemble_mass(self, block: Any) -> Any:
        """The block's mass matrix (``Problem.assemble_mass``)."""
        if block is None:
            return self._assemble_mass(self.mass, self.bcs)
        return self._assemble_mass(self.mode_forms.mass, self.mode_forms.conditions(block))

    def assemble_kinetic_mass(self, block: Any) -> Any:
        """The kinetic mass of the free shell for block None (the axisymmetric unknowns) or
        mode m (``shells.problem.interface.KineticMass``): the second variation of T = ½ ∫
        ``kinetic_density`` dω at the current state, for block m of the velocity field
        (U cos mφ, V sin mφ, W cos mφ) integrated over φ as the block's Hessian is (π, 2π for
        m = 0), so that ω² of H_m v = ω² M_m v is the frequency of that mode. The rigid motions
        the block's gauge removes (``rigid_motions``) carry no kinetic energy
        (``shells.problem.kinetic.free_body_mass``)."""
        from dolfinx.fem.petsc import assemble_matrix, set_bc

        from shells.problem.kinetic import free_body_mass

        if block is None:
            if not hasattr(self, "_kinetic_form"):
                import ufl
                from dolfinx import fem

                jets = (self.base_jet(ufl.TrialFunction(self.W)),
                        self.base_jet(ufl.TestFunction(self.W)))
                self._kinetic_form = fem.form(
                    self.kinetic_density(self.base_jet(self.w), *jets) * self.area_density
                    * self.dx, jit_options=JIT_OPTIONS)
            form, bcs = self._kinetic_form, self.bcs
        else:
            mf = self.mode_forms
            bcs = mf.set_mode(int(block))
            form = mf.kinetic_form
        M = self._assemble_mass(form, bcs)
        M_full = assemble_matrix(form)
        M_full.assemble()
        self.__dict__.setdefault("_free_body", {})[block] = free_body_mass(
            M, M_full, self.rigid_motions(block), lambda v: set_bc(v, bcs, alpha=0.0))
        return self._free_body[block].mass

    def free_motion(self, block: Any, v: Any) -> Any:
        """v minus its rigid part (``shells.problem.interface.KineticMass``)."""
        return self._free_body[block].free_part(v)

    def rigid_motions(self, block: Any) -> list[Any]:
        """The rigid motions that block's gauge removes, at the current state (vectors of the
        block's layout): block None the translation along the axis; m = 0 that translation
        (W = 1) and the rotation about the axis (V = r); m = 1 the translation across the
        axis (U = 1, V = -1) and the tilt about the perpendicular axis (U = z, V = -z,
        W = -r), r, z the deformed meridian's coordinates and the slope fields their
        t-derivatives; none for m ≥ 2."""
        if block is None:
            v = self.create_vector()
            with v.localForm() as vl:
                vl.set(0.0)
            _, dofs = self.W.sub(0).sub(1).collapse()
            n = v.getLocalSize()
            idx = np.asarray(dofs)
            v.array_w[idx[idx < n]] = 1.0
            return [v]
        m = int(block)
        if m >= 2:
            return []
        return self.mode_forms.rigid_motions(m)

    def classify_mode(self, vec: Any, block: Any) -> ModeInfo:
        """m = the block's wavenumber (0 for the Jacobian); on a closed sphere also the degree
        n of the mode from the Rayleigh quotient R² ∫ |∇w|² / ∫ w² = n(n+1) of its normal
        component w, |∇w|² = (∂_s w)² + m² w² / r² (exact for the spherical harmonic Y_n^m)."""
        m = 0 if block is None else int(block)
        if not is_sphere(self.shape):
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
        rayleigh = {"x": x}
        if m == 1:
            rayleigh["orbit"] = self._sliding_overlap(f, float(fem.assemble_scalar(w2)))
        return ModeInfo(m=m, n=n, rayleigh=rayleigh)

    def _sliding_overlap(self, f: Any, w2: float) -> float:
        """|cos| of the angle (L² of the normal components) between an m = 1 mode of a closed
        sphere (``f``, its normal component's ∫ w² dω = ``w2``) and the tangent space of the
        current state's orbit under the rotations about the sphere's centre that move the pole,
        modulo rigid motions: a rotation by ε about the y axis moves the normal displacement
        w(s) of an axisymmetric state by -ε R cos φ ∂_s w (the reference sphere and n° being
        invariant), an m = 1 pattern of amplitude ∂_s w; the rigid-motion gauge adds to it a
        translation along x (normal amplitude n°_r) and a rotation of the deformed sphere
        about y (amplitude u_z n°_r - u_r n°_z), both m = 1 too. A dimple at the pole slides
        over the sphere along that tangent: neutral in the continuum, of either sign on the
        meridian's mesh (as ``ShellModel``'s ``orbit_overlap`` on the surface model). 0 for a
        uniform state, which has no orbit."""
        from dolfinx import default_scalar_type, fem

        if "orbit" not in self._degree_forms:
            mf = self.mode_forms
            ur, uz = mf.radial_axial(f)
            nr, nz = -self.z0t / self.g, self.r0t / self.g
            wm = ur * nr + uz * nz
            shift = fem.Constant(self.mesh, default_scalar_type(0.0))
            sr, sz = self._radial_axial(self.w)
            ws = sr * nr + (sz - shift) * nz
            basis = [ws.dx(0) / self.g, nr, (sz - shift) * nr - sr * nz]
            ad = self.area_density
            qs = [wm * b for b in basis] + [basis[i] * basis[j] for i in range(3)
                                            for j in range(i, 3)] + [ws * ws, sz]
            forms = tuple(fem.form(q * ad * self.dx, jit_options=JIT_OPTIONS) for q in qs)
            self._degree_forms["orbit"] = (shift, forms)
        shift, forms = self._degree_forms["orbit"]
        # the gauge u_z(pole) = 0 translates the state along the axis: removed, as in the
        # degree's Rayleigh quotient
        shift.value = float(fem.assemble_scalar(forms[-1])) / self.assemble("area")
        vals = np.array([float(fem.assemble_scalar(q)) for q in forms[:-1]])
        return orbit_cosine(vals[:3], vals[3:9], w2, vals[9], tangents=1)

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
        forms = tuple(fem.form(q * ad * self.dx, jit_options=JIT_OPTIONS)
                      for q in (grad2, wn * wn, uz, 1.0))
        return f, shift, m_c, forms
