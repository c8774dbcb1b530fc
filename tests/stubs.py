"""Test helper: stub out every computation a CLI subcommand starts (tests/test_paths.py,
tests/test_validation.py), so a test that gets past validation ends at once, on all ranks alike
(a test never meshes or solves, and 2 ranks never wait for each other)."""

from __future__ import annotations

import contextlib


class WorkStartedError(BaseException):
    """The command got past validation to its computation (stubbed out). A BaseException: the
    CLI turns every Exception into a one-line failure with exit status 1."""


def _stub(*args, **kwargs):
    raise WorkStartedError


def stub_computations(monkeypatch) -> None:
    """Replace the meshing, branch, critical-point, phase-diagram, post-buckling and knock-down
    entry points by stubs raising WorkStartedError."""
    from shells.analyses import axisym_runs, branch, knockdown, phase_diagram, postbuckle
    from shells.surface import mesh

    @contextlib.contextmanager
    def no_gmsh(name):
        raise WorkStartedError
        yield  # pragma: no cover

    monkeypatch.setattr(mesh, "gmsh_model", no_gmsh)
    monkeypatch.setattr(branch, "run_branch", _stub)
    monkeypatch.setattr(axisym_runs, "critical", _stub)
    monkeypatch.setattr(axisym_runs, "branch", _stub)
    monkeypatch.setattr(phase_diagram, "run", _stub)
    monkeypatch.setattr(postbuckle, "run", _stub)
    monkeypatch.setattr(knockdown, "run", _stub)
