"""The public Python API (``shells.cap``, ``shells.Shell``, ``shells.critical``, ...): the
command line's numbers to the last digit, units that change nothing but the units, Timoshenko's
bilayer against its exact limits, results that save, load, tabulate and plot, and a sweep
spread over the MPI processes. Valid on any number of ranks."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import child_env
from mpi4py import MPI

import shells
from shells.errors import InputError
from shells.layers import Bilayer, timoshenko_curvature

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def cap30():
    """The 30° cap at h/R = 0.04 on the 1D model, going up: its snap-through fold."""
    return shells.critical(shells.Shell(shells.cap(30), h_over_r=0.04))


def test_the_api_gives_the_command_lines_numbers(cap30, shared_tmp):
    """``shells critical --model axisym --json`` and ``shells.critical`` run the same analysis:
    every key of the command's JSON is the result's, with the same value to the last bit."""
    cmd = [sys.executable, "-m", "shells", "critical", "--shape", "cap", "--theta-deg", "30",
           "--h-over-r", "0.04", "--model", "axisym", "--json"]
    out = None
    if MPI.COMM_WORLD.rank == 0:  # one process: the CLI on its own
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=child_env(),
                             check=True, timeout=300).stdout
    cli = json.loads(MPI.COMM_WORLD.bcast(out, root=0).strip().splitlines()[-1])
    api = cap30.to_dict()
    assert cap30.model == "axisym"  # the API's default for a cap
    for key, value in cli.items():
        assert api[key] == value, key
    assert cap30.kind == "fold" and cap30.mode_m == 0
    # the fold against the independent 2D code (shared/peers/ngsolve-hhj: 1.393427, 1e-4)
    assert cap30.kappa_R == pytest.approx(1.393427, rel=1e-4)


def test_units_change_only_the_units(cap30):
    """The same cap in mm, in m and dimensionless: the same κR to 1e-12 (the same
    dimensionless computation), κ in 1/m = κR / R, and the thickness from h/R or a length."""
    mm = shells.critical(shells.Shell(shells.cap(30, radius="25 mm"), thickness="1 mm"))
    m = shells.critical(shells.Shell(shells.cap(theta=math.radians(30), radius="0.025 m"),
                                     thickness="0.001 m"))
    for r in (mm, m):
        assert r.kappa_R == pytest.approx(cap30.kappa_R, rel=1e-12, abs=0)
        assert r.kappa.to("1/m").magnitude == pytest.approx(cap30.kappa_R / 0.025, rel=1e-12)
    assert cap30.kappa is None  # dimensionless: no κ with units
    assert mm.shell["R_m"] == pytest.approx(0.025) and mm.shell["h_m"] == pytest.approx(1e-3)
    # a range in 1/m: the range the shell's R turns it into
    short = shells.critical(shells.Shell(shells.cap(30, radius="25 mm"), thickness="1 mm"),
                            kappa_max="40 1/m")
    assert short.kappa_R_end == pytest.approx(1.0) and short.kind == "none"


@pytest.mark.parametrize("bad, match", [
    (lambda: shells.cap(30, radius="25 kg"), "length"),
    (lambda: shells.cap(30, radius="-2 mm"), "positive"),
    (lambda: shells.Shell(shells.cap(30), thickness="1 mm"), "units"),
    (lambda: shells.Shell(shells.cap(30), h_over_r=0.04, thickness=0.04), "once"),
    (lambda: shells.Shell(shells.cap(30), h_over_r=0.9), "h/R must lie in"),
    (lambda: shells.Shell(shells.cap(30), h_over_r=0.04, nu=0.7), "nu must lie in"),
    (lambda: shells.critical(shells.Shell(shells.cap(30), h_over_r=0.04), kappa_max="4 1/m"),
     "units"),
])
def test_bad_input_is_one_input_error(bad, match):
    with pytest.raises(InputError, match=match):
        bad()


def test_bilayer_is_timoshenkos():
    """Equal layers give κh = 3Δε/2 exactly (Timoshenko 1925), a thin film tends to Stoney's
    κ = 6 M_f h_f Δε / (M_s h_s²) with an error O(h_f/h_s), and the sign follows the outward
    normal: an outer layer that expands bends the shell like a sphere (κ < 0)."""
    eps = 0.01
    equal = shells.bilayer(h=(0.5, 0.5), E=(2.0, 2.0), mismatch=eps, nu=0.3)
    assert equal.kappa * equal.thickness == pytest.approx(-1.5 * eps, rel=1e-14)
    assert equal.modulus == pytest.approx(2.0, rel=1e-14)  # one material: its own modulus
    assert equal.stretching_modulus == pytest.approx(2.0, rel=1e-14)
    # the units version: the same numbers in SI
    si = shells.bilayer(h=("0.5 mm", "500 um"), E=("2 MPa", "2e6 Pa"), mismatch=eps, nu=0.3)
    assert si.kappa == pytest.approx(equal.kappa / 1e-3, rel=1e-12)
    # Stoney: film 1 (biaxial modulus E/(1 - nu)) on substrate 2
    hs, ef, es, nuf, nus = 1.0, 3.0, 1.0, 0.25, 0.4
    errs, ratios = [], [1e-2, 1e-3, 1e-4]
    for r in ratios:
        hf = r * hs
        stoney = 6 * ef / (1 - nuf) * hf * eps / (es / (1 - nus) * hs**2)
        k = -Bilayer((hf, ef, nuf), (hs, es, nus), eps).kappa
        errs.append(abs(k / stoney - 1))
    assert errs[-1] < 1e-3
    rate = math.log(errs[0] / errs[-1]) / math.log(ratios[0] / ratios[-1])
    assert rate == pytest.approx(1.0, abs=0.05)
    # the formula itself at an arbitrary point, written out independently
    h1, h2, m1, m2 = 0.3, 0.7, 5.0, 2.0
    m, n = h1 / h2, m1 / m2
    expect = 6 * eps * (1 + m) ** 2 / ((h1 + h2) * (3 * (1 + m) ** 2
                                                    + (1 + m * n) * (m**2 + 1 / (m * n))))
    assert timoshenko_curvature(h1, h2, m1, m2, eps) == pytest.approx(expect, rel=1e-14)
    # the same strip turned over (layers swapped, the mismatch now the other's relative to
    # the first): the same magnitude, the other sign (the normal points the other way)
    a = Bilayer((h1, 5.0, 0.5), (h2, 2.0, 0.5), eps).kappa
    b = Bilayer((h2, 2.0, 0.5), (h1, 5.0, 0.5), -eps).kappa
    assert a == pytest.approx(-b, rel=1e-14) and a < 0


def test_a_bilayer_shell_carries_its_natural_curvature():
    bl = shells.bilayer(h=("0.5 mm", "0.5 mm"), E=("1 MPa", "1 MPa"), mismatch=0.01)
    s = shells.Shell(shells.cap(30, radius="25 mm"), layers=bl)
    assert s.h_over_r == pytest.approx(0.04)
    assert s.kappa_natural * 1.0 == pytest.approx(-15.0 * 0.025)  # κR, R = 25 mm
    assert s.describe()["kappa_natural_R"] == pytest.approx(-0.375)
    assert s.E == pytest.approx(1e6)


def test_results_save_load_tabulate_and_plot(cap30, shared_tmp):
    out = shared_tmp / "saved"
    if MPI.COMM_WORLD.rank == 0:
        cap30.save(out)
        cap30.plot(out / "fig.png")
    MPI.COMM_WORLD.barrier()
    back = shells.load(out)
    assert back.analysis == "critical" and back.to_dict() == cap30.to_dict()
    table = back.to_dataframe()
    assert list(table["kind"]) == [c["kind"] for c in cap30.critical_points]
    assert (out / "table.csv").stat().st_size > 0 and (out / "fig.png").stat().st_size > 5000
    with pytest.raises(InputError, match="no result"):
        shells.load(shared_tmp / "nothing-here")
    with pytest.raises(AttributeError, match="no 'kapa_R'"):
        cap30.kapa_R  # noqa: B018


def test_a_sweep_spreads_one_d_runs_over_the_processes(cap30):
    """Three caps, spread over the processes: every process gets every result, each the
    single run's to the last bit."""
    # θ̄ = 2.6, 3.1, 3.5: between θ̄_s and θ̄_c, each snaps at an axisymmetric fold
    caps = [shells.Shell(shells.cap(t), h_over_r=0.04) for t in (30, 35, 40)]
    res = shells.sweep(caps, "critical", direction="up")
    assert res[0].kappa_R == cap30.kappa_R and all(r.kind == "fold" for r in res)
    kinds = MPI.COMM_WORLD.allgather([(r.kind, r.kappa_R) for r in res])
    assert all(k == kinds[0] for k in kinds)
    # deeper caps snap later (the paper's snapping line rises with θ̄)
    assert res[0].kappa_R < res[1].kappa_R < res[2].kappa_R


def test_the_default_model_is_the_1d_model_where_it_applies():
    assert shells.choose_model(shells.Shell(shells.sphere(), h_over_r=0.01)) == "axisym"
    assert shells.choose_model(shells.Shell(shells.torus(), h_over_r=0.05)) == "surface"
    assert shells.choose_model(shells.Shell(shells.cap(30), h_over_r=0.04),
                               "surface") == "surface"


def _cli_json(argv: list[str], capsys) -> dict:
    from shells.cli import main

    assert main(argv) == 0
    out = MPI.COMM_WORLD.bcast(capsys.readouterr().out if MPI.COMM_WORLD.rank == 0 else None)
    return json.loads(out.strip().splitlines()[-1])


def test_the_command_line_takes_units(cap30, capsys):
    """``--radius 25mm --thickness 1mm`` (refused as ``--radius 0.025`` before units): the
    dimensionless run's κR to 1e-12, with κ in 1/m, R and h in metres added; a range in 1/m."""
    base = ["critical", "--shape", "cap", "--theta-deg", "30", "--model", "axisym", "--json"]
    d = _cli_json(base + ["--radius", "25mm", "--thickness", "1mm"], capsys)
    assert d["kappa_R"] == pytest.approx(cap30.kappa_R, rel=1e-12, abs=0)
    assert d["kappa_per_m"] == pytest.approx(cap30.kappa_R / 0.025, rel=1e-12)
    assert d["critical_points"][0]["kappa_per_m"] == pytest.approx(d["kappa_per_m"])
    assert (d["R_m"], d["h_m"]) == (pytest.approx(0.025), pytest.approx(0.001))
    short = _cli_json(base + ["--radius", "2.5 cm", "--thickness", "1 mm", "--kappa-max",
                              "40/m"], capsys)
    assert short["kappa_R_end"] == pytest.approx(1.0) and short["kind"] == "none"


def test_the_command_line_takes_a_bilayer(cap30, capsys):
    """``--bilayer 0.5mm,0.5mm,1MPa,1MPa,-0.05`` on a 25 mm cap: equal layers, so h = 1 mm
    (h/R = 0.04) and κh = -1.5 Δε = 0.075 (Timoshenko), κR = 1.875; the range ends there and
    the cap's fold (κR = 1.3934) is reached at the mismatch -0.05 × 1.3934 / 1.875."""
    base = ["critical", "--shape", "cap", "--theta-deg", "30", "--model", "axisym", "--json",
            "--radius", "25mm"]
    d = _cli_json(base + ["--bilayer", "0.5mm,0.5mm,1MPa,1MPa,-0.05"], capsys)
    b = d["bilayer"]
    assert b["thickness"] == pytest.approx(1e-3, rel=1e-12)
    assert b["kappa_R"] == pytest.approx(1.875, rel=1e-12)
    assert d["kappa_R_end"] == pytest.approx(1.875, rel=1e-12)
    assert d["kind"] == "fold" and d["kappa_R"] == pytest.approx(cap30.kappa_R, rel=1e-5)
    assert b["mismatch_at_critical"] == pytest.approx(-0.05 * d["kappa_R"] / 1.875, rel=1e-12)
    # the mismatch's sign is the direction: the same layers swelling the other way go down
    down = _cli_json(base + ["--bilayer", "0.5mm,0.5mm,1MPa,1MPa,0.02"], capsys)
    assert down["kappa_R_end"] == pytest.approx(-0.75, rel=1e-12)


@pytest.mark.parametrize("extra, message", [
    (["--bilayer", "0.5mm,0.5mm,1MPa,1MPa"], "five values"),
    (["--bilayer", "0.5,0.5,1,1,0.01", "--radius", "25mm"], "need units"),
    (["--bilayer", "0.5mm,0.5mm,1MPa,1MPa,0.01"], "--radius with units"),
    (["--bilayer", "0.5mm,0.5mm,1MPa,1MPa,x", "--radius", "25mm"], "must be a number"),
    (["--radius", "0.025", "--h-over-r", "0.04"], "a length with units is any size"),
    (["--radius", "25mm", "--thickness", "0.001"], "--thickness needs units"),
    (["--thickness", "1mm"], "needs --radius with units"),
    (["--radius", "25mm", "--h-over-r", "0.04", "--kappa-max", "40"], "curvature with units"),
    (["--radius", "25 kg", "--h-over-r", "0.04"], "must be a length"),
    (["--radius", "25 parsecs per", "--h-over-r", "0.04"], "cannot read"),
])
def test_units_on_the_command_line_are_checked(extra, message, capsys):
    from shells.cli import main

    argv = ["critical", "--shape", "cap", "--theta-deg", "30", "--model", "axisym", *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert message in err and len(err.strip().splitlines()) == 1


def test_tables_with_a_header_row_read_as_spreadsheets_write_them(shared_tmp):
    """A meridian written by pandas (an index column, a header ``r,z``), one with its columns
    swapped and units in the header, and a field table ``theta;f``: the numbers the header
    names, in the order the reader needs; a header that names no needed column is refused."""
    import numpy as np
    import pandas as pd

    from shells.geometry.meridian import MeridianTable
    from shells.geometry.stimulus import CurvatureField

    t = np.linspace(0.0, math.radians(30), 40)
    r, z = np.sin(t), np.cos(t)
    d = shared_tmp
    if MPI.COMM_WORLD.rank == 0:
        pd.DataFrame({"r": r, "z": z}).to_csv(d / "pandas.csv")
        pd.DataFrame({"Z (mm)": z, "R (mm)": r}).to_csv(d / "swapped.csv", index=False)
        (d / "field.csv").write_text("theta;f\n0;1\n0.5;2\n")
        (d / "wrong.csv").write_text("a,b\n0,1\n")
    MPI.COMM_WORLD.barrier()
    plain = MeridianTable(tuple(zip(r.tolist(), z.tolist(), strict=True)))
    for name in ("pandas.csv", "swapped.csv"):
        tab = MeridianTable.from_file(str(d / name))
        assert np.allclose(np.array(tab.points), np.array(plain.points), rtol=0, atol=1e-15)
    field = CurvatureField.from_file(str(d / "field.csv"))
    assert field.table == ((0.0, 1.0), (0.5, 2.0))
    with pytest.raises(InputError, match="needs the columns r z"):
        MeridianTable.from_file(str(d / "wrong.csv"))


def test_plots_and_tables_of_runs_and_run_folders(shared_tmp, capsys):
    """``--plot`` and ``--csv`` beside a run, ``shells plot DIR`` on its folder: a picture
    that is not blank, and the table of the branch's points (the JSON lines as one table)."""
    import numpy as np
    import pandas as pd

    from shells.cli import main

    out = shared_tmp / "branch"
    argv = ["branch", "--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04", "--model",
            "axisym", "--kappa-r-max", "1.2", "-o", str(out), "--plot", str(shared_tmp / "b.png"),
            "--csv", str(shared_tmp / "b.csv")]
    assert main(argv) == 0
    assert main(["plot", str(out), "-o", str(shared_tmp / "again.png")]) == 0
    capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        table = pd.read_csv(shared_tmp / "b.csv")
        # the JSON lines are one table, the run's header in its sidecar run.json
        lines = pd.read_json(out / "branch.jsonl", lines=True)
        assert len(lines) == len(table) and "header" not in lines.columns
        assert json.loads((out / "run.json").read_text())["header"]["model"] == "axisym"
        back = shells.load(out)
        assert back.analysis == "branch" and len(back.rows()) == len(table)
        assert table["kappa_R"].iloc[-1] == pytest.approx(1.2, rel=1e-12)  # lands on the end
        assert np.all(np.diff(table["kappa_R"]) > 0)  # below the fold: κ rises
        import matplotlib.image as mpimg

        for png in ("b.png", "again.png"):
            img = mpimg.imread(shared_tmp / png)
            assert img.shape[0] > 300 and float(img[..., :3].std()) > 0.05  # not blank


def test_progress_is_a_bar_on_a_terminal_and_quiet_under_json(monkeypatch, caplog):
    """On a terminal: a tqdm bar with the share of the κ range, points and critical points;
    under ``--json`` no bar; elsewhere a log line (every 10 s: the first at once)."""
    import io
    import logging

    from shells import progress

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr("sys.stderr", term)
    progress.quiet(False)
    bar = progress.Progress("branch", 2.0)
    for k in (0.5, 1.0, 1.5):
        bar.update(k, critical=int(k == 1.0))
    bar.close()
    shown = term.getvalue()
    assert "75%" in shown and "point 3" in shown and "critical 1" in shown
    progress.quiet(True)
    term.seek(0), term.truncate()
    silent = progress.Progress("branch", 2.0)
    silent.update(1.0)
    silent.close()
    progress.quiet(False)
    assert "|" not in term.getvalue()  # no bar (a log line may go to the log's handler)
    monkeypatch.setattr("sys.stderr", io.StringIO())  # not a terminal
    with caplog.at_level(logging.INFO, logger="shells"):
        lines = progress.Progress("critical", 4.0, interval=0.0)
        lines.update(1.0)
    assert "critical: 25 % of the range, point 1" in caplog.text


def test_one_kappa_b_for_the_sphere_from_every_command():
    """The closed sphere at h/R = 0.01, ν = ½ on the 1D model: ``critical``, ``postbuckle``
    and ``knockdown`` (δ = 0) report κ_b h within 1e-4 of the converged 1.5062 (the 1D model
    with the penalty's pole imperfection out of reach, penalty 1e6, benchmarks/
    sphere_knockdown.py; the thin-shell theory's 4/√7 = 1.5119 is O(h/R) above it)."""
    sphere = shells.Shell(shells.sphere(), h_over_r=0.01)
    crit = shells.critical(sphere).kappa_h
    post = shells.postbuckle(sphere, max_points=2, sides=(-1,)).critical_point["kappa_h"]
    knock = shells.knockdown(sphere, amplitudes=(0.0,)).kappa_b * 0.01
    for value in (crit, post, knock):
        assert value == pytest.approx(1.5062, rel=1e-4)


def test_the_first_line_says_which_model_runs_and_why(capsys):
    """Subcommands differ in their default model (critical and branch: surface; postbuckle,
    knockdown, phase-diagram, frequencies: axisym): where --model is not given, the first line
    of the output names the model, that it is the command's default, and the other one; with
    --model the same run says only the model."""
    import argparse

    from shells.cli import main
    from shells.cli.common import model_words

    default = model_words(argparse.Namespace(model="surface", model_given=False))
    assert default.startswith("model surface: the default of this command")
    assert "--model axisym" in default
    assert model_words(argparse.Namespace(model="surface", model_given=True)) == "model surface"
    base = ["knockdown", "--h-over-r", "0.05", "--imperfection", "dimple", "--amplitudes", "0.1",
            "--no-figure"]
    assert main(base) == 0
    first = capsys.readouterr().out.splitlines()
    assert main([*base, "--model", "axisym"]) == 0
    given = capsys.readouterr().out.splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert "model axisym: the default of this command" in first[0]
        assert "--model surface" in first[0]
        assert given[0].endswith("model axisym") and first[1:] == given[1:]


def test_a_folder_in_use_is_refused(shared_tmp):
    """As on the command line: a run into an output folder another run holds is refused
    (``InputError`` naming the folder), before any work; once free, the folder is usable."""
    from shells.files import hold_output_folder

    shell = shells.Shell(shells.cap(30), h_over_r=0.04)
    folder = shared_tmp / "held"
    with hold_output_folder(folder, MPI.COMM_WORLD):
        with pytest.raises(InputError, match="held"):
            shells.critical(shell, model="axisym", outdir=folder)
    res = shells.critical(shell, model="axisym", outdir=folder)
    assert res.kind == "fold"
