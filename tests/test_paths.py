"""shells.cli.paths (the I/O-validation layer) and the CLI's use of it: a path outside the folders
shared with the host (SHELLS_HOST_PATHS) or an unusable output file or folder is refused before
any work, as one line on stderr with exit status 2.

The tests run inside the environment already, so the host side of scripts/in-env (the binds) is
checked by hand on the host, from a folder outside the repository:

    cd /tmp && /work/main/scripts/in-env shells mesh cap --theta-deg 30 -o /tmp/x.msh \\
        && ls -l /tmp/x.msh && /work/main/scripts/in-env shells info /tmp/x.msh

Here: the Python-level checks against a fake SHELLS_HOST_PATHS, the CLI's refusals for every
path argument of every subcommand (the computations are replaced by a stub that fails the test
if reached where it must not be), and scripts/in-env's mount-derived list (the Docker route).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from mpi4py import MPI
from stubs import WorkStartedError, stub_computations

from shells.cli import main, paths
from shells.errors import InputError

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def no_work(monkeypatch):
    """Every computation a subcommand starts is a stub raising WorkStartedError."""
    stub_computations(monkeypatch)


def _refused(capsys, argv, needle):
    """main(argv) exits 2 with one stderr line containing needle (rank 0 prints)."""
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, (argv, err)
    if MPI.COMM_WORLD.rank == 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1, (argv, err)
        assert needle in lines[0] and "Traceback" not in err, (argv, err)


# ------------------------------------------------------------------------------------------
# shells.cli.paths
# ------------------------------------------------------------------------------------------
def test_host_prefixes(tmp_path):
    assert paths.host_prefixes({}) is None
    assert paths.host_prefixes({"SHELLS_HOST_PATHS": ""}) == ()
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "real")
    got = paths.host_prefixes({"SHELLS_HOST_PATHS": f"{tmp_path}:relative::{tmp_path}:{link}"})
    assert got == (os.path.realpath(tmp_path), os.path.realpath(tmp_path / "real"))


def test_shared_paths_pass_and_private_ones_are_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("SHELLS_HOST_PATHS", f"{tmp_path}:/nonexistent-share")
    assert paths.check_shared(tmp_path / "a" / "b.msh", "-o") == tmp_path / "a" / "b.msh"
    assert paths.check_shared(tmp_path, "-o") == tmp_path
    for bad in ("/usr/x.msh", "/etc/passwd", "/var/tmp/out", "/opt", "/"):
        with pytest.raises(InputError, match="inside the environment's private root") as e:
            paths.check_shared(bad, "-o")
        msg = str(e.value)
        assert "\n" not in msg and msg.startswith("-o ") and str(tmp_path) in msg
    # a prefix is a folder, not a string prefix
    monkeypatch.setenv("SHELLS_HOST_PATHS", str(tmp_path / "ab"))
    with pytest.raises(InputError):
        paths.check_shared(tmp_path / "abc" / "x", "-o")


def test_relative_paths_and_symlinks_resolve_first(tmp_path, monkeypatch):
    monkeypatch.setenv("SHELLS_HOST_PATHS", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    paths.check_shared("out/x.msh", "-o")
    monkeypatch.chdir("/")
    with pytest.raises(InputError, match="private root"):
        paths.check_shared("out/x.msh", "-o")
    (tmp_path / "escape").symlink_to("/usr/share")
    with pytest.raises(InputError, match=r"\(= /usr/share/x\)"):
        paths.check_shared(tmp_path / "escape" / "x", "--png")


def test_no_list_no_check_and_empty_list_shares_nothing(monkeypatch):
    monkeypatch.delenv("SHELLS_HOST_PATHS", raising=False)
    assert paths.check_shared("/usr/x.msh", "-o") == Path("/usr/x.msh")
    monkeypatch.setenv("SHELLS_HOST_PATHS", "")
    with pytest.raises(InputError, match="no host folder is shared"):
        paths.check_shared("/tmp/x", "-o")


def test_output_dir(tmp_path, monkeypatch):
    monkeypatch.delenv("SHELLS_HOST_PATHS", raising=False)
    assert paths.check_output_dir(tmp_path, "-o") == tmp_path
    paths.check_output_dir(tmp_path / "new" / "deeper", "-o")
    assert sorted(os.listdir(tmp_path)) == []  # nothing created, no probe left behind
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="exists and is not a folder"):
        paths.check_output_dir(tmp_path / "file", "-o")
    with pytest.raises(InputError, match="'.*file' is not a folder"):
        paths.check_output_dir(tmp_path / "file" / "sub", "-o")
    for bad in ("/proc/forbidden", "/proc/forbidden/deeper", "/sys/forbidden"):
        with pytest.raises(InputError, match="cannot be written: a folder cannot be made"):
            paths.check_output_dir(bad, "-o")
    for bad in ("", "a\0b"):
        with pytest.raises(InputError, match="path"):
            paths.check_output_dir(bad, "-o")


def test_output_file(tmp_path, monkeypatch):
    monkeypatch.delenv("SHELLS_HOST_PATHS", raising=False)
    paths.check_output_file(tmp_path / "a.msh", "-o", suffixes=(".msh",))
    paths.check_output_file(tmp_path / "new" / "a.png", "--png", suffixes=(".png",))
    assert sorted(os.listdir(tmp_path)) == []
    with pytest.raises(InputError, match="must name a .msh file"):
        paths.check_output_file(tmp_path / "a.txt", "-o", suffixes=(".msh",))
    (tmp_path / "d.msh").mkdir()
    with pytest.raises(InputError, match="is a folder, not a file"):
        paths.check_output_file(tmp_path / "d.msh", "-o")
    with pytest.raises(InputError, match="cannot be written"):
        paths.check_output_file("/proc/x.png", "-o")
    with pytest.raises(InputError, match="a folder cannot be made in '/proc'"):
        paths.check_output_file("/proc/forbidden/x.msh", "-o")


# ------------------------------------------------------------------------------------------
# the CLI: every path argument of every subcommand
# ------------------------------------------------------------------------------------------
def _cli_cases(d: Path):
    sphere = ["--shape", "sphere", "--h-over-r", "0.05"]
    return {
        "mesh -o": ["mesh", "cap", "--theta-deg", "30", "-o", "{bad}/x.msh"],
        "mesh --png": ["mesh", "cap", "--theta-deg", "30", "--png", "{bad}/x.png"],
        "mesh --spec": ["mesh", "--spec", "{bad}/x.json"],
        "info": ["info", "{bad}/x.msh"],
        "render mesh": ["render", "{bad}/x.msh", "-o", str(d / "x.png")],
        "render -o": ["render", str(d / "x.msh"), "-o", "{bad}/x.png"],
        "branch -o": ["branch", *sphere, "--kappa-h-max", "1", "-o", "{bad}/b"],
        "branch axisym -o": ["branch", *sphere, "--kappa-h-max", "1", "--model", "axisym",
                             "-o", "{bad}/b"],
        "critical -o": ["critical", *sphere, "-o", "{bad}/c"],
        "critical axisym -o": ["critical", *sphere, "--model", "axisym", "-o", "{bad}/c"],
        "phase-diagram -o": ["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1", "2",
                             "--points", "2", "-o", "{bad}/pd"],
    }


@pytest.mark.parametrize("case", list(_cli_cases(Path("/x"))))
@pytest.mark.parametrize("bad", ["/usr", "/etc", "/var/lib", "/opt/shells"])
def test_cli_refuses_paths_in_the_private_root(capsys, monkeypatch, shared_tmp, no_work, case,
                                               bad):
    monkeypatch.setenv("SHELLS_HOST_PATHS", str(shared_tmp))
    argv = [a.replace("{bad}", bad) for a in _cli_cases(shared_tmp)[case]]
    _refused(capsys, argv, "is inside the environment's private root, not on the host; use a "
             f"path under {os.path.realpath(shared_tmp)}")


def test_cli_default_output_folders_are_checked_too(capsys, monkeypatch, shared_tmp, no_work):
    monkeypatch.setenv("SHELLS_HOST_PATHS", str(shared_tmp))
    monkeypatch.chdir("/")  # results/branch, results/phase-diagram: under / (the root's own)
    _refused(capsys, ["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1"],
             "-o 'results/branch' (= /results/branch) is inside")  # the default
    _refused(capsys, ["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1", "2",
                      "--points", "2"], "-o 'results/phase-diagram' (= /results/phase-diagram)")


@pytest.mark.parametrize("case", list(_cli_cases(Path("/x"))))
def test_cli_refuses_unusable_outputs(capsys, monkeypatch, shared_tmp, no_work, case):
    """Outside the env (no SHELLS_HOST_PATHS): an output under /proc cannot be made (it ended in
    a FileNotFoundError traceback after the computation); an input there is not checked here
    (its reader says it is not found)."""
    monkeypatch.delenv("SHELLS_HOST_PATHS", raising=False)
    argv = [a.replace("{bad}", "/proc/forbidden") for a in _cli_cases(shared_tmp)[case]]
    if case in ("mesh --spec", "info", "render mesh"):
        _refused(capsys, argv, "not found")
    else:
        _refused(capsys, argv, "cannot be written: a folder cannot be made in '/proc'")


def test_cli_refuses_a_file_as_output_folder_and_a_folder_as_output_file(capsys, monkeypatch,
                                                                         shared_tmp, no_work):
    monkeypatch.delenv("SHELLS_HOST_PATHS", raising=False)
    f, d = shared_tmp / "plain.txt", shared_tmp / "folder.msh"
    if MPI.COMM_WORLD.rank == 0:
        f.write_text("x")
        d.mkdir()
    MPI.COMM_WORLD.barrier()
    _refused(capsys, ["critical", "--shape", "sphere", "--h-over-r", "0.05", "-o", str(f)],
             "exists and is not a folder")
    _refused(capsys, ["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1",
                      "-o", str(f / "sub")], "is not a folder")
    _refused(capsys, ["mesh", "sphere", "-o", str(d)], "is a folder, not a file")
    _refused(capsys, ["mesh", "sphere", "--png", str(shared_tmp / "x.jpg")],
             "--png must name a .png file")


def test_cli_accepted_paths_reach_the_work_and_create_nothing(monkeypatch, shared_tmp, no_work):
    monkeypatch.setenv("SHELLS_HOST_PATHS", str(shared_tmp))
    out = shared_tmp / "new" / "deeper"
    for argv in (["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1",
                  "-o", str(out)],
                 ["mesh", "cap", "--theta-deg", "30", "-o", str(out / "x.msh"), "--png",
                  str(out / "x.png")],
                 ["critical", "--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                  "--model", "axisym", "-o", str(out)]):
        with pytest.raises(WorkStartedError):
            main(argv)
    # rank 0 holds the output folder and removes what it made for it: read there
    comm = MPI.COMM_WORLD
    assert comm.bcast(not (shared_tmp / "new").exists() if comm.rank == 0 else None)


# ------------------------------------------------------------------------------------------
# scripts/in-env as the Docker image's entrypoint: SHELLS_HOST_PATHS from the mounts
# ------------------------------------------------------------------------------------------
def _mounted_folders() -> list[str]:
    """The mount points in /proc/self/mountinfo that scripts/in-env should list (read here
    independently: its octal escapes decoded, /, /proc, /sys, /dev and non-folders left out)."""
    import re

    out = []
    with open("/proc/self/mountinfo") as f:
        for line in f:
            mp = re.sub(r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)), line.split()[4])
            if mp == "/" or ":" in mp or re.match(r"/(proc|sys|dev)(/|$)", mp):
                continue
            if os.path.isdir(mp):
                out.append(mp)
    return out


def test_in_env_lists_the_mounted_folders():
    env = {k: v for k, v in os.environ.items() if k != "SHELLS_HOST_PATHS"}
    env["SHELLS_HOST_PATHS_FROM"] = "mountinfo"
    out = subprocess.run([str(REPO / "scripts" / "in-env"), "bash", "-c",
                          'printf "%s" "${SHELLS_HOST_PATHS-unset}"'], env=env,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    listed = out.stdout.split(":") if out.stdout else []
    assert out.stdout != "unset" and listed == _mounted_folders()
    # inside the scripts/in-env root, every folder bound from the host is a mount point
    if os.environ.get("SHELLS_IN_ENV") == "1":
        for p in (os.environ.get("SHELLS_HOST_PATHS") or "").split(":"):
            if p and p != "/":
                assert p in listed, (p, listed)
