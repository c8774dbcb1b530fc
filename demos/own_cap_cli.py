r"""Your own cap, from the command line
===================================

The same questions without writing Python: the ``shells`` command. For a cap of radius
25 mm, thickness 1 mm, half opening angle 30° (θ̄ = θ/√(h/R) = 2.6):

.. code-block:: sh

    shells critical --shape cap --theta-deg 30 --radius 25mm --thickness 1mm \
        --model axisym --json

prints one line per critical point (the snap-through fold of this cap going up) and, with
``--json``, a last line of JSON that scripts read. ``--direction down`` asks for the loss of
symmetry under κ < 0. ``--model axisym`` is the 1D model (seconds); without it the command
runs the surface model (the first output line says which model runs), about 0.1 % away at
its default mesh.
This demo runs the command and reads its JSON, then computes the same cap from Python:
both give the same number to the last digit (the command is a thin layer over the API).
"""

# %%
import json
import os
import subprocess
import sys

from mpi4py import MPI

import shells

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
rank0 = MPI.COMM_WORLD.rank == 0
ARGS = ["critical", "--shape", "cap", "--theta-deg", "30", "--radius", "25mm",
        "--thickness", "1mm", "--model", "axisym", "--json"]

# %% [markdown]
# Running the command
# -------------------
#
# (``python3 -m shells`` is the ``shells`` command.) The child process is started without
# the MPI variables of this one, so that under ``mpirun`` it runs on its own rather than
# joining this job; rank 0 runs it and shares the answer.


# %%
def clean_env() -> dict[str, str]:
    """This process's environment without the MPI job's variables."""
    keep = ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "OMPI_MCA_btl")
    return {k: v for k, v in os.environ.items()
            if k.startswith(keep) or not k.startswith(("OMPI_", "PMIX_", "PRTE_"))}


out = None
if rank0:
    proc = subprocess.run([sys.executable, "-m", "shells", *ARGS], capture_output=True,
                          text=True, env=clean_env(), check=True)
    print("$ shells " + " ".join(ARGS))
    print(proc.stdout.strip())
    out = json.loads(proc.stdout.strip().splitlines()[-1])
out = MPI.COMM_WORLD.bcast(out, root=0)

# %% [markdown]
# The same cap from Python
# ------------------------

# %%
shell = shells.Shell(shells.cap(theta_deg=30, radius="25 mm"), thickness="1 mm")
res = shells.critical(shell, direction="up")
if rank0:
    print(f"Python: {res.kind} at kappa R = {res.kappa_R!r} ({res.kappa:.2f~P})")
    print(f"JSON:   {out['kind']} at kappa R = {out['kappa_R']!r}")

# %% [markdown]
# Checks
# ------
#
# The 30° cap at h/R = 0.04 snaps at its fold, κR = 1.3934 (the 1D model), on both paths.

# %%
assert out["kind"] == res.kind == "fold"
assert out["kappa_R"] == res.kappa_R
assert abs(res.kappa_R - 1.39343) < 1e-4
