"""The non-Euclidean shell energy of the paper on a surface mesh (Eq. 1 / S-energy), in UFL:
the surface model (model layer; implements ``shells.problem.interface.Problem``).

Energy (dimensionless as in the paper: Young's modulus scaled out, per reference area dω)::

    U = ∫ (1-ν) |a - a°|² + ν tr²(a - a°)
      + (h²/3) ∫ (1-ν) |b - b̄|² + ν tr²(b - b̄)          b̄ = b° + κ a°
      + ∫ c_s |γ|²                                           (Kirchhoff-Love penalty)
      + 8 (1-ν²) (p/E) / h ∫ u·n°                            (optional dead pressure, Eq. 5)

Up to the constant (h²/3) 2(1+ν) κ² A this is U_s^K + (h²/3) U_b^K + P_κ with the curvature
potential P_κ = -(2(1+ν)/3) h² κ ∫ tr(b - b°), the paper's Eq. (1).

Discretisation (frame-free, valid on closed surfaces; docs/model.md, "Discretisation"): the
unknown is w = (u, θ) in a blocked P2⁶ (or P3⁶) Lagrange space on the second-order surface mesh:
u the Cartesian displacement, θ a Cartesian director increment; d = v/|v| with v = A n° + θ (A
the identity but on the everted branch), so the director can rotate by any angle, and the term
∫ ((|v|² - 1)/2)² removes the null direction of θ. Reference quantities (a°, b°, γ°) use the
same formulas at w = 0, so the reference state is exactly stress-free.
``ModelParameters.director = "tangent"`` is the alternative chart d = normalize(n° + (I -
n°⊗n°) θ), limited to rotations below 90°; both charts give the same stability answer at an
equilibrium (docs/model.md, "Director charts").

Kirchhoff-Love limit: c_s = shear_penalty · (10/3)(1-ν), ``shear_penalty`` times the natural
Naghdi shear stiffness, since a shear-flexible model with natural curvature loses ellipticity
at κh = √3 (1-ν)/(1+ν), below the closed sphere's buckling (docs/model.md). Rigid motions are
removed by six point constraints, a gauge whose reactions vanish under self-equilibrated loads
(docs/model.md, "Rigid motions").

Residual and Hessian are ``ufl.derivative`` of this one energy; κ, h, ν, p are ``fem.Constant``
so continuation never recompiles a form.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.shapes import Shape
from shells.geometry.stimulus import UNIFORM, CurvatureField, field_radius
from shells.parameters import check_nu
from shells.problem.forms import FormProblem, assemble_symmetric
from shells.problem.interface import ModeInfo
from shells.surface.mesh import RIM_TAG, MeshSpec, ShellMesh, estimate_cap_cells

__all__ = ["ModelParameters", "ShellModel", "cap_default_size", "default_discretisation",
           "default_dofs", "sphere_default_size"]


#: caps deeper than this θ̄ = θ/√(h/R) get P3 by default (P2 locks on deep shells)
P2_THETABAR_MAX = 3.0
#: a closed sphere's default P3 mesh has at least this many elements per wavelength 2πR/n of
#: its critical degree n (``shells.theory.sphere_mode_n``). κ_b against the 1D model's: h/R =
#: 0.05 at size 0.21 (3.55 per wavelength) +0.57 %, at 0.15 (4.97) +0.22 %; h/R = 0.02 at
#: 0.132 (3.5) +0.67 %; h/R = 0.01 at 0.21 (1.54) +5.8 % (benchmarks/surface_defaults.py,
#: docs/model.md). The error falls as the elements per wavelength to the power 2.8: 4.25 keeps
#: it near 0.4 %
SPHERE_ELEMENTS_PER_WAVELENGTH = 4.25
#: the error a sphere's default discretisation is meant to stay within, relative in κ_b
SPHERE_DEFAULT_ERROR = 5.0e-3
#: P3 DOFs of the sphere mesh per 1/size² (20,748 at size 0.21)
SPHERE_P3_DOFS = 20748 * 0.21**2
#: a default surface mesh above this many DOFs is refused (``default_discretisation``)
MAX_DEFAULT_DOFS = 150_000
#: a spherical cap's default bulk size / R at h/R ≥ ``CAP_SIZE_H_OVER_R``: P3 caps (θ̄ above
#: ``P2_THETABAR_MAX``) and P2 caps
DEEP_CAP_SIZE = 0.2
SHALLOW_CAP_SIZE = 0.1
#: below this h/R a cap's default bulk size falls as √(h/R), so that in units of the rim layer's
#: width √(Rh) every default cap mesh is at least as fine as at this h/R, where the defaults were
#: measured (the rim band of ``shells.surface.mesh`` scales with √(Rh) already)
CAP_SIZE_H_OVER_R = 0.04
#: the error a spherical cap's default discretisation is meant to stay within, relative in κ
#: (measured errors: docs/design-notes.md, "Surface model defaults")
CAP_DEFAULT_ERROR = 5.0e-3
#: a state has an orbit about the axis where ‖∂w/∂φ‖ ≥ ORBIT_MIN ‖w‖ for its normal
#: displacement w (L² norms by quadrature): a pattern of m lobes and relative amplitude a has
#: about m a; an axisymmetric state only its discretisation's departure from symmetry
ORBIT_MIN = 1.0e-2


def default_discretisation(shape: Shape, h_over_r: float | None = None,
                           degree: int | None = None, size: float | None = None,
                           kappa_field: CurvatureField | None = None,
                           nu: float = 0.5) -> tuple[int, float]:
    """The element degree and bulk mesh size / R that give right answers on ``shape``.

    Closed spheres with a given h/R: P3, the size following the critical degree n(h/R, ν) of
    ``shells.theory.sphere_mode_n``, at most 0.21 and at least ``SPHERE_ELEMENTS_PER_WAVELENGTH``
    elements per wavelength 2πR/n (κ_b meant within ``SPHERE_DEFAULT_ERROR``); where that needs
    more than ``MAX_DEFAULT_DOFS`` (h/R below about 0.011 at ν = 1/2) the default is refused
    with the 1D model and the explicit options as the ways on.

    P2 with the stiff Kirchhoff-Love penalty locks on deep shells (bending-dominated states of
    a curved surface), so: closed spheres P3 (an explicit degree 2 is refused);
    caps of θ̄ ≤ 3 and the flat disk P2 at size 0.1; deeper caps, ellipsoids, tori, meridian
    tables and surfaces known only by their mesh P3 at size 0.2 (a closed meridian table as a
    sphere); a non-uniform ``kappa_field`` P3 on every shape.

    Spherical caps with a given h/R: those sizes down to h/R = ``CAP_SIZE_H_OVER_R``, below it
    shrinking as √(h/R) (``cap_default_size``), so that with the rim band of
    ``shells.surface.mesh`` (size √(Rh)/4 within 3 √(Rh) of the rim) a cap of given θ̄ is meshed
    alike in units of √(Rh) at every h/R (κ meant within ``CAP_DEFAULT_ERROR``); where that
    needs more than ``MAX_DEFAULT_DOFS`` (``default_dofs``: P3 caps of θ̄ above about 8 at
    h/R ≤ 0.01) the default is refused with the 1D model and the explicit options as the ways
    on. The errors of each choice against the 1D model: docs/design-notes.md, "Surface model
    defaults".

    Args:
        shape: the shell.
        h_over_r: thickness over the shape's length scale (decides θ̄ of a spherical cap).
        degree: a degree the caller chose (None: the default).
        size: a size the caller chose (None: the default).
        kappa_field: the stimulus (None: uniform).
        nu: Poisson's ratio (the sphere's critical degree).

    Returns:
        (degree, size).

    Raises:
        InputError: for degree 2 on a closed sphere, or a default sphere or spherical cap mesh
            beyond ``MAX_DEFAULT_DOFS``.
    """
    from shells.geometry.meridian import MeridianTable
    from shells.geometry.shapes import EllipsoidalCap, SphericalCap, Torus

    sphere = shape.closed and shape.kind in ("sphere", "meridian")
    if sphere and degree == 2:
        raise InputError("P2 locks on a closed sphere (kappa_b h 1.56-1.71 against a converged "
                         "1.484 at h/R = 0.05, docs/model.md): use --degree 3 (the default)")
    deep = isinstance(shape, (EllipsoidalCap, MeridianTable, Torus)) or not shape.of_revolution or (
        isinstance(shape, SphericalCap) and not sphere and h_over_r is not None
        and shape.theta / math.sqrt(h_over_r) > P2_THETABAR_MAX)
    patterned = kappa_field is not None and not kappa_field.uniform
    if degree is None:
        degree = 3 if sphere or deep or patterned else 2
    if size is None:
        size = 0.21 if sphere else DEEP_CAP_SIZE if deep else SHALLOW_CAP_SIZE
        if isinstance(shape, SphericalCap) and not sphere and h_over_r is not None:
            size = cap_default_size(h_over_r, deep)
            dofs = default_dofs(shape, h_over_r, degree, size)
            if dofs > MAX_DEFAULT_DOFS:
                raise InputError(
                    f"the surface model's default mesh for a spherical cap of theta/sqrt(h/R) = "
                    f"{shape.theta / math.sqrt(h_over_r):.3g} at h/R = {h_over_r:g} needs about "
                    f"{dofs:,.0f} DOFs (P{degree} at size {size:.3f}, the rim graded to "
                    f"sqrt(R h)/4), above {MAX_DEFAULT_DOFS:,}: use --model axisym (the 1D "
                    f"model), or give --size {size:.3f} --degree {degree} to run it anyway")
        if sphere and h_over_r is not None:
            size = min(size, sphere_default_size(h_over_r, nu))
            dofs = SPHERE_P3_DOFS / size**2 * (degree / 3.0) ** 2
            if dofs > MAX_DEFAULT_DOFS:
                raise InputError(
                    f"the surface model's default mesh for a closed sphere of h/R = "
                    f"{h_over_r:g} needs about {dofs:,.0f} DOFs (P{degree} at size {size:.3f}, "
                    f"{SPHERE_ELEMENTS_PER_WAVELENGTH:g} elements per wavelength of the "
                    f"critical degree n = {sphere_mode_n(h_over_r, nu):.0f}), above "
                    f"{MAX_DEFAULT_DOFS:,}: use --model axisym (the 1D model), or give "
                    f"--size {size:.3f} --degree 3 to run it anyway")
    return degree, size


def cap_default_size(h_over_r: float, deep: bool) -> float:
    """A spherical cap's default bulk size / R: ``DEEP_CAP_SIZE`` (P3 caps) or
    ``SHALLOW_CAP_SIZE`` (P2 caps), times √(h/R / ``CAP_SIZE_H_OVER_R``) below that h/R, so the
    bulk size in units of the rim layer's width √(Rh) does not grow as the shell thins."""
    base = DEEP_CAP_SIZE if deep else SHALLOW_CAP_SIZE
    return base * min(1.0, math.sqrt(h_over_r / CAP_SIZE_H_OVER_R))


def default_dofs(shape: Shape, h_over_r: float, degree: int, size: float,
                 layer_elements: float = 4.0) -> float:
    """The DOFs of the surface model on the mesh ``shells critical`` makes of a spherical cap:
    six fields of Lagrange degree ``degree`` on triangles (about degree²/2 nodes each) over
    ``shells.surface.mesh.estimate_cap_cells``.

    Args:
        shape: a ``SphericalCap``.
        h_over_r: thickness over R.
        degree: the element degree.
        size: the bulk size / R.
        layer_elements: elements across the rim layer's width √(Rh).

    Returns:
        The estimate.
    """
    spec = MeshSpec(shape, h=h_over_r * shape.characteristic_size(), size=size,
                    layer_elements=layer_elements)
    return 3.0 * degree**2 * estimate_cap_cells(spec)


def sphere_mode_n(h_over_r: float, nu: float) -> float:
    """The closed sphere's critical degree (``shells.theory.sphere_mode_n``); for ν < 0, where
    its formula loses meaning at ν ≤ -1/2, that of ν = 0 (an estimate only)."""
    from shells.theory import sphere_mode_n as n

    return n(h_over_r, max(nu, 0.0))


def sphere_default_size(h_over_r: float, nu: float = 0.5) -> float:
    """The bulk size / R that puts ``SPHERE_ELEMENTS_PER_WAVELENGTH`` elements on the
    wavelength 2πR/n of the closed sphere's critical degree n(h/R, ν)."""
    return 2.0 * math.pi / (sphere_mode_n(h_over_r, nu) * SPHERE_ELEMENTS_PER_WAVELENGTH)


@dataclass(frozen=True)
class ModelParameters:
    """Material and discretisation parameters of the surface model.

    Attributes:
        h: shell thickness (absolute, in the mesh's length unit).
        nu: Poisson ratio, in (-1, 1/2].
        shear_penalty: multiple of the natural Naghdi shear stiffness (Kirchhoff-Love limit).
        degree: polynomial degree of u and θ.
        quadrature_degree: quadrature degree of the energy (full integration).
        director: ``"free"`` (d = v/|v|, v = A n° + θ: rotations of any size) or ``"tangent"``
            (d = normalize(n° + (I - n°⊗n°) θ): rotations below 90°).
        kappa_field: the natural-curvature stimulus K of b̄ = b° + κ K
            (``shells.geometry.stimulus``; the default is the paper's K = a°).
    """

    h: float
    nu: float = 0.5
    shear_penalty: float = 1.0e3
    degree: int = 2
    quadrature_degree: int = 4
    director: str = "free"
    kappa_field: CurvatureField = UNIFORM

    def __post_init__(self) -> None:
        if not (isinstance(self.h, (int, float)) and math.isfinite(self.h) and self.h > 0):
            raise InputError(f"thickness h must be positive, got {self.h!r}")
        if not isinstance(self.kappa_field, CurvatureField):
            raise InputError(f"kappa_field must be a CurvatureField, got {self.kappa_field!r}")
        check_nu(self.nu, "Poisson ratio nu")
        if not self.shear_penalty > 0:
            raise InputError(f"shear_penalty must be positive, got {self.shear_penalty!r}")
        if self.degree not in (1, 2, 3):
            raise InputError(f"degree must be 1, 2 or 3, got {self.degree!r}")
        if self.director not in ("free", "tangent"):
            raise InputError(f"director must be 'free' or 'tangent', got {self.director!r}")


@dataclass
class ShellModel(FormProblem):
    """Surface shell model: spaces, the energy and its derivatives, supports and functionals.

    A ``shells.problem.interface.Problem``: assembly from ``FormProblem``; one stability block
    (``None``, the Hessian) with the L² mass of (u, θ); modes classified by the Rayleigh quotients
    of their normal component (``classify_mode``).
    """

    shell: ShellMesh
    params: ModelParameters
    kappa: Any = field(init=False)
    pressure: Any = field(init=False)

    def __post_init__(self) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        if self.shell.shape is None:
            raise InputError("the surface model needs the mesh's analytic shape (a mesh made by "
                             "`shells mesh`, with its .msh.json sidecar)")
        mesh = self.shell.mesh
        self.shape: Shape = self.shell.shape
        p = self.params
        el = basix.ufl.element("Lagrange", mesh.basix_cell(), p.degree, shape=(6,))
        self.W = fem.functionspace(mesh, el)
        self.w = fem.Function(self.W, name="state")
        self.kappa = fem.Constant(mesh, default_scalar_type(0.0))
        # the director chart: base A (v = A n° + θ) and the sign of the reference shear, the
        # identity and +1, or the mirror -M and -1 (set_everted_guess)
        self.director_base = fem.Constant(mesh, np.eye(3, dtype=default_scalar_type))
        self.shear_sign = fem.Constant(mesh, default_scalar_type(1.0))
        self.pressure = fem.Constant(mesh, default_scalar_type(0.0))
        self.h = fem.Constant(mesh, default_scalar_type(p.h))
        self.nu = fem.Constant(mesh, default_scalar_type(p.nu))
        self.c_shear = fem.Constant(mesh, default_scalar_type(p.shear_penalty * 10.0 / 3.0
                                                              * (1.0 - p.nu)))
        self.dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree":
                                                           p.quadrature_degree})
        ft = self.shell.facet_tags
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft,
                              metadata={"quadrature_degree": p.quadrature_degree})
        self._x = ufl.SpatialCoordinate(mesh)
        self.n0 = (self.shape.normal_ufl(self._x) if self.shape.has_ufl_normal
                   else self._interpolated_normal())
        if not self.shape.of_revolution and self.shell.comm.rank == 0:
            logging.getLogger("shells").info(
                "the mesh is not of revolution about z, nor a torus: its normal and curvatures "
                "are fitted at its nodes (R = 1 / mean |H| = %.6g; no azimuthal mode numbers)",
                self.shape.R)
        J = ufl.Jacobian(mesh)
        self.P0 = J * ufl.JacobianInverse(mesh)
        p.kappa_field.check_on(self.shape)
        self.K = self._natural_tensor()
        self._build_forms()
        self.bcs = self._supports()

    def _interpolated_normal(self) -> Any:
        """The reference normal of a shape without a closed form (a meridian table), its
        ``normal`` interpolated in Lagrange of one degree above the state's: b° = -∇n° then
        errs by O(size^(degree+1)) against the O(size^degree) of the state's own
        approximation."""
        from dolfinx import fem

        mesh = self.shell.mesh
        V = fem.functionspace(mesh, ("Lagrange", self.params.degree + 1, (3,)))
        n0 = fem.Function(V, name="reference_normal")
        n0.interpolate(self.shape.normal)
        return n0

    def owned_dof_coordinates(self) -> np.ndarray:
        """Coordinates of this rank's owned DOF nodes (each carries 6 values: u, θ)."""
        return self.W.tabulate_dof_coordinates()[: self.W.dofmap.index_map.size_local]

    # ------------------------------------------------------------------------------------------
    # kinematics
    # ------------------------------------------------------------------------------------------
    @staticmethod
    def split(w: Any) -> tuple[Any, Any]:
        """(u, θ) of a state ``w`` in the blocked space, as UFL vectors."""
        import ufl

        return ufl.as_vector([w[0], w[1], w[2]]), ufl.as_vector([w[3], w[4], w[5]])

    def kinematics(self, w: Any) -> dict[str, Any]:
        """Metric a, curvature b, shear γ, director d of the state w (UFL)."""
        import ufl

        u, th = self.split(w)
        n0, P0 = self.n0, self.P0
        F = P0 + ufl.grad(u)
        if self.params.director == "free":
            v = self.director_base * n0 + th
            gauge = 0.25 * (ufl.dot(v, v) - 1.0) ** 2
        else:
            v = n0 + th - ufl.dot(th, n0) * n0
            gauge = ufl.dot(th, n0) ** 2
        d = v / ufl.sqrt(ufl.dot(v, v))
        grad_d = ufl.grad(d) * P0
        b = -0.5 * (F.T * grad_d + grad_d.T * F)
        return {"u": u, "theta": th, "F": F, "a": F.T * F, "b": b, "gamma": F.T * d, "d": d,
                "gauge": gauge}

    def reference(self) -> dict[str, Any]:
        """a°, b°, γ° from the same formulas at w = 0.

        γ° = P°ᵀ n° is not exactly 0: the analytic normal is not exactly normal to the
        second-order mesh (an angle O(size²)), and the stiff shear term must not see that as
        strain. On the mirror chart (``set_everted_guess``) the base state is the mirrored
        reference surface with the mirrored director -M n°, whose shear is -γ°: each chart's
        base state is shear-free, and the discrete problem is exactly mirror-symmetric.
        """
        import ufl

        n0, P0 = self.n0, self.P0
        if self.shape.closed or np.isfinite(self.shape.R) or self.shape.kind != "disk":
            grad_n = ufl.grad(n0) * P0
        else:  # the disk's constant normal carries no mesh for ufl.grad
            grad_n = ufl.as_matrix([[0.0] * 3] * 3) * P0
        b0 = -0.5 * (P0.T * grad_n + grad_n.T * P0)
        return {"a": P0.T * P0, "b": b0, "gamma": self.shear_sign * (P0.T * n0)}

    def _natural_tensor(self) -> Any:
        """K of b̄ = b° + κ K: a° (= P°) for the paper's stimulus, else f (f1 e1⊗e1 + f2 e2⊗e2)
        = f (f1 P° + (f2 - f1) e2⊗e2), e2 the parallel's direction projected on the mesh's
        tangent plane (no quadrature point lies on the axis, where e2 is undefined). f is a
        Lagrange function of the model's degree, (f1, f2) Constants: one kernel for every field."""
        import ufl
        from dolfinx import default_scalar_type, fem

        fld = self.params.kappa_field
        if fld.uniform:
            return self.P0
        mesh = self.shell.mesh
        self.kappa_f = fld.interpolate(fem.functionspace(mesh, ("Lagrange", self.params.degree)),
                                       lambda p: (p[0], p[1], p[2]), field_radius(self.shape))
        self.kappa_anisotropy = fem.Constant(mesh, np.array(fld.anisotropy,
                                                            dtype=default_scalar_type))
        f1, f2 = self.kappa_anisotropy[0], self.kappa_anisotropy[1]
        x = self._x
        rho = ufl.sqrt(x[0] ** 2 + x[1] ** 2)
        e2 = self.P0 * ufl.as_vector([-x[1] / rho, x[0] / rho, 0.0])
        e2 = e2 / ufl.sqrt(ufl.dot(e2, e2))
        return self.kappa_f * (f1 * self.P0 + (f2 - f1) * ufl.outer(e2, e2))

    def _quad(self, A: Any) -> Any:
        """(1-ν) tr(A²) + ν tr²(A) for a symmetric tangential tensor A."""
        import ufl

        return (1 - self.nu) * ufl.inner(A, A) + self.nu * ufl.tr(A) ** 2

    def energy_density(self, w: Any) -> dict[str, Any]:
        """Densities of every energy term (UFL); ``total`` is what is minimised."""
        import ufl

        k, r = self.kinematics(w), self.reference()
        Ea = k["a"] - r["a"]
        Eb = k["b"] - r["b"]
        bbar_gap = Eb - self.kappa * self.K  # b - b̄
        u = k["u"]
        stretch = self._quad(Ea)
        bend_nat = self.h**2 / 3 * self._quad(bbar_gap)
        shear = self.c_shear * ufl.dot(k["gamma"] - r["gamma"], k["gamma"] - r["gamma"])
        gauge = k["gauge"]
        load = 8 * (1 - self.nu**2) * self.pressure / self.h * ufl.dot(u, self.n0)
        return {
            "total": stretch + bend_nat + shear + gauge + load,
            "stretching": stretch,
            "bending": self.h**2 / 3 * self._quad(Eb),              # (h²/3) U_b^K density
            "curvature_potential": self._curvature_potential(Eb),
            "shear": shear,
            "pressure_work": load,
        }

    def _curvature_potential(self, Eb: Any) -> Any:
        """P_κ's density, the part of the natural bending energy linear in b - b°:
        -(2/3) h² κ [(1-ν) K:(b-b°) + ν tr K tr(b-b°)], i.e. -(2/3)(1+ν) h² κ tr(b-b°) for
        K = a°."""
        import ufl

        if self.params.kappa_field.uniform:
            return -2 * (1 + self.nu) / 3 * self.h**2 * self.kappa * ufl.tr(Eb)
        K = self.K
        return -2 / 3 * self.h**2 * self.kappa * ((1 - self.nu) * ufl.inner(K, Eb)
                                                  + self.nu * ufl.tr(K) * ufl.tr(Eb))

    # ------------------------------------------------------------------------------------------
    # forms
    # ------------------------------------------------------------------------------------------
    def _build_forms(self) -> None:
        import ufl
        from dolfinx import fem

        dens = self.energy_density(self.w)
        self._derive_forms(dens["total"] * self.dx)
        self._scalar_forms = {k: fem.form(v * self.dx) for k, v in dens.items()}
        u, _ = self.split(self.w)
        self._scalar_forms["psi3_integral"] = fem.form(ufl.dot(u, self.n0) * self.dx)
        for i in range(3):
            self._scalar_forms[f"u{i}_integral"] = fem.form(u[i] * self.dx)
            self._scalar_forms[f"n{i}_integral"] = fem.form(self.n0[i] * self.dx)
        self._scalar_forms["area"] = fem.form(fem.Constant(self.shell.mesh, 1.0) * self.dx)
        self._scalar_forms.update(self._work_forms())
        if not self.shape.closed and self.shell.facet_tags is not None:
            # the director's rotation from the reference normal, averaged over the rim: a snapped
            # cap turns its rim by about twice its opening angle
            cos_rot = ufl.max_value(-1.0, ufl.min_value(1.0, ufl.dot(self.kinematics(self.w)["d"],
                                                                     self.n0)))
            self._scalar_forms["rim_rotation"] = fem.form(ufl.acos(cos_rot) * self.ds(RIM_TAG))
            self._scalar_forms["rim_length"] = fem.form(
                fem.Constant(self.shell.mesh, 1.0) * self.ds(RIM_TAG))
        # metric for eigenproblems: L2 mass of u and θ (SPD)
        dw, w_ = ufl.TestFunction(self.W), ufl.TrialFunction(self.W)
        self.mass = fem.form(ufl.inner(w_, dw) * self.dx)

    def _work_forms(self) -> dict[str, Any]:
        """Edge and bulk works of Eqs. (2a, 2b), linearised, on spherical surfaces."""
        import ufl
        from dolfinx import fem

        from shells.geometry.shapes import SphericalCap

        if not isinstance(self.shape, SphericalCap) or not self.params.kappa_field.uniform:
            return {}  # Eqs. (2a, 2b) are the works of a uniform natural curvature
        R = self.shape.R
        # W_bulk and W_edge separately change under a rigid translation of an open cap (only
        # their sum -P_kappa does not): they are evaluated on u minus its mean (set in scalars())
        self._u_shift = fem.Constant(self.shell.mesh, np.zeros(3))
        u = self.split(self.w)[0] - self._u_shift
        n0 = self.n0
        psi3 = ufl.dot(u, n0)
        psi_t = u - psi3 * n0
        out = {"W_bulk": fem.form(-4 * (1 + self.nu) / 3 * (self.h / R) ** 2 * self.kappa
                                  * psi3 * self.dx)}
        if not self.shape.closed and self.shell.facet_tags is not None:
            x = self._x
            rho = ufl.sqrt(x[0] ** 2 + x[1] ** 2)
            # outward conormal at the rim of a cap centred on z: e_theta
            t = ufl.as_vector([x[0] * x[2] / (rho * R), x[1] * x[2] / (rho * R), -rho / R])
            grad_psi3 = ufl.grad(psi3)
            q_minus = ufl.dot(grad_psi3, t) - 2 * ufl.dot(psi_t, t) / R  # (q - Ψ̌/R)·t
            out["W_edge"] = fem.form(2 * (1 + self.nu) / 3 * self.h**2 * self.kappa * q_minus
                                     * self.ds(RIM_TAG))
        return out

    # ------------------------------------------------------------------------------------------
    # supports
    # ------------------------------------------------------------------------------------------
    def _supports(self) -> list[Any]:
        """Six scalar constraints fixing the rigid motion exactly (a gauge, not a support).

        Translations: u = 0 at the pole/apex/centre A. Rotations, on curved shells: u_y = 0 at
        the points B (azimuth 0) and D (azimuth pi) and u_x = 0 at C (azimuth pi/2) of the
        parallel t = t_max/2 (``mesh.gauge_points``); on the flat disk: θ_x = θ_y = 0 at A (the
        director there stays e_z) and u_y = 0 at the rim node of azimuth 0. Without a pole (a
        torus): u_z = 0 at B, C and D instead of u = 0 at A (with those of B, C, D above: six
        independent constraints for any height of the parallel, z = 0 included).

        An axisymmetric state meets these with a translation only, so they constrain no
        deformation and no reaction arises, and Newton need not find a finite rotation (a gauge
        met only turned costs no energy but shortens the steps Newton converges from:
        ``_general_supports``).
        Displacement constraints are preferred to the director one because u carries membrane
        stiffness: a pointwise constraint on θ alone leaves the rotations nearly free (a point
        has no capacity in 2D), with spurious near-zero eigenvalues that fall as the mesh refines.
        """
        from mpi4py import MPI

        from shells.geometry.shapes import Disk
        from shells.surface.mesh import gauge_points

        comm = self.shell.comm
        x = self.owned_dof_coordinates()
        L = self.shape.characteristic_size()
        tol = 1e-9 * L

        def node(pt: np.ndarray, what: str) -> np.ndarray:
            # the node nearest the point: on shells' meshes a node lies there (distance 0);
            # a user's mesh has one nearby, and any point near it fixes the same rigid motions
            dist = np.linalg.norm(x - pt, axis=1)
            i = int(np.argmin(dist)) if len(dist) else -1
            best = comm.allreduce((float(dist[i]) if i >= 0 else math.inf, comm.rank),
                                  op=MPI.MINLOC)
            if not best[0] < 0.05 * L:
                raise InputError(f"the mesh has no node near the {what} {pt} (needed for the "
                                 "rigid-motion gauge)")
            return np.asarray(comm.bcast(x[i] if comm.rank == best[1] else None, root=best[1]))

        if not self.shape.of_revolution:
            return self._general_supports(node, tol)
        constraints = []
        if self.shape.has_pole:
            top = node(np.array([0.0, 0.0, float(self.shape.meridian(np.array(0.0))[1])]),
                       "pole")
            constraints = [(top, 0), (top, 1), (top, 2)]
        if isinstance(self.shape, Disk):
            rim_b = node(np.array([self.shape.radius, 0.0, 0.0]), "rim point")
            constraints += [(top, 3), (top, 4), (rim_b, 1)]
            self.support_points = [top, rim_b]
        else:
            pb, pc, pd = (np.array(p) for p in gauge_points(self.shape))
            C, D = node(pc, "gauge point"), node(pd, "gauge point")
            # B: any node of the azimuth-0 meridian (the OCC seam) will do; take the nearest
            seam = (np.abs(x[:, 1]) < tol) & (x[:, 0] > 1e-3 * L)
            dist = np.linalg.norm(x[seam] - pb, axis=1) if seam.any() else np.array([np.inf])
            best = comm.allreduce((float(dist.min()), comm.rank), op=MPI.MINLOC)
            if math.isfinite(best[0]):
                B = np.asarray(comm.bcast(x[seam][np.argmin(dist)] if comm.rank == best[1]
                                          else None, root=best[1]))
            else:  # a user's mesh, no node on that meridian: the nearest one
                B = node(pb, "gauge point")
            constraints += [(B, 1), (D, 1), (C, 0)]
            if self.shape.has_pole:
                self.support_points = [top, B, C, D]
            else:
                # no pole (a torus): u_z at B, C, D fixes the translation along z and the two
                # tilts instead; an axisymmetric state has equal u_z there, a translation
                constraints += [(B, 2), (C, 2), (D, 2)]
                self.support_points = [B, C, D]
        return self._point_bcs(constraints, tol)

    def _general_supports(self, node: Any, tol: float) -> list[Any]:
        """The gauge of a surface known only by its mesh (``shells.surface.gauge.mesh_gauge``:
        the caps' azimuthal gauge about the vertical through the highest node where it fixes
        the rotations well, else a 3-2-1 gauge)."""
        from shells.surface.gauge import mesh_gauge

        gauge = mesh_gauge(self.shape.nodes)
        pts = [node(p, "gauge point") for p in gauge.points]
        self.support_points = pts
        return self._point_bcs([(pts[i], comp) for i, comp in gauge.constraints], tol)

    def _point_bcs(self, constraints: list[tuple[np.ndarray, int]], tol: float) -> list[Any]:
        """u_comp = 0 at each (point, comp) of ``constraints`` (a DOF node at each point)."""
        from dolfinx import fem

        bcs = []
        for pt, comp in constraints:
            sub = self.W.sub(comp)
            Vc, _ = sub.collapse()
            dofs = fem.locate_dofs_geometrical(
                (sub, Vc), lambda xx, pt=pt: np.linalg.norm(xx.T - pt, axis=1) < tol)
            bcs.append(fem.dirichletbc(fem.Function(Vc), dofs, sub))
        return bcs

    # ------------------------------------------------------------------------------------------
    # scalars
    # ------------------------------------------------------------------------------------------
    def assemble(self, name: str) -> float:
        """The scalar functional ``name`` (energy parts, integrals) at the current state."""
        from dolfinx import fem
        from mpi4py import MPI

        local = fem.assemble_scalar(self._scalar_forms[name])
        return float(self.shell.comm.allreduce(local, op=MPI.SUM))

    def total_energy(self) -> float:
        """The energy whose gradient is the residual, at the current state (``Energy``)."""
        return self.assemble("total")

    def scalars(self) -> dict[str, float]:
        """Scalar indicators of the current state, free of its translation; the rotation is
        the gauge's (a state without axial symmetry reads otherwise in its best-fit frame:
        evaluate them inside ``rigid_frame().aligned()``, as the snap's landing does)."""
        out = {k: self.assemble(k) for k in ("total", "stretching", "bending",
                                             "curvature_potential", "shear")}
        out["energy"] = out.pop("total")
        area = self.assemble("area")
        # mean normal displacement with the mean translation removed (rigid-motion free; on a
        # closed surface the translation integrates to zero anyway)
        mean_u = np.array([self.assemble(f"u{i}_integral") for i in range(3)]) / area
        mean_n = np.array([self.assemble(f"n{i}_integral") for i in range(3)]) / area
        psi3 = self.assemble("psi3_integral") / area - float(mean_u @ mean_n)
        h = float(self.h.value)
        out["psi3_over_h"] = psi3 / h
        out.update(self._apex(float(mean_u[2])))
        if "rim_rotation" in self._scalar_forms:
            out["rim_rotation_deg"] = math.degrees(self.assemble("rim_rotation")
                                                   / self.assemble("rim_length"))
        if "W_bulk" in self._scalar_forms:
            self._u_shift.value[:] = mean_u
            for k in ("W_bulk", "W_edge"):
                if k in self._scalar_forms:
                    out[k] = self.assemble(k)
        return out

    def _apex(self, mean_uz: float) -> dict[str, float]:
        """Apex displacement along z, free of rigid motion, and the pole's normal displacement.

        ``apex_uz_over_h``: closed surfaces: half the change of the pole-to-pole distance (a
        torus: of the tube's height at azimuth 0, top to bottom); open
        shells: apex u_z minus the mean u_z of the rim nodes. ``psi3_pole_over_h``: (u_z(pole) -
        ū_z)/h with ū the mean displacement (the pole's normal is e_z), as the 1D model's.
        """
        from mpi4py import MPI

        comm = self.shell.comm
        x = self.owned_dof_coordinates()
        n_owned = x.shape[0]
        arr = self.w.x.array.reshape(-1, 6)[:n_owned]
        tol = 1e-8 * self.shape.characteristic_size()
        if not self.shape.of_revolution:  # its highest node, against the mean
            top = self.shape.nodes[int(np.argmax(self.shape.nodes[:, 2]))]
        else:  # the pole; without one (a torus) the meridian's top at azimuth 0 (a mesh node)
            r_top, z_top = (float(v) for v in self.shape.meridian(np.array(0.0)))
            top = np.array([r_top, 0.0, z_top])

        def value_at(pt: np.ndarray) -> float:
            hit = np.linalg.norm(x - pt, axis=1) < tol
            val = float(arr[hit, 2][0]) if hit.any() else 0.0
            cnt = int(hit.any())
            val, cnt = comm.allreduce(val, op=MPI.SUM), comm.allreduce(cnt, op=MPI.SUM)
            return val / cnt if cnt else math.nan

        uz_top = value_at(top)
        if not self.shape.of_revolution:
            disp = uz_top - mean_uz
        elif self.shape.closed:
            r_b, z_b = (float(v) for v in self.shape.meridian(np.array(math.pi)))
            bottom = np.array([r_b, 0.0, z_b])
            disp = 0.5 * (uz_top - value_at(bottom))
        else:
            r_rim, z_rim = self.shape.meridian(np.array(self.shape.t_max))
            rho = np.hypot(x[:, 0], x[:, 1])
            on_rim = (np.abs(rho - float(r_rim)) < 1e-6) & (np.abs(x[:, 2] - float(z_rim)) < 1e-6)
            s = comm.allreduce(float(arr[on_rim, 2].sum()), op=MPI.SUM)
            c = comm.allreduce(int(on_rim.sum()), op=MPI.SUM)
            disp = uz_top - (s / c if c else 0.0)
        h = float(self.h.value)
        return {"apex_uz_over_h": disp / h, "psi3_pole_over_h": (uz_top - mean_uz) / h}

    def pole_functional(self) -> Any:
        """The state-shaped vector e with e·w = Ψ3(pole)/h, the ``psi3_pole_over_h`` of
        ``scalars`` on a shape of revolution with a pole: (u_z(pole) - ū_z)/h, ū_z = ∫ u_z dA / A
        (linear in w; the pole node's u_z once, on the rank that owns it)."""
        import ufl
        from dolfinx import fem
        from dolfinx.fem.petsc import assemble_vector
        from petsc4py import PETSc

        if not (self.shape.of_revolution and getattr(self.shape, "has_pole", True)):
            raise InputError("the pole's depth needs a shape of revolution with a pole")
        v = ufl.TestFunction(self.W)
        e = assemble_vector(fem.form(v[2] * self.dx))
        e.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        e.scale(-1.0 / self.assemble("area"))
        r_top, z_top = (float(c) for c in self.shape.meridian(np.array(0.0)))
        x = self.owned_dof_coordinates()
        tol = 1e-8 * self.shape.characteristic_size()
        hit = np.nonzero(np.linalg.norm(x - np.array([r_top, 0.0, z_top]), axis=1) < tol)[0]
        if self.shell.comm.allreduce(min(len(hit), 1)) == 0:
            raise InputError("the mesh has no node at the pole: its depth is not defined")
        arr = e.getArray()  # owned values, 6 per node (u, θ)
        arr[hit[:1] * 6 + 2] += 1.0
        e.setArray(arr)
        e.scale(1.0 / float(self.h.value))
        return e

    def pole_moments(self) -> list[Any]:
        """Two state-shaped vectors e_x, e_y with e_a·w = ∫ (u·n°) x_a dA / (A h): the first
        moments of the normal displacement about the axis, where a dimple at the pole has its
        centre. Held fixed, they stop the dimple sliding over a closed sphere (its orbit of
        rotations, neutral: a phase condition, ``switch_branch``'s ``phase``) without
        constraining the dimple itself or a pattern m ≥ 2 about the pole (their moments
        vanish)."""
        import ufl
        from dolfinx import fem
        from dolfinx.fem.petsc import assemble_vector
        from petsc4py import PETSc

        u_n = ufl.dot(self.split(ufl.TestFunction(self.W))[0], self.n0)
        scale = 1.0 / (self.assemble("area") * float(self.h.value))
        out = []
        for a in (0, 1):
            e = assemble_vector(fem.form(u_n * self._x[a] * self.dx))
            e.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            e.scale(scale)
            self.zero_constrained(e)
            out.append(e)
        return out

    def set_everted_guess(self) -> None:
        """Set the state to the open shell mirrored through its rim plane (an isometry).

        u = (0, 0, 2(z_rim - z)) and the director keeps the material orientation, d = -M n° =
        (-n_x, -n_y, n_z) with M the mirror (unchanged at the pole, rotated by twice the rim
        angle at the rim). With the free director this is the mirror chart: director base
        A = -M, reference shear -γ° (``reference``) and θ = 0; the mirror maps the original
        chart's states onto it exactly, so its equilibrium at κ is the image of the original
        one at 2/R - κ on sphere caps, up to the mesh's departure from the sphere (b° ≠ -a°/R by
        O(size³): energies 3-4e-6 apart at size 0.2, docs/model.md). The tangent chart
        represents the mirror only for caps below 45° (θ = d/(d·n°) - n°). A Newton start for
        the everted (snapped) branch, which continuation from κ = 0 reaches only through two
        folds.
        """
        import ufl
        from dolfinx import fem

        if self.shape.closed:
            raise InputError("a closed shell has no rim plane to evert through")
        z_rim = float(self.shape.meridian(np.array(self.shape.t_max))[1])
        x, n0 = self._x, self.n0
        zero = 0.0 * x[0]
        if self.params.director == "free":
            self.director_base.value[:] = np.diag([-1.0, -1.0, 1.0])
            self.shear_sign.value = -1.0
            th = ufl.as_vector([zero, zero, zero])
        else:
            d = ufl.as_vector([-n0[0], -n0[1], n0[2]])
            th = d / ufl.dot(d, n0) - n0
        e = ufl.as_vector([zero, zero, 2 * (z_rim - x[2]), th[0], th[1], th[2]])
        self.w.interpolate(fem.Expression(e, self.W.element.interpolation_points()))
        self.w.x.scatter_forward()

    def num_dofs(self) -> int:
        """The global number of unknowns."""
        im = self.W.dofmap.index_map
        return int(im.size_global * self.W.dofmap.index_map_bs)

    # ------------------------------------------------------------------------------------------
    # stability blocks and modes (shells.problem.interface.Problem)
    # ------------------------------------------------------------------------------------------
    def stability_blocks(self) -> tuple[None]:
        """One block, ``None``: the Hessian (``Problem.stability_blocks``)."""
        return (None,)

    def block_layout(self, block: Any) -> None:
        """The one layout (``Problem.block_layout``)."""
        return None

    def create_hessian(self, block: Any) -> Any:
        """A matrix of the Hessian's pattern (the Jacobian's)."""
        return self.create_jacobian()

    def assemble_hessian(self, block: Any, H: Any) -> None:
        """The Hessian at the current state into ``H``, the gauge's rows as unit rows."""
        assemble_symmetric(H, self.hessian, self.bcs)

    def assemble_mass(self, block: Any) -> Any:
        """The L² mass of u and θ (``Problem.assemble_mass``)."""
        return self._assemble_mass(self.mass, self.bcs)

    def assemble_kinetic_mass(self, block: Any = None) -> Any:
        """The kinetic mass of the free shell (``shells.problem.interface.KineticMass``).

        T = ½ ∫ ρh (|u̇|² + (h²/12) |θ̇|²) dA over E h / (8 (1 - ν²)) with time in units of
        L √(ρ/E): M = (8 (1 - ν²) / L²) ∫ (u·δu + (h²/12) θ·δθ) dA. With the free director
        d = v/|v|, v = A n° + θ, and |v| = 1 (the chart's gauge term), ḋ = (I - d⊗d) θ̇, so
        |θ̇|² = |ḋ|² + (d·θ̇)²: the director's rotary inertia plus that of the chart's null
        direction, which no elastic term couples to at an equilibrium (its own stiffness is
        the gauge term's), so it adds a stiff decoupled mode and leaves the elastic ones. A
        constant matrix. Rigid motions removed (``shells.problem.kinetic.free_body_mass``,
        with ``rigid_motions``), the gauge's DOFs as in ``assemble_mass``."""
        from dolfinx.fem.petsc import assemble_matrix

        from shells.problem.kinetic import free_body_mass

        if not hasattr(self, "_kinetic_form"):
            import ufl
            from dolfinx import fem

            L = self.shape.characteristic_size()
            (u, th), (du, dth) = (self.split(a) for a in (ufl.TrialFunction(self.W),
                                                         ufl.TestFunction(self.W)))
            c = 8 * (1 - self.nu**2) / L**2
            self._kinetic_form = fem.form(
                c * (ufl.dot(u, du) + self.h**2 / 12 * ufl.dot(th, dth)) * self.dx)
        M = self._assemble_mass(self._kinetic_form, self.bcs)
        M_full = assemble_matrix(self._kinetic_form)
        M_full.assemble()
        self._free_body = {None: free_body_mass(M, M_full, self.rigid_motions(),
                                                self.zero_constrained)}
        return self._free_body[None].mass

    def free_motion(self, block: Any, v: Any) -> Any:
        """v minus its rigid part (``shells.problem.interface.KineticMass``)."""
        return self._free_body[None].free_part(v)

    def rigid_motions(self) -> list[Any]:
        """The six infinitesimal rigid motions of the current state (state-shaped vectors,
        gauge DOFs included): translations u = e_i, θ = 0, and rotations u = e_i × (x + u),
        θ = e_i × v (v = A n° + θ, the director's unnormalised vector: the rotated director)."""
        if not hasattr(self, "_rigid"):
            import ufl
            from dolfinx import default_scalar_type, fem

            mesh = self.shell.mesh
            e = fem.Constant(mesh, np.zeros(3, dtype=default_scalar_type))  # the axis
            t = fem.Constant(mesh, default_scalar_type(0.0))  # 1: translation, 0: rotation
            u, th = self.split(self.w)
            a, b = ufl.cross(e, self._x + u), ufl.cross(e, self.director_base * self.n0 + th)
            ex = ufl.as_vector([t * e[i] + (1 - t) * a[i] for i in range(3)]
                               + [(1 - t) * b[i] for i in range(3)])
            self._rigid = (e, t, fem.Expression(ex, self.W.element.interpolation_points()),
                           fem.Function(self.W))
        e, t, expr, f = self._rigid
        out = []
        for i in range(6):
            e.value[:] = np.eye(3)[i % 3]
            t.value = 1.0 if i < 3 else 0.0
            f.interpolate(expr)
            f.x.scatter_forward()
            out.append(f.x.petsc_vec.copy())
        return out

    def hessian_quadratic(self, block: Any, v: Any) -> float:
        """vᵀ H v at the current state by quadrature of the second variation d²E(v, v)
        (``FormProblem._quadratic``; the gauge's DOFs of v taken as zero), for
        ``shells.algorithms.stability``'s Rayleigh quotients. Its functional compiles far
        faster than the bilinear Hessian (docs/model.md, "Stability and critical points")."""
        return self._quadratic(None, self.hessian_ufl, self.bcs, v)

    def mode_rayleigh(self, vec: Any) -> dict[str, float]:
        """Rayleigh quotients of the normal component w = u·n° of a mode: ``m2`` =
        ∫(∂_φ w)²/∫w² about the z axis (m² on a surface of revolution) and, on spherical
        surfaces, ``x`` = R² ∫|∇w|²/∫w² (n(n+1) for a spherical harmonic of degree n)."""
        from dolfinx import fem
        from mpi4py import MPI

        if not hasattr(self, "_mode_forms"):
            import ufl

            u, _ = self.split(self._mode_function())
            wn = ufl.dot(u, self.n0)
            x = self._x
            grad_s = self.P0 * ufl.grad(wn)
            e_phi = ufl.as_vector([-x[1], x[0], 0.0])  # ∂x/∂φ about the z axis
            self._mode_forms = {
                "w2": fem.form(wn * wn * self.dx),
                "grad2": fem.form(ufl.dot(grad_s, grad_s) * self.dx),
                "dphi2": fem.form(ufl.dot(e_phi, ufl.grad(wn)) ** 2 * self.dx)}
        self._load_mode(vec)
        comm = self.shell.comm
        vals = {k: comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                for k, f in self._mode_forms.items()}
        w2 = max(vals["w2"], 1e-300)
        R = self.shape.R
        out = {"m2": vals["dphi2"] / w2}
        if math.isfinite(R):
            out["x"] = vals["grad2"] / w2 * R * R
        return out

    def orbit_tangents(self) -> list[Any]:
        """The state's tangent along its rotation about the axis of a shell of revolution
        (``shells.problem.interface.OrbitTangents``): d/dε of the state turned by ε, for u and
        θ alike (Cartesian vector fields: e_z × w - (∇w)(e_z × x)), interpolated in the
        state's space; [] where the state is axisymmetric (``ORBIT_MIN``, decided by
        quadrature, free of the interpolated gradient's error), on a closed sphere (whose
        orbit also holds the rotations the gauge fixes) and on a surface known only by its
        mesh."""
        import ufl
        from dolfinx import fem
        from mpi4py import MPI

        from shells.geometry.shapes import Sphere

        if not self.shape.of_revolution or isinstance(self.shape, Sphere):
            return []
        if not hasattr(self, "_tangent_expr"):
            ez = ufl.as_vector((0.0, 0.0, 1.0))
            a = ufl.cross(ez, self._x)
            u, th = self.split(self.w)
            tu, tt = (ufl.cross(ez, f) - ufl.grad(f) * a for f in (u, th))
            self._tangent_expr = fem.Expression(
                ufl.as_vector([tu[0], tu[1], tu[2], tt[0], tt[1], tt[2]]),
                self.W.element.interpolation_points())
            self._tangent_f = fem.Function(self.W)
            wn = ufl.dot(u, self.n0)
            self._tangent_norms = [fem.form(ufl.dot(a, ufl.grad(wn)) ** 2 * self.dx),
                                   fem.form(wn * wn * self.dx)]
        comm = self.shell.comm
        dphi2, w2 = (comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                     for f in self._tangent_norms)
        if not dphi2 >= ORBIT_MIN**2 * w2 or w2 == 0.0:
            return []
        self._tangent_f.interpolate(self._tangent_expr)
        t = self.create_vector()
        t.array_w[:] = self._tangent_f.x.array[: t.getLocalSize()]
        self.zero_constrained(t)
        return [t]

    def orbit_overlap(self, vec: Any) -> float:
        """|cos| of the angle (L² of the normal components) between a mode and the tangent
        space of the current state's orbit under the rotations that map the reference surface
        onto itself (``shells.problem.interface.orbit_cosine``): a rotation by ε about an axis a
        moves the normal displacement w = u·n° by -ε (a × x)·∇w (n° and the reference surface are
        invariant). A shell of revolution: a about its axis (turning a pattern). A closed
        sphere: any a through its centre, modulo the rigid motions that the gauge adds (a
        translation, a rotation of the deformed sphere): a dimple at the pole, which has no
        orbit about the axis, slides over the sphere. 1: the mode only turns or slides the
        pattern (a neutral direction of the continuum, broken by the mesh); 0 for a state with
        no orbit (an axisymmetric one of a shell of revolution) and on a surface known only by
        its mesh, which has no axis of symmetry."""
        import ufl
        from dolfinx import fem
        from mpi4py import MPI

        from shells.geometry.shapes import Sphere
        from shells.problem.interface import orbit_cosine

        if not self.shape.of_revolution:
            return 0.0

        if not hasattr(self, "_orbit_forms"):
            self._orbit_v = fem.Function(self.W)
            uv, _ = self.split(self._orbit_v)
            us, _ = self.split(self.w)
            x, n0 = self._x, self.n0
            ws, wv = ufl.dot(us, n0), ufl.dot(uv, n0)
            axes = [ufl.as_vector(a) for a in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0),
                                               (0.0, 1.0, 0.0))]
            sphere = isinstance(self.shape, Sphere)
            basis = [ufl.dot(ufl.cross(a, x), ufl.grad(ws)) for a in axes[: 3 if sphere else 1]]
            if sphere:  # the rigid motions: translations, rotations of the deformed sphere
                basis += [n0[i] for i in range(3)] + [ufl.dot(ufl.cross(a, us), n0) for a in axes]
            nb = len(basis)
            forms = ([wv * b for b in basis] + [basis[i] * basis[j] for i in range(nb)
                                                for j in range(i, nb)] + [wv * wv, ws * ws])
            self._orbit_forms = (3 if sphere else 1, nb, [fem.form(f * self.dx) for f in forms])
        vec.copy(self._orbit_v.x.petsc_vec)
        self._orbit_v.x.scatter_forward()
        comm = self.shell.comm
        tangents, nb, forms = self._orbit_forms
        vals = np.array([comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM) for f in forms])
        return orbit_cosine(vals[:nb], vals[nb:-2], vals[-2], vals[-1], tangents)

    def rigid_frame(self) -> Any:
        """The state's rigid rotation against the reference (``shells.surface.frame``): read
        material-frame quantities of a state without axial symmetry in its ``aligned()``
        block, where they do not depend on the gauge's choice of rotation. Built once."""
        from shells.surface.frame import RigidFrame

        if not hasattr(self, "_rigid_frame"):
            self._rigid_frame = RigidFrame(self)
        return self._rigid_frame

    def azimuthal_spectrum(self, vec: Any, m_max: int = 12, radial: int = 8) -> np.ndarray:
        """The power of a mode's normal component w = u·n° in each azimuthal wavenumber m =
        0..m_max: P_m = Σ_j |∫ w e^{-imφ} cos(jπ s) dω|² (j < ``radial``; s ∈ [0, 1] the
        meridian coordinate from the pole), normalised so that f(t) and f(t) cos(mφ) have equal
        power. From nodal values and the lumped mass of the mesh's Lagrange space, summed over
        ranks. Unlike the Rayleigh quotient m² = ∫(∂_φ w)²/∫w², which a mixture of m = 0 and
        m = 2 (two critical points 3e-4 apart) puts at m ≈ 1, this names the m present."""
        import ufl
        from dolfinx import fem, la
        from mpi4py import MPI

        if not hasattr(self, "_spectrum"):
            V = fem.functionspace(self.shell.mesh, ("Lagrange", self.params.degree))
            fw = fem.Function(V)
            u, _ = self.split(self._mode_function())
            expr = fem.Expression(ufl.dot(u, self.n0), V.element.interpolation_points())
            lumped = fem.assemble_vector(fem.form(ufl.TestFunction(V) * self.dx))
            lumped.scatter_reverse(la.InsertMode.add)
            n = V.dofmap.index_map.size_local
            x = V.tabulate_dof_coordinates()[:n]
            self._spectrum = (fw, expr, lumped.array[:n].copy(), np.arctan2(x[:, 1], x[:, 0]),
                              self._meridian_coordinate(x), n)
        fw, expr, mass, phi, s, n = self._spectrum
        self._load_mode(vec)
        fw.interpolate(expr)
        aw = mass * fw.x.array[:n]
        ms, js = np.arange(m_max + 1), np.arange(radial)
        c = (np.exp(-1j * np.outer(ms, phi)) * aw) @ np.cos(np.pi * np.outer(js, s)).T
        comm = self.shell.comm
        c = comm.allreduce(c.real, op=MPI.SUM) + 1j * comm.allreduce(c.imag, op=MPI.SUM)
        p = np.sum(np.abs(c) ** 2, axis=1)
        p[0] /= 2 * np.pi
        p[1:] *= 2 / np.pi
        return p

    def _meridian_coordinate(self, x: np.ndarray) -> np.ndarray:
        """s ∈ [0, 1] from the pole to the rim (the south pole of a closed shape) at points x."""
        from shells.geometry.meridian import MeridianTable
        from shells.geometry.shapes import Disk, EllipsoidalCap, Torus

        if isinstance(self.shape, Disk):
            return np.hypot(x[:, 0], x[:, 1]) / self.shape.radius
        if isinstance(self.shape, Torus):
            t = self.shape.meridian_angle(x.T)
        elif isinstance(self.shape, MeridianTable):
            t = self.shape.meridian_parameter(x.T)
        elif isinstance(self.shape, EllipsoidalCap):
            t = np.arccos(np.clip(x[:, 2] / self.shape.r3, -1, 1))
        else:
            t = np.arccos(np.clip(x[:, 2] / np.linalg.norm(x, axis=1), -1, 1))
        return t / self.shape.t_max

    def _mode_function(self) -> Any:
        from dolfinx import fem

        if not hasattr(self, "_mode_v"):
            self._mode_v = fem.Function(self.W)
        return self._mode_v

    def _load_mode(self, vec: Any) -> None:
        vec.copy(self._mode_function().x.petsc_vec)
        self._mode_v.x.scatter_forward()

    def classify_mode(self, vec: Any, block: Any = None) -> ModeInfo:
        """n on closed spheres (m is not defined on a degenerate eigenspace), else m, the
        azimuthal wavenumber of largest power (``azimuthal_spectrum``); ``rayleigh``: the
        Rayleigh quotients (``m2``, ``x``), ``orbit`` (``orbit_overlap``) and the power
        fraction of the chosen m (``m_power``)."""
        from shells.geometry.shapes import Sphere

        q = self.mode_rayleigh(vec)
        q["orbit"] = self.orbit_overlap(vec)
        if isinstance(self.shape, Sphere):
            x = q["x"]
            return ModeInfo(None, int(round((-1 + math.sqrt(1 + 4 * max(x, 0.0))) / 2)), q)
        if not self.shape.of_revolution:
            return ModeInfo(None, None, q)  # no axis to count waves about
        p = self.azimuthal_spectrum(vec)
        m = int(np.argmax(p))
        q["m_power"] = float(p[m] / max(p.sum(), 1e-300))
        return ModeInfo(m, None, q)
