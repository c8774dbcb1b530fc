"""The form cache (shells.problem.formcache): the 1D model's mode forms and dR/dκ loaded from a
record are the forms derived anew, bound to the new model's own data (its element matrices and dR/dκ
identical to the last bit, at another state and other parameters than the record's); a
different derivation or a broken record derives them again; ranks that disagree about a
record all derive. The Hessian functional of the Rayleigh quotients (a derived form of rank 0
with a coefficient of its own) comes from its record as well.

The 1D problem runs on MPI.COMM_SELF on every rank; each test uses a cache folder of its own
per rank, and the outcome is reduced over MPI.COMM_WORLD before asserting.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.newton import NewtonSolver
from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters
from shells.geometry.shapes import SphericalCap
from shells.problem import formcache


def everywhere(flag: bool) -> bool:
    return MPI.COMM_WORLD.allreduce(bool(flag), op=MPI.LAND)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    path = tmp_path / f"derived{MPI.COMM_WORLD.rank}"
    monkeypatch.setattr(formcache, "cache_folder", lambda: path)
    monkeypatch.delenv("SHELLS_FORM_CACHE", raising=False)
    return path


def loaded(h: float, nu: float, kappa: float) -> AxisymModel:
    model = AxisymModel(SphericalCap(1.0, math.radians(30.0)),
                        AxisymParameters(h=h, nu=nu, cells=24))
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    model.set_kappa(kappa)
    ok, _ = ns.solve()
    ns.destroy()
    assert everywhere(ok)
    return model


def element_matrices(model: AxisymModel) -> np.ndarray:
    mf = model.mode_forms
    E = mf.element_matrices()
    assert E is not None  # the 1D model runs on one process: the element-matrix path
    return E.copy()


def test_mode_forms_from_the_record_are_the_derived_ones_bound_to_the_new_data(folder):
    first = loaded(0.01, 0.5, 3.0)
    derived = element_matrices(first)  # derived and compiled; the record written
    # C_0..C_4 (H_0's element matrices come from C_0's); the model's dR/dκ, and R with dR/dκ
    # on W x W (``AxisymModel._paired``)
    assert len(list(folder.glob("*.json"))) == 3

    # another model: other Poisson ratio and state (the same mesh), the same kernels
    second = loaded(0.01, 0.3, -2.0)
    calls = []
    original = second.mode_forms.coefficient_ufl
    second.mode_forms.coefficient_ufl = lambda: calls.append(1) or original()
    from_record = element_matrices(second)
    assert not calls  # no UFL work: the record served

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SHELLS_FORM_CACHE", "0")
        third = loaded(0.01, 0.3, -2.0)
        fresh = element_matrices(third)
    same = np.array_equal(from_record, fresh)
    b2, b3 = second.create_vector(), third.create_vector()
    second.assemble_dkappa(b2)
    third.assemble_dkappa(b3)
    same = same and np.array_equal(b2.array, b3.array) and b2.norm() > 0
    # and not a stale copy of the first model's values
    differs = not np.allclose(from_record, derived)
    assert everywhere(same and differs)


def test_the_key_changes_with_anything_that_changes_the_kernels():
    """The record is found by the source's whole UFL: another quadrature degree, another number
    written into the expression or another element give another key (no compilation needed
    to tell); the same form built again, on another mesh of the same kind, the same key."""
    import ufl
    from dolfinx import fem, mesh

    def source(degree=4, number=2.0, p=2, cells=8):
        domain = mesh.create_unit_interval(MPI.COMM_SELF, cells)
        V = fem.functionspace(domain, ("Lagrange", p))
        f, c = fem.Function(V), fem.Constant(domain, 3.0)
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": degree})
        return (number * f + c) * u.dx(0) * v.dx(0) * dx

    key = lambda form: formcache.record_key(form, "a test", None)  # noqa: E731
    base = key(source())
    assert key(source(cells=12)) == base
    assert len({base, key(source(degree=6)), key(source(number=2.5)), key(source(p=3))}) == 4
    assert formcache.record_key(source(), "another derivation", None) != base


def test_a_changed_derivation_or_a_broken_record_derives_again(folder):
    model = loaded(0.01, 0.5, 1.0)
    mf = model.mode_forms
    tag, calls = "a test derivation", []

    def derive():
        calls.append(1)
        return mf.coefficient_ufl()[:2]

    forms, _ = formcache.compiled_derived(mf.hessian_ufl, tag, derive)
    formcache.compiled_derived(mf.hessian_ufl, tag, derive)
    formcache.compiled_derived(mf.hessian_ufl, tag + " changed", derive)
    counts_ok = len(calls) == 2
    # a record naming a module that is gone: derived again, and the record repaired
    for path in folder.glob("*.json"):
        path.write_text(path.read_text().replace(".so", ".gone.so"))
    again, reads = formcache.compiled_derived(mf.hessian_ufl, tag, derive)
    formcache.compiled_derived(mf.hessian_ufl, tag, derive)  # the repaired record serves
    repaired_ok = len(calls) == 3
    from dolfinx.fem.petsc import assemble_matrix

    A, B = assemble_matrix(forms[1]), assemble_matrix(again[1])
    A.assemble()
    B.assemble()
    B.axpy(-1.0, A)
    same = B.norm() == 0.0 and A.norm() > 0
    assert everywhere(counts_ok and repaired_ok and same and len(reads) == 2)


def test_ranks_that_disagree_about_a_record_all_derive(tmp_path, monkeypatch):
    """On a mesh of every rank, a record only rank 0 has (each rank its own folder here; the
    shared folder of a cluster can be seen at different times): compiling is collective, so
    every rank derives (no rank waits forever for another), and the forms are the same."""
    import ufl
    from dolfinx import fem, mesh
    from dolfinx.fem.petsc import assemble_matrix

    folder = tmp_path / f"derived-{MPI.COMM_WORLD.rank}"
    monkeypatch.setattr(formcache, "cache_folder", lambda: folder)
    domain = mesh.create_unit_interval(MPI.COMM_WORLD, 8)
    V = fem.functionspace(domain, ("Lagrange", 2))
    f, c = fem.Function(V), fem.Constant(domain, 3.0)
    f.interpolate(lambda x: 1.0 + x[0] ** 2)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    source = f * c * u * v * ufl.dx
    calls = []

    def derive():
        calls.append(1)
        return [ufl.replace(source, {c: ufl.as_ufl(2.0)})]

    first, _ = formcache.compiled_derived(source, "a test", derive)
    written = len(list(folder.glob("*.json")))
    second, _ = formcache.compiled_derived(source, "a test", derive)
    A, B = assemble_matrix(first[0]), assemble_matrix(second[0])
    A.assemble()
    B.assemble()
    norm = A.norm()
    B.axpy(-1.0, A)
    ok = B.norm() == 0.0 and norm > 0
    if MPI.COMM_WORLD.size > 1:
        ok = ok and len(calls) == 2 and written == (1 if MPI.COMM_WORLD.rank == 0 else 0)
    else:
        ok = ok and len(calls) == 1 and written == 1
    assert everywhere(ok)


def test_the_hessian_functional_from_the_record_is_the_derived_one(folder, monkeypatch):
    """``hessian_quadratic`` (vᵀ H_m v by quadrature of d²E(v, v): the functional
    action(action(H, f), f), a derived form of rank 0 with a coefficient f of its own, through
    ``compiled_derived``'s ``extra``): a second model loads it from the record with no UFL
    work, and gets the value a fresh derivation gives, to the last bit; that value is vᵀ H_m v
    of the assembled block to round-off (the block's constrained DOFs of v taken as zero)."""
    from dolfinx.fem.petsc import set_bc

    def quadratic(model):
        H = model.create_hessian(2)
        model.assemble_hessian(2, H)
        v = H.createVecRight()
        v.array_w[:] = np.sin(np.arange(v.getLocalSize()) * 0.37)
        q = model.hessian_quadratic(2, v)
        set_bc(v, model.mode_forms.conditions(2), alpha=0.0)
        Hv = H.createVecLeft()
        H.mult(v, Hv)
        return q, v.dot(Hv), H.norm() * v.dot(v)

    quadratic(loaded(0.01, 0.5, 3.0))  # derived and recorded
    assert any(folder.glob("*.json"))
    import shells.problem.forms

    derived = []
    original = shells.problem.forms.compiled_derived

    def counted(source, tag, derive, *args, **kwargs):
        return original(source, tag, lambda: derived.append(tag) or derive(), *args, **kwargs)

    monkeypatch.setattr(shells.problem.forms, "compiled_derived", counted)
    q_record, qm, scale = quadratic(loaded(0.01, 0.3, -2.0))
    from_record = not [t for t in derived if t.endswith("quadratic")]
    monkeypatch.setenv("SHELLS_FORM_CACHE", "0")
    q_fresh, _, _ = quadratic(loaded(0.01, 0.3, -2.0))
    from_record = from_record and any(t.endswith("quadratic") for t in derived)  # (counted)
    assert everywhere(from_record and q_record == q_fresh and abs(q_record) > 0
                      and abs(q_record - qm) < 1e-12 * scale)


def test_a_signature_does_not_depend_on_how_many_constants_came_before():
    """UFL orders the operands of a sum canonically, and Constants by their reprs, whose last
    number is a count that grows through the process: as strings, "..., 100)" came before
    "..., 99)", so the same form got another signature when its Constants' counts straddled a
    power of ten, and its record was not found. ``shells.problem.formcache`` compares those counts
    as numbers: the same signature either way."""
    import ufl
    from dolfinx import mesh

    domain = mesh.create_unit_interval(MPI.COMM_SELF, 4)

    def form():
        a, b = ufl.Constant(domain), ufl.Constant(domain)  # consecutive counts
        return (a + b) * a * ufl.dx(domain), a.count()

    plain, count = form()
    digits = len(str(count + 2))
    while len(str(ufl.Constant(domain).count() + 2)) == digits:
        pass  # up to the counts just below the next power of ten
    straddling, count = form()
    assert len(str(count)) < len(str(count + 1))  # 9..9 and 10..0
    assert straddling.signature() == plain.signature()
