"""The energy's mirror symmetry on the surface model, against the mesh: the everted cap at κ
(Newton from the cap mirrored through its rim plane, the mirror chart of
``ShellModel.set_everted_guess``) against the original cap at 2/R - κ, 60° and 90° caps at
h/R = 0.04 (issue 13's must-hold: 1e-6 relative). The difference is the mesh's departure from
the sphere (b° = -a°/R to O(size³)); tests/test_director.py runs the coarsest mesh.

    scripts/in-env mpirun -n 2 python3 benchmarks/everted_mirror.py

Writes benchmarks/results/everted_mirror.json and prints a table.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from mpi4py import MPI

from shells.algorithms.newton import NewtonSolver
from shells.geometry.shapes import SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel

H = 0.04
#: (opening angle, κR of the everted cap, bulk size, elements across the rim layer)
CASES = [(60, 1.8, 0.2, 3.0), (60, 1.8, 0.2, 5.0), (90, 1.5, 0.2, 3.0), (90, 1.5, 0.2, 5.0),
         (90, 1.5, 0.12, 5.0), (90, 1.5, 0.07, 5.0)]


def solve(model: ShellModel, kappas: list[float]) -> dict:
    ns = NewtonSolver(model)
    for k in kappas:
        model.kappa.value = k
        ok, _ = ns.solve()
        if not ok:
            raise RuntimeError(f"Newton failed at kappa R = {k}")
    ns.destroy()
    return model.scalars()


def main() -> None:
    out = []
    for deg, kr, size, layer in CASES:
        t0 = time.perf_counter()
        sm = generate(MeshSpec(SphericalCap(1.0, math.radians(deg)), h=H, size=size,
                               layer_elements=layer), MPI.COMM_WORLD)
        orig = solve(ShellModel(sm, ModelParameters(h=H, nu=0.5)),
                     [(2 - kr) * s for s in (0.5, 1.0)])
        model = ShellModel(sm, ModelParameters(h=H, nu=0.5))
        model.set_everted_guess()
        ever = solve(model, [2.0, (2.0 + kr) / 2, kr])
        rel = abs(ever["energy"] - orig["energy"]) / abs(orig["energy"])
        out.append({"theta_deg": deg, "kappa_R": kr, "kappa_R_original": 2 - kr,
                    "size": size, "layer_elements": layer, "dofs": model.num_dofs(),
                    "energy_everted": ever["energy"], "energy_original": orig["energy"],
                    "relative_difference": rel,
                    "rim_rotation_everted_deg": ever["rim_rotation_deg"],
                    "rim_rotation_original_deg": orig["rim_rotation_deg"],
                    "time_s": time.perf_counter() - t0, "ranks": MPI.COMM_WORLD.size})
    if MPI.COMM_WORLD.rank == 0:
        path = Path(__file__).parent / "results" / "everted_mirror.json"
        path.write_text(json.dumps(out, indent=1))
        print(f"{'cap':>4} {'kR':>5} {'size':>5} {'layer':>5} {'DOFs':>7} {'rel diff':>9} "
              f"{'rim rot':>8} {'time':>6}")
        for r in out:
            print(f"{r['theta_deg']:4d} {r['kappa_R']:5.2f} {r['size']:5.2f} "
                  f"{r['layer_elements']:5.1f} {r['dofs']:7d} {r['relative_difference']:9.2e} "
                  f"{r['rim_rotation_everted_deg']:8.2f} {r['time_s']:5.0f}s")


if __name__ == "__main__":
    main()
