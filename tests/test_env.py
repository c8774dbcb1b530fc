"""The environment's cache of roots and runs side by side (issue 43).

* ``scripts/in-env --gc`` and ``--list`` on a cache of fake roots (folders with a root's name
  and completeness marker; no debootstrap): a root is removed only when unused for the maximum
  age (``--max-age-days``, ``SHELLS_ENV_MAX_AGE_DAYS``) and not in use (its lock held shared,
  as every in-env call holds it for its command, or a process chrooted in it), one line per
  removed folder with the space freed; what interrupted builds left goes too; nothing is
  removed while a build holds the folder's build lock; ``--list`` shows each root's env, key,
  size, last use and use, and the cache's total. The real roots, built and used side by side:
  ``scripts/test-env-coexist``.
* An output folder is held by one run: a second run into it (1 or 2 ranks) is refused with one
  line, exit 2, and the first ends with the uninterrupted run's records; the folders made for a
  run that leaves them empty are removed.
* Runs at once (two ``shells critical`` processes with an empty form cache, two 2-rank jobs)
  end with the results of a run alone.

Subprocesses are started by rank 0 only (with the environment of no MPI job), the others wait
for its verdict, so every test is valid on any number of ranks. The runs' tests start their own
1- and 2-rank runs, whatever this process's rank count: they run in the serial pass only.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import child_env
from mpi4py import MPI

from shells.errors import InputError
from shells.files import RUN_LOCK, hold_output_folder, read_records

REPO = Path(__file__).resolve().parent.parent
IN_ENV = REPO / "scripts" / "in-env"
WORLD = MPI.COMM_WORLD
DAY = 86400.0
#: the runs' tests start their own 1- and 2-rank runs: once, in the serial pass
serial_only = pytest.mark.skipif(WORLD.size > 1, reason="starts its own 1- and 2-rank runs")

#: the fast 1D case of the issue: a fold at kappa R = 1.3934 in a few seconds
CRITICAL = ["critical", "--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04", "--model",
            "axisym", "--json"]
BRANCH = ["branch", "--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
          "--kappa-r-max", "1.3", "--model", "axisym"]

def on_rank0(fn: Callable[[], None]) -> None:
    """fn() on rank 0 (it starts processes), its AssertionError or other exception raised on
    every rank. The others wait asleep, not in a collective that spins a core the processes
    need."""
    err = None
    if WORLD.rank == 0:
        try:
            fn()
        except Exception as e:  # noqa: BLE001 - reported on every rank
            err = f"{type(e).__name__}: {e}"
    req = WORLD.Ibarrier()
    while not req.Test():
        time.sleep(0.05)
    err = WORLD.bcast(err, root=0)
    assert err is None, err


# ------------------------------------------------------------------------------------------
# scripts/in-env --gc, --list on fake roots
# ------------------------------------------------------------------------------------------
def list_key(pkglist: Path) -> str:
    """scripts/in-env's key of a package list: the packages (comments dropped, blanks
    squeezed to one space) and a version tag, hashed."""
    import hashlib

    text = "\n".join(re.sub(r"#.*", "", ln) for ln in pkglist.read_text().split("\n"))
    packages = re.sub(r"[ \t\n]+", " ", text)
    return hashlib.sha256(f"{packages}\nin-env-v1\n".encode()).hexdigest()[:16]


def fake_root(folder: Path, key: str, *, days_ago: float, env: str = "main",
              size: int = 0) -> Path:
    """A complete root's look (python3 and the env's completeness marker) in ``folder``, last
    used ``days_ago`` days ago (its lock file's mtime), holding ``size`` bytes more."""
    root = folder / f"trixie-{key}"
    (root / "usr" / "bin").mkdir(parents=True)
    (root / "usr" / "bin" / "python3").write_text("")
    marker = root / ("usr/local/bin/shells" if env == "main" else "etc/shells-env")
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text("")
    (root / "data").write_bytes(b"\0" * size)
    lock = folder / f"trixie-{key}.lock"
    lock.write_text("")
    t = time.time() - days_ago * DAY
    os.utime(lock, (t, t))
    return root


def in_env(cache: Path, *args: str, timeout: float = 60, **env: str
           ) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", str(IN_ENV), *args], capture_output=True, text=True,
                          timeout=timeout, env=child_env(SHELLS_ENV_CACHE=str(cache), **env))


class Holder:
    """A root's lock held shared, as an in-env call and its command hold it."""

    def __init__(self, root: Path) -> None:
        self.fd = os.open(f"{root}.lock", os.O_RDONLY)
        fcntl.flock(self.fd, fcntl.LOCK_SH)

    def release(self) -> None:
        os.close(self.fd)


def removed(out: str) -> list[str]:
    """The folders that --gc's lines say it removed (their last path part)."""
    return sorted(Path(m).name for m in re.findall(r"in-env: removed .*?(/\S+)", out))


def test_gc_removes_only_roots_unused_for_the_age_and_not_in_use(tmp_path):
    def check() -> None:
        cache = tmp_path / "cache"
        old = fake_root(cache, "a" * 16, days_ago=10, size=1 << 20)
        held = fake_root(cache, "b" * 16, days_ago=10)
        recent = fake_root(cache, "c" * 16, days_ago=1)
        pv = fake_root(cache / "paraview", "d" * 16, days_ago=30, env="paraview")
        (cache / f"trixie-{'e' * 16}.partial" / "usr").mkdir(parents=True)
        (cache / f"trixie-{'f' * 16}.lock").write_text("")  # a failed build's: no root
        holder = Holder(held)
        try:
            r = in_env(cache, "--gc")
            assert r.returncode == 0 and not r.stderr, r
            assert removed(r.stdout) == sorted([old.name, f"trixie-{'e' * 16}.partial",
                                                pv.name]), r.stdout
            line = next(ln for ln in r.stdout.splitlines() if old.name in ln)
            assert re.search(r"main env's root .* days ago\): freed 1\.\dMiB$", line), line
            assert f"kept the main env's root {held.name}: in use" in r.stdout
            assert held.is_dir() and recent.is_dir() and not old.exists() and not pv.exists()
            assert not (cache / f"trixie-{'f' * 16}.lock").exists()
            assert not Path(f"{old}.lock").exists() and not Path(f"{old}.removing").exists()
            r = in_env(cache, "--gc", "--max-age-days", "0")
            assert removed(r.stdout) == [recent.name] and held.is_dir(), r.stdout
        finally:
            holder.release()
        r = in_env(cache, "--gc", SHELLS_ENV_MAX_AGE_DAYS="0")
        assert removed(r.stdout) == [held.name], r.stdout
        r = in_env(cache, "--gc")
        assert r.returncode == 0 and r.stdout.startswith("in-env: nothing to remove"), r
        assert sorted(p.name for p in cache.rglob("trixie-*")) == []

    on_rank0(check)


def test_list_shows_each_root_and_the_total(tmp_path):
    def check() -> None:
        cache = tmp_path / "cache"
        mine = list_key(REPO / "deps" / "debian-packages.txt")
        fake_root(cache, mine, days_ago=0, size=3 << 20)
        other = fake_root(cache, "1" * 16, days_ago=2.5)
        fake_root(cache / "paraview", "2" * 16, days_ago=0, env="paraview")
        (cache / f"trixie-{'3' * 16}.partial").mkdir()
        holder = Holder(other)
        try:
            r = in_env(cache, "--list")
        finally:
            holder.release()
        assert r.returncode == 0 and not r.stderr, r
        rows = {ln.split()[1]: ln for ln in r.stdout.splitlines()[1:-1]}
        assert re.match(rf"main +{mine} +3\.\dMiB +\d{{4}}-\d\d-\d\d \d\d:\d\d UTC +unused, "
                        "this checkout's$", rows[mine]), r.stdout
        assert rows["1" * 16].startswith("main ") and rows["1" * 16].endswith(" in use")
        assert rows["2" * 16].startswith("paraview ") and rows["2" * 16].endswith(" unused")
        assert "half-built" in rows["3" * 16]
        assert re.fullmatch(rf"total 3\.\dMiB in {re.escape(str(cache))} \(3 roots\)",
                            r.stdout.splitlines()[-1]), r.stdout
        r = in_env(tmp_path / "none", "--list")
        assert r.returncode == 0 and "does not exist" in r.stdout, r

    on_rank0(check)


def test_a_process_chrooted_in_a_root_keeps_it(tmp_path):
    """A process chrooted in a root that took no lock (as one started by an older in-env) makes
    the root in use: kept by --gc, its last use set to now."""

    def check() -> None:
        cache = tmp_path / "cache"
        root = fake_root(cache, "a" * 16, days_ago=10)
        ldd = subprocess.run(["ldd", "/bin/sleep"], capture_output=True, text=True).stdout
        for f in ["/bin/sleep", *re.findall(r"(/\S+) \(0x", ldd)]:
            (root / f[1:]).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, root / f[1:])
        p = subprocess.Popen(["chroot", str(root), "/bin/sleep", "60"])
        try:
            t0 = time.monotonic()
            while os.readlink(f"/proc/{p.pid}/root") != str(root):
                assert p.poll() is None and time.monotonic() - t0 < 10, "not chrooted"
                time.sleep(0.01)
            r = in_env(cache, "--list")
            assert r.stdout.splitlines()[1].endswith(" in use"), r.stdout
            r = in_env(cache, "--gc", "--max-age-days", "0")
            assert f"kept the main env's root {root.name}: in use" in r.stdout and root.is_dir()
            assert time.time() - os.stat(f"{root}.lock").st_mtime < 60
        finally:
            p.kill()
            p.wait()
        r = in_env(cache, "--gc", "--max-age-days", "0")
        assert removed(r.stdout) == [root.name], r.stdout

    on_rank0(check)


def test_gc_waits_for_a_build_and_refuses_bad_arguments(tmp_path):
    def check() -> None:
        cache = tmp_path / "cache"
        old = fake_root(cache, "a" * 16, days_ago=10)
        build = os.open(f"{cache}.lock", os.O_RDWR | os.O_CREAT)
        fcntl.flock(build, fcntl.LOCK_EX)  # a build in progress in this folder
        try:
            p = subprocess.Popen(["bash", str(IN_ENV), "--gc"], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True,
                                 env=child_env(SHELLS_ENV_CACHE=str(cache)))
            time.sleep(3.0)  # past the 2 s waited for without a word
            assert p.poll() is None and old.is_dir()  # nothing removed during a build
        finally:
            os.close(build)
        out, err = p.communicate(timeout=60)
        assert p.returncode == 0, (out, err)
        assert "waiting for the build or removal in progress" in out, out
        assert removed(out) == [old.name] and not old.exists(), out
        for args, env in ((["--gc", "--max-age-days", "x"], {}), (["--gc", "--frob"], {}),
                          (["--list", "x"], {}), (["--gc"], {"SHELLS_ENV_MAX_AGE_DAYS": "-1"})):
            r = in_env(cache, *args, **env)
            lines = r.stderr.splitlines()
            assert r.returncode == 2 and len(lines) == 1 and not r.stdout, (args, r)

    on_rank0(check)


# ------------------------------------------------------------------------------------------
# the output folder: one run at a time
# ------------------------------------------------------------------------------------------
def test_hold_output_folder(shared_tmp):
    out = shared_tmp / "new" / "out"
    with hold_output_folder(out, WORLD):
        held = WORLD.bcast(out.is_dir() and (out / RUN_LOCK).read_text() if WORLD.rank == 0
                           else None)
        assert held.startswith(f"pid {WORLD.bcast(os.getpid())} on ")
        with pytest.raises(InputError, match=r"^-o '.*out' is the output folder of a run in "
                           r"progress \(pid \d+ on .*\): wait for it to end"):
            with hold_output_folder(out, WORLD):
                pass
    # made for the run, left empty: removed by rank 0, which holds the folder (read there: the
    # 2-rank suite once saw the folder on rank 1 after rank 0 had removed it)
    assert WORLD.bcast(not (shared_tmp / "new").exists() if WORLD.rank == 0 else None)
    with hold_output_folder(out, WORLD, "--out"):
        if WORLD.rank == 0:
            (out / "result").write_text("x")
    WORLD.barrier()
    assert sorted(os.listdir(out)) == ["result"]
    with hold_output_folder(out, WORLD):  # the next run takes it
        pass


def shells(argv: list[str], ranks: int = 1) -> list[str]:
    """The command of ``shells ARGV`` on ``ranks`` ranks."""
    cmd = [sys.executable, "-m", "shells", *argv]
    return cmd if ranks == 1 else ["mpirun", "-n", str(ranks), *cmd]


def results(path: Path) -> list[dict[str, Any]]:
    """A file's records without their timings."""
    return [{k: v for k, v in r.items() if "time" not in k} for r in read_records(path)]


def json_result(stdout: str) -> dict[str, Any]:
    """The JSON last line of a run, without its timings and the paths of its files."""
    res = json.loads(stdout.strip().splitlines()[-1])
    return {k: v for k, v in res.items() if "time" not in k and not k.endswith("_file")}


@serial_only
def test_a_second_run_into_a_folder_in_use_is_refused(shared_tmp):
    """A run is stopped (SIGSTOP) while it holds its folder; a second run into that folder, on
    1 and on 2 ranks, is refused with one line and exit 2; the first, continued, ends with the
    records of a run alone."""

    def check() -> None:
        ref = shared_tmp / "ref"
        r = subprocess.run(shells([*BRANCH, "-o", str(ref)]), cwd=REPO, env=child_env(),
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        out = shared_tmp / "out"
        first = subprocess.Popen(shells([*BRANCH, "-o", str(out)]), cwd=REPO, env=child_env(),
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            t0 = time.monotonic()
            while not (out / RUN_LOCK).is_file() or not (out / RUN_LOCK).read_text():
                assert first.poll() is None and time.monotonic() - t0 < 60, "no lock taken"
                time.sleep(0.005)
            first.send_signal(signal.SIGSTOP)
            for ranks in (1, 2):
                r = subprocess.run(shells([*BRANCH, "-o", str(out)], ranks), cwd=REPO,
                                   env=child_env(), capture_output=True, text=True,
                                   timeout=120)
                lines = [ln for ln in r.stderr.splitlines() if ln.startswith("shells")]
                assert r.returncode == 2 and len(lines) == 1, (ranks, r.stderr)
                assert f"is the output folder of a run in progress (pid {first.pid} on" \
                    in lines[0] and "Traceback" not in r.stderr, (ranks, r.stderr)
        finally:
            first.send_signal(signal.SIGCONT)
            _, err = first.communicate(timeout=120)
        assert first.returncode == 0, err
        assert results(out / "branch.jsonl") == results(ref / "branch.jsonl")
        assert not (out / RUN_LOCK).exists()

    on_rank0(check)


@serial_only
def test_runs_at_once_end_with_the_results_of_a_run_alone(shared_tmp):
    """Two ``shells critical`` processes started at once (one with an output folder, one
    without) into an empty form and FFCx cache, where both compile the same forms, and then two
    2-rank jobs at once into two folders: each ends with the result of a run alone."""

    def check() -> None:
        def at_once(cmds: list[list[str]], **env: str) -> list[dict[str, Any]]:
            ps = [subprocess.Popen(c, cwd=REPO, env=child_env(**env), stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True) for c in cmds]
            outs = [p.communicate(timeout=400) for p in ps]
            for p, (_, err) in zip(ps, outs, strict=True):
                assert p.returncode == 0, err[-2000:]
            return [json_result(o) for o, _ in outs]

        (alone,) = at_once([shells(CRITICAL)])
        assert alone["kind"] == "fold" and alone["kappa_R"] == pytest.approx(1.39343, abs=1e-5)
        cold = str(shared_tmp / "cache")
        got = at_once([shells([*CRITICAL, "-o", str(shared_tmp / "a")]), shells(CRITICAL)],
                      XDG_CACHE_HOME=cold)
        assert got == [alone, alone]
        (alone2,) = at_once([shells(CRITICAL, 2)])
        got = at_once([shells([*CRITICAL, "-o", str(shared_tmp / f"m{i}")], 2) for i in (1, 2)])
        assert got == [alone2, alone2]

    on_rank0(check)
