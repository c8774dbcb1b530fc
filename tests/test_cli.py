"""The command line: version, help, JSON last line, one-line errors with exit status 2."""

import json

import pytest
from mpi4py import MPI

from shells import __version__
from shells.cli import main


def _last_json(out: str) -> dict:
    return json.loads(out.strip().splitlines()[-1])


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    if MPI.COMM_WORLD.rank == 0:
        assert __version__ in capsys.readouterr().out


def test_help_lists_subcommands(capsys):
    assert main([]) == 0
    if MPI.COMM_WORLD.rank == 0:
        out = capsys.readouterr().out
        assert "mesh" in out and "render" in out


@pytest.mark.parametrize("argv, needle", [
    (["mesh", "cap", "--theta-deg", "200"], "(0, 180]"),
    (["mesh", "cap", "--theta-deg", "-3"], "(0, 180]"),
    (["mesh", "cap", "--theta-deg", "30", "--h-over-r", "-0.01"], "must be positive"),
    (["mesh", "cube"], "unknown shape"),
    (["mesh", "cap"], "needs an opening angle"),
    (["info", "pyproject.toml"], "not a gmsh .msh mesh file"),
    (["info", "no-such-file.msh"], "not found"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_input_is_one_line_exit_2(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1, err
        assert needle in lines[0] and "Traceback" not in err


def test_mesh_json_last_line(capsys, shared_tmp):
    out_file = str(shared_tmp / "cap.msh")
    rc = main(["mesh", "cap", "--theta-deg", "30", "--h-over-r", "0.02", "--size", "0.2",
               "-o", out_file, "--json"])
    assert rc == 0
    if MPI.COMM_WORLD.rank == 0:
        d = _last_json(capsys.readouterr().out)
        assert d["file"] == out_file and d["cells"] > 100
        assert d["area_rel_error"] < 1e-5 and d["rim_rel_error"] < 1e-7
    assert main(["info", out_file, "--json"]) == 0


def test_reference_mesh_specs_are_valid(capsys):
    """Every parameter file in meshes/ builds a mesh close to its exact area."""
    import pathlib

    files = sorted(pathlib.Path(__file__).parent.parent.glob("meshes/*.json"))
    assert files
    for f in files:
        assert main(["mesh", "--spec", str(f), "--json"]) == 0
        if MPI.COMM_WORLD.rank == 0:
            d = _last_json(capsys.readouterr().out)
            assert d["area_rel_error"] < 1e-5, f
