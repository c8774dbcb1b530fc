"""The analyses as a researcher calls them (API layer): one function per analysis, taking a
``Shell``, returning a ``Result``, with one set of defaults.

The model. ``model=None`` picks the 1D axisymmetric model for every shell of revolution it
takes (spheres, caps, ellipsoidal caps, disks, meridian tables) under a uniform or
axisymmetric natural curvature: its branch is exact for an axisymmetric state and its
stability covers every Fourier mode m, in seconds. Other shells (a torus, a user's mesh that
is no surface of revolution, a field that varies around the axis) take the 2D surface model.
``model="surface"`` or ``"axisym"`` chooses explicitly. The chosen model is in the result
(``res.model``).

The κ range: ``kappa_R_max`` (κR), ``kappa_h_max`` (κh) or ``kappa_max`` (a curvature with
units, such as ``"40 1/m"``, for a shell with units); none: a range from the paper's laws that
contains the first critical point.
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from shells.analyses.setup import kappa_end
from shells.api.results import Result
from shells.api.shell import Shell
from shells.errors import InputError
from shells.geometry.shapes import kappa_length
from shells.units import curvature

__all__ = ["branch", "choose_model", "critical", "frequencies", "knockdown", "phase_diagram",
           "postbuckle", "snap", "sweep"]


def _held(outdir: Any) -> AbstractContextManager[None]:
    """Hold ``outdir`` for one run at a time (``shells.files.hold_output_folder``, as the
    command line does): a second run into the same folder is refused with an ``InputError``
    instead of interleaving its files; None: nothing to hold."""
    if outdir is None:
        return nullcontext()
    from mpi4py import MPI

    from shells.files import hold_output_folder

    return hold_output_folder(outdir, MPI.COMM_WORLD, label="outdir")


def choose_model(shell: Shell, model: str | None = None) -> str:
    """The model a run uses: ``model`` if given, else the 1D model where it applies (a shell of
    revolution with a pole under an axisymmetric stimulus), else the surface model."""
    from shells.parameters import check_model

    if model is not None:
        return check_model(model)
    from shells.axisym.mesh import check_supported

    try:
        check_supported(shell.shape)
    except InputError:
        return "surface"
    field = shell.kappa_field
    if field is not None:
        try:
            field.check_on(shell.shape, axisymmetric=True)
        except InputError:
            return "surface"
    return "axisym"


def _kappa_end(shell: Shell, kappa_max: Any, kappa_R_max: Any, kappa_h_max: Any,
               direction: str | None) -> float | None:
    """The end of the κ range as an absolute κ in the shape's units (None: the default), its
    sign the direction's when one is given."""
    given = [v is not None for v in (kappa_max, kappa_R_max, kappa_h_max)]
    if sum(given) > 1:
        raise InputError("give the end of the kappa range once: kappa_max, kappa_R_max or "
                         "kappa_h_max")
    if kappa_max is not None:
        si = curvature(kappa_max, "kappa_max")
        if si is None:
            k = float(kappa_max)
        elif shell.geometry.length is None:
            raise InputError("kappa_max with units needs a shell with units (give the radius "
                             "as a length), or give kappa_R_max")
        else:
            k = si * shell.geometry.length
        kappa_R_max = k * kappa_length(shell.shape)
    k = kappa_end(shell.shape, shell.h_over_r, kappa_h_max, kappa_R_max, direction)
    if k is not None and not k:
        raise InputError("the end of the kappa range must be nonzero")
    return k


def critical(shell: Shell, direction: str = "up", *, model: str | None = None,
             kappa_max: Any = None, kappa_R_max: float | None = None,
             kappa_h_max: float | None = None, outdir: Any = None, first_only: bool = False,
             **options: Any) -> Result:
    """The critical points of the shell's fundamental branch from κ = 0 (``shells critical``).

    Args:
        shell: the shell.
        direction: ``"up"`` (κ > 0) or ``"down"`` (κ < 0).
        model: ``"axisym"``, ``"surface"`` or None (``choose_model``).
        kappa_max, kappa_R_max, kappa_h_max: the end of the range (module docstring).
        outdir: a folder for the run's files (``critical.json``; the surface model also its
            branch, checkpoints and modes); None: none.
        first_only: stop at the first critical point.
        **options: the surface model's numerics (``size``, ``degree``, ``layer_elements``,
            ``shear_penalty``, ``ds``, ``ds_max``, ``mesh_file``, ``resume``).

    Returns:
        The ``Result``: ``kind``, ``kappa_R``, ``kappa_h``, ``mode_m``, ``mode_n`` of the first
        critical point, and ``critical_points``, as ``shells critical --json`` gives them.
    """
    from shells.analyses import critical as analysis

    m = choose_model(shell, model)
    if m == "axisym" and options:
        raise InputError(f"{', '.join(options)}: the surface model's options (model='surface')")
    end = _kappa_end(shell, kappa_max, kappa_R_max, kappa_h_max, direction)
    with _held(outdir):
        data = analysis.run(shell.shape, shell.h_over_r, shell.nu, direction=direction,
                            model=m, kappa_end=end, outdir=outdir,
                            kappa_field=shell.kappa_field, first_only=first_only, **options)
    return Result("critical", data, shell.describe())


def branch(shell: Shell, *, kappa_max: Any = None, kappa_R_max: float | None = None,
           kappa_h_max: float | None = None, model: str | None = None,
           outdir: Any = "results/branch", fields: str = "none", resume: bool = True,
           **options: Any) -> Result:
    """The shell's equilibrium branch from κ = 0 to the end of the range (its sign: the
    direction), by pseudo-arclength through folds (``shells branch``).

    Args:
        shell: the shell.
        kappa_max, kappa_R_max, kappa_h_max: the end of the range (one is required).
        model: ``"axisym"``, ``"surface"`` or None (``choose_model``).
        outdir: the run's folder (``branch.jsonl``, every point appended as computed).
        fields: the surface model's fields for ParaView: ``"none"``, ``"last"``, ``"all"``.
        resume: the surface model resumes an unfinished run of the same configuration.
        **options: the surface model's ``BranchConfig`` numerics (``size``, ``degree``, ...).

    Returns:
        The ``Result``: ``points`` (κR, κh, Ψ3/h, energy, ... per point) and ``folds``.
    """
    from shells.analyses import branch as analysis

    end = _kappa_end(shell, kappa_max, kappa_R_max, kappa_h_max, None)
    if end is None:
        raise InputError("a branch needs the end of its range: kappa_R_max, kappa_h_max or "
                         "kappa_max")
    with _held(outdir):
        data = analysis.run(shell.shape, shell.h_over_r, shell.nu, end,
                            model=choose_model(shell, model), outdir=outdir,
                            kappa_field=shell.kappa_field, fields=fields, resume=resume,
                            **options)
    return Result("branch", data, shell.describe())


def postbuckle(shell: Shell, direction: str = "up", *, at: int = 1, model: str | None = None,
               kappa_max: Any = None, kappa_R_max: float | None = None,
               kappa_h_max: float | None = None, outdir: Any = None, fields: str = "none",
               **options: Any) -> Result:
    """The branch that bifurcates at the ``at``-th bifurcation of the fundamental branch,
    both sides, with the stability at every point (``shells postbuckle``).

    Args:
        shell: the shell.
        direction: ``"up"`` or ``"down"``.
        at: which bifurcation (1: the first).
        model, kappa_max, kappa_R_max, kappa_h_max, outdir: as for ``critical``.
        fields: 3D shapes (1D model) or fields (surface model) for ParaView: ``"none"``,
            ``"last"``, ``"all"`` (needs ``outdir``).
        **options: ``PostbuckleConfig`` fields (``sides``, ``max_points``, ``amplitude``,
            ``cells``, ``penalty``, ``size``, ``degree``, ...).

    Returns:
        The ``Result``: ``critical_point``, ``points`` (branch, side, κR, Ψ3(pole)/h,
        stable, ...) and ``sides``.
    """
    from shells.analyses import postbuckle as analysis
    from shells.analyses.postbuckle import PostbuckleConfig
    from shells.geometry.stimulus import UNIFORM

    cfg = PostbuckleConfig(
        shape=shell.shape, h_over_r=shell.h_over_r, nu=shell.nu,
        model=choose_model(shell, model), direction=direction, at=at,
        kappa_end=_kappa_end(shell, kappa_max, kappa_R_max, kappa_h_max, direction),
        kappa_field=UNIFORM if shell.kappa_field is None else shell.kappa_field, **options)
    with _held(outdir):
        data = analysis.run(cfg, outdir, fields=fields)
    return Result("postbuckle", data, shell.describe())


def snap(shell: Shell, *, past: float = 0.01, kappa_R: float | None = None,
         method: str = "minimise", outdir: Any = None, render: bool = True,
         **options: Any) -> Result:
    """Where the shell lands when it snaps through (``shells snap``; the surface model).

    Follows the fundamental branch to its snap fold, steps ``past`` beyond it (κ = (1 + past)
    κ_fold, or ``kappa_R``), perturbs the state along its unstable modes and minimises the
    energy there, or integrates the equations of motion to rest and polishes the rest state
    by the same minimiser (``shells.analyses.snap``).

    Args:
        shell: an open shell (a cap).
        past: the relative step past the fold.
        kappa_R: κR of the landing instead (past the fold).
        method: ``"minimise"`` or ``"dynamics"``.
        outdir: a folder for ``snap.json``, the renders, the checkpoint and (dynamics)
            ``snap_series.csv``, ``snap.bp`` (the fields over time for ParaView) and
            ``snap.gif`` (None: none).
        render: draw the landing and everted states and (dynamics) the animation (with
            ``outdir``); without it a dynamics run keeps its frames, and a rerun with it
            draws the animation from them.
        **options: ``SnapConfig`` numerics (``amplitude``, ``kappa_R_max``, ``size``,
            ``degree``, ``layer_elements``, ``shear_penalty``, ``damping``: dynamics' α of
            C = α M in units √(E/ρ)/R, ``step_tol``: dynamics' adaptive step tolerance,
            ``settle``: the kinetic energy's fraction of its peak under which the dynamics
            stop once the Hessian is stable, 0 to run to rest, ``t_max``: the time at which
            the dynamics stop if they have not before, in units R √(ρ/E)).

    Returns:
        The ``Result``: ``start``, ``method``, ``landing`` (``energy``, ``stable``,
        ``symmetric``, ``mode_m``, ...), ``axisymmetric_everted``, ``snap_time`` (dynamics:
        in units of R √(ρ/E)), ``dynamics``.
    """
    from shells.analyses import snap as analysis

    if shell.kappa_field is not None and not shell.kappa_field.uniform:
        raise InputError("snap takes a uniform natural curvature")
    cfg = analysis.SnapConfig(shape=shell.shape, h_over_r=shell.h_over_r, nu=shell.nu,
                              method=method, past=past, kappa_R=kappa_R, **options)
    with _held(outdir):
        data = analysis.run(cfg, outdir, render=render)
    return Result("snap", data, shell.describe())


def frequencies(shell: Shell, *, kappa_R: float = 0.0, model: str | None = None,  # noqa: N803
                count: int = 4, **options: Any) -> Result:
    """The lowest natural frequencies of the free shell at κR = ``kappa_R``
    (``shells frequencies``; ``shells.analyses.frequencies``).

    Args:
        shell: the shell (a uniform natural curvature).
        kappa_R: κR of the prestressed state (reached from κ = 0 on the fundamental branch).
        model: ``"axisym"``, ``"surface"`` or None (``choose_model``).
        count: frequencies per Fourier block (1D model) or in all (surface model).
        **options: ``m_max``, ``cells``, ``size``, ``degree``, ``shear_penalty``.

    Returns:
        The ``Result``: ``frequencies`` (``omega`` in units of √(E/ρ)/R, ``omega2``,
        ``mode_m``, ``mode_n``), ``kappa_R``.
    """
    from shells.analyses import frequencies as analysis

    if shell.kappa_field is not None and not shell.kappa_field.uniform:
        raise InputError("frequencies take a uniform natural curvature")
    data = analysis.run(shell.shape, shell.h_over_r, shell.nu, kappa_R=kappa_R,
                        model=choose_model(shell, model), count=count, **options)
    return Result("frequencies", data, shell.describe())


def knockdown(shell: Shell | None = None, amplitudes: Sequence[float] = (0.0,), *,
              h_over_r: float | None = None, nu: float = 0.5, imperfection: str = "dimple",
              model: str = "axisym", outdir: Any = None, figure: bool = True,
              **options: Any) -> Result:
    """The knock-down of a closed sphere's buckling curvature by an imperfection
    (``shells knockdown``).

    Args:
        shell: a closed sphere (its h/R and ν), or None with ``h_over_r`` and ``nu``.
        amplitudes: imperfection amplitudes δ/h (0: the perfect sphere).
        imperfection: ``"dimple"``, ``"mode"`` or ``"harmonic"`` (the surface model).
        model: ``"axisym"`` (rotational symmetry enforced, Koiter's law beside the points) or
            ``"surface"``.
        outdir: a folder: every point appended to ``points.jsonl`` and skipped on a rerun.
        figure: draw ``outdir/knockdown.png``.
        **options: ``KnockdownConfig`` fields (``width``, ``degree``, ``order``, ``load``, ...).

    Returns:
        The ``Result``: ``kappa_b``, ``asymptotics`` and ``points`` (δ/h, κ_max h,
        knock-down).
    """
    from shells.analyses import knockdown as analysis
    from shells.analyses.knockdown import KnockdownConfig

    if shell is not None:
        if not shell.shape.closed:
            raise InputError("the knock-down is computed for closed spheres")
        h_over_r, nu = shell.h_over_r, shell.nu
    if h_over_r is None:
        raise InputError("give the sphere: a shell or h_over_r")
    cfg = KnockdownConfig(h_over_r=h_over_r, amplitudes=tuple(amplitudes), nu=nu,
                          imperfection=imperfection, model=model, **options)
    with _held(outdir):
        data = analysis.run(cfg, outdir, figure=figure and outdir is not None)
    return Result("knockdown", data, None if shell is None else shell.describe())


def phase_diagram(h_over_r: Sequence[float], thetabar_range: tuple[float, float],
                  points: int, *, nu: float = 0.5, model: str = "axisym",
                  outdir: Any = "results/phase-diagram", figure: bool = True,
                  landings: Sequence[Any] | None = None, **options: Any) -> Result:
    """The phase diagram of open spherical caps in (θ̄, κR) with the paper's fits
    (``shells phase-diagram``); points run in parallel, one per MPI process.

    Args:
        h_over_r: the thicknesses h/R.
        thetabar_range: (A, B): ``points`` values of θ̄ = θ/√(h/R) evenly spaced in it.
        points: values of θ̄ per h/R.
        nu: Poisson's ratio.
        model: ``"axisym"`` or ``"surface"`` (spot checks).
        outdir: the run's folder (``points.jsonl``, ``phase_diagram.json``, the figure).
        figure: draw ``outdir/phase_diagram.png``.
        landings: ``shells.snap`` output folders (or their ``snap.json``): where those caps
            landed is marked in the figure (symmetric or broken, with m) and listed in the
            result's ``landings``.
        **options: ``PhaseDiagramConfig`` fields (``m_max``, ``rel_tol``, ``refine``, ...).

    Returns:
        The ``Result``: ``points`` and ``fits`` (α, β, b, c, θ̄_s, θ̄_c with errors).
    """
    from shells.analyses import phase_diagram as analysis
    from shells.analyses.phase_diagram import PhaseDiagramConfig

    cfg = PhaseDiagramConfig(h_over_r=tuple(h_over_r), thetabar_range=tuple(thetabar_range),
                             points=points, nu=nu, model=model, **options)
    marks = analysis.read_landings(list(landings)) if landings is not None else None
    with _held(outdir):
        data = analysis.run(cfg, outdir, figure=figure, landings=marks)
    return Result("phase_diagram", data)


def sweep(shells: Sequence[Shell], analysis: str = "critical", *, comm: Any = None,
          **kwargs: Any) -> list[Result]:
    """One analysis of many shells, spread over the MPI processes of ``comm``.

    Shells the 1D model runs (``choose_model``) are independent one-process runs: process r
    computes shells r, r + size, ... and every process gets all the results. Surface-model
    runs are collective: they run one after another on all processes.

    Args:
        shells: the shells.
        analysis: ``"critical"`` or ``"postbuckle"``.
        comm: the communicator (default MPI.COMM_WORLD).
        **kwargs: the analysis's arguments (without ``outdir``: runs of a sweep keep no
            files).

    Returns:
        The results, in the order of ``shells``, on every process.
    """
    from mpi4py import MPI

    runs = {"critical": critical, "postbuckle": postbuckle}
    if analysis not in runs:
        raise InputError(f"a sweep runs critical or postbuckle, not {analysis!r}")
    if "outdir" in kwargs:
        raise InputError("a sweep keeps no files: drop outdir")
    comm = MPI.COMM_WORLD if comm is None else comm
    fn = runs[analysis]
    one_d = all(choose_model(s, kwargs.get("model")) == "axisym" for s in shells)
    if not one_d:
        return [fn(s, **kwargs) for s in shells]
    mine = {i: fn(s, **kwargs) for i, s in enumerate(shells) if i % comm.size == comm.rank}
    gathered: dict[int, Result] = {}
    for part in comm.allgather(mine):
        gathered.update(part)
    return [gathered[i] for i in range(len(shells))]
