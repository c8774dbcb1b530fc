"""The mesh's pinning of a pattern's orientation, and the two methods' landings (issue 41).

The θ̄ = 5 cap (h/R = 0.04, the paper's Fig. 1 d) lands in an m = 2 state by minimisation and by
dynamics. In the continuum that state turned about the axis is the same state, of the same
energy; a mesh pins its orientation weakly, so two landings at different orientations differ in
energy by a discretisation error. This script takes the two landing states (the checkpoints of
two `shells snap -o DIR` runs, `--method minimise` and `--method dynamics`, on one mesh),
converges each on that mesh (``minimise_to_stable``: TAO, then Newton modulo the orbit), and
then interpolates each onto finer meshes and converges it there, keeping its orientation. It
reports on the first mesh how much of the two states' difference lies along the orbit (the
Hessian's eigenvector that turns the pattern), and on every mesh the two energies and their
relative difference: the pinning between the two orientations, as the mesh is refined.

    scripts/in-env python3 benchmarks/snap_orbit_pinning.py MIN_DIR DYN_DIR
        [--meshes SIZE:LAYER ...]   (default: the runs' own mesh, 0.25:3, 0.2:4)

Writes benchmarks/results/snap_orbit_pinning.json (``--out``) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

OUT = Path("benchmarks/results/snap_orbit_pinning.json")


def build(header: dict, size: float, layer: float):
    """The surface model of a snap run's header on the mesh (size, layer elements)."""
    from mpi4py import MPI

    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel, default_discretisation

    sh = header["shape"]
    shape = SphericalCap(radius=sh["R"], theta=sh["theta"])
    degree, size = default_discretisation(shape, header["h_over_r"], header["degree"], size,
                                          None, header["nu"])
    h = header["h_over_r"] * shape.characteristic_size()
    mesh = generate(MeshSpec(shape, h=h, size=size, layer_elements=layer), MPI.COMM_WORLD)
    params = ModelParameters(h=h, nu=header["nu"], shear_penalty=header["shear_penalty"],
                             degree=degree, quadrature_degree=2 * degree)
    model = ShellModel(mesh, params)
    model.shell_size, model.shell_layer = size, layer
    return model


def transfer(src, dst, angle: float = 0.0) -> None:
    """dst's state = src's turned by ``angle`` about the axis, interpolated (non-matching
    meshes of the same surface: src's mesh and state are turned, then put back)."""
    from dolfinx import fem

    c, s = math.cos(angle), math.sin(angle)
    Q = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    x0, w0 = src.shell.mesh.geometry.x.copy(), src.w.x.array.copy()
    src.shell.mesh.geometry.x[:] = x0 @ Q.T
    w = src.w.x.array.reshape(-1, 6)
    w[:, :3], w[:, 3:] = w[:, :3] @ Q.T, w[:, 3:] @ Q.T  # u and θ are Cartesian vectors
    V = dst.W
    cmap = V.mesh.topology.index_map(V.mesh.topology.dim)
    cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
    # the two meshes approximate the curved surface by different facets: points of one lie
    # off the other by the geometry's error, well below this padding
    data = fem.create_interpolation_data(V, src.W, cells, padding=1e-3)
    dst.w.interpolate_nonmatching(src.w, cells, data)
    dst.w.x.scatter_forward()
    src.shell.mesh.geometry.x[:] = x0
    src.w.x.array[:] = w0
    if angle:
        regauge(dst)


def _rotation(w: np.ndarray) -> np.ndarray:
    """exp([w]×) (Rodrigues)."""
    a = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if a == 0.0:
        return np.eye(3)
    return np.eye(3) + math.sin(a) / a * K + (1 - math.cos(a)) / a**2 * (K @ K)


def regauge(model) -> None:
    """Meet the rigid-motion gauge again after the state was turned about the axis: turn the
    deformed shell (and its director) rigidly about the pole until u_y = 0 at the gauge points
    B and D and u_x = 0 at C (``ShellModel._supports``'s points). A rigid turn of the whole
    configuration changes no strain, so the energy is that of the turned state; without it
    the turned state's values at those points would be held wrong and strain the shell."""
    from mpi4py import MPI

    from shells.problem.interface import get_state, set_state

    comm = model.shell.comm
    X = model.owned_dof_coordinates()
    w = get_state(model).reshape(-1, 6)
    top, B, C, D = (np.asarray(q) for q in model.support_points)

    def value_at(q: np.ndarray) -> np.ndarray:
        d = np.linalg.norm(X - q, axis=1)
        mine = np.zeros(3)
        if d.size and d.min() < 1e-12:
            mine = w[int(np.argmin(d)), :3].copy()
        return comm.allreduce(mine, op=MPI.SUM)

    YB, YC, YD = (q + value_at(q) - top for q in (B, C, D))

    def residual(om: np.ndarray) -> np.ndarray:
        P = _rotation(om)
        return np.array([(P @ YB)[1] + top[1] - B[1], (P @ YD)[1] + top[1] - D[1],
                         (P @ YC)[0] + top[0] - C[0]])

    om = np.zeros(3)
    for _ in range(20):
        f = residual(om)
        if np.abs(f).max() < 1e-15:
            break
        J = np.column_stack([(residual(om + 1e-7 * e) - f) / 1e-7 for e in np.eye(3)])
        om = om - np.linalg.solve(J, f)
    # the turn about the pole, the director with it: the frame's own
    set_state(model, model.rigid_frame().aligned_state(_rotation(om)))


def orientation(model, frame: bool = True) -> float:
    """ψ of the state's m = 2 pattern, w·n° ∝ cos 2(φ - ψ): ½ atan2 of its moments against
    2xy and x² - y², read in the shell's best-fit rigid frame (``frame``; else in the gauge's
    representative, whose tilt biases it by an amount that depends on ψ itself; collective)."""
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    if frame:
        with model.rigid_frame().aligned():
            return orientation(model, frame=False)
    x = ufl.SpatialCoordinate(model.shell.mesh)
    wn = ufl.dot(model.split(model.w)[0], model.n0)
    m = [model.shell.comm.allreduce(fem.assemble_scalar(fem.form(wn * f * model.dx)),
                                    op=MPI.SUM) for f in (x[0] ** 2 - x[1] ** 2, 2 * x[0] * x[1])]
    return 0.5 * math.atan2(m[1], m[0])


def converge(model) -> dict:
    from shells.algorithms.minimise import minimise_to_stable

    t0 = time.perf_counter()
    res = minimise_to_stable(model)
    return {"energy": res.energy, "reason": res.reason, "iterations": res.iterations,
            "gradient_norm": res.gradient_norm, "orbit_gradient": res.orbit_gradient,
            "stable": res.negative_count == res.orbit_modes,
            "negative_count": res.negative_count, "orbit_modes": res.orbit_modes,
            "wall_s": time.perf_counter() - t0}


def orbit_share(model, a: np.ndarray, b: np.ndarray) -> dict:
    """The mass norm of b - a and of its part along the Hessian's orbit mode at a."""
    from shells.algorithms.stability import Stability
    from shells.problem.interface import set_state

    set_state(model, a)
    stab = Stability(model)
    vals, vecs = stab.eigenpairs(4, modes=True)
    M = model.assemble_mass(None)
    d = model.create_vector()
    d.array_w[:] = (b - a)[: d.getLocalSize()]
    Md = d.duplicate()
    M.mult(d, Md)
    out = {"difference_mass_norm": math.sqrt(d.dot(Md))}
    for mu, v in zip(vals, vecs, strict=True):
        if model.classify_mode(v, None).rayleigh.get("orbit", 0.0) >= 0.7:
            Mv = v.duplicate()
            M.mult(v, Mv)
            out.update(orbit_eigenvalue=mu, along_orbit_mode=abs(d.dot(Mv)) / math.sqrt(v.dot(Mv)))
            break
    stab.destroy()
    return out


def aligned(first, header: dict, ends: dict, kappa: float) -> dict:
    """The dynamics' landing turned to the minimiser's orientation (its m = 2 pattern's ψ, the
    turn by π that brings it closer), interpolated and converged on the same mesh: at one
    orientation the two landings are the same discrete state, or not."""
    from shells.problem.interface import get_state, set_state

    other = build(header, header["size"], header["layer_elements"])
    psi = {}
    for name in ("minimise", "dynamics"):
        set_state(first, ends[name])
        psi[name] = orientation(first)
    set_state(other, ends["dynamics"])
    other.set_kappa(kappa)
    first.set_kappa(kappa)
    best = None
    for turn in (0.0, math.pi):
        angle = psi["minimise"] - psi["dynamics"] + turn
        transfer(other, first, angle)
        d = first.create_vector()
        d.array_w[:] = get_state(first) - ends["minimise"][: d.getLocalSize()]
        dist = d.norm()
        d.destroy()
        if best is None or dist < best[1]:
            best = (angle, dist, get_state(first))
    angle, dist, w = best
    set_state(first, w)
    out = converge(first)
    ref = first.create_vector()
    ref.array_w[:] = ends["minimise"][: ref.getLocalSize()]
    d = ref.copy()
    d.array_w[:] = get_state(first) - ref.array_r
    out.update(turn_deg=math.degrees(angle), psi_deg={k: math.degrees(v) for k, v in psi.items()},
               distance_before=dist / ref.norm(), distance_after=d.norm() / ref.norm())
    return out


def landscape(model, header: dict, start: np.ndarray, kappa: float, samples: int) -> dict:
    """The energy along the orbit: the landing ``start`` turned by k/``samples`` of the mesh's
    period 2π/sectors (k = 1 ... samples - 1; the gauge met again, ``regauge``) and converged
    (``minimise_to_stable``; it keeps the orientation but for a small drift, so each point is
    recorded at the orientation ψ it ends at)."""
    from shells.problem.interface import set_state
    from shells.surface.mesh import MeshSpec

    sectors = MeshSpec(model.shape, h=1.0).sectors
    other = build(header, model.shell_size, model.shell_layer)
    other.set_kappa(kappa)
    set_state(other, start)
    model.set_kappa(kappa)
    points = [{"turn_deg": 0.0, "psi_deg": math.degrees(orientation(other)),
               "energy": other.total_energy()}]
    for k in range(1, samples):
        angle = 2 * math.pi / sectors * k / samples
        transfer(other, model, angle)
        res = converge(model)
        if res["stable"] and res["reason"].startswith("CONVERGED"):
            points.append({"turn_deg": math.degrees(angle),
                           "psi_deg": math.degrees(orientation(model)),
                           "energy": res["energy"], "iterations": res["iterations"]})
    e = np.array([q["energy"] for q in points])
    return {"sectors": sectors, "points": points,
            "amplitude": float((e.max() - e.min()) / abs(e.mean()))}


def main() -> None:
    from mpi4py import MPI

    from shells.analyses.store import load_state_checkpoint
    from shells.problem.interface import get_state, set_state

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("min_dir", type=Path)
    ap.add_argument("dyn_dir", type=Path)
    ap.add_argument("--meshes", nargs="*", default=None)
    ap.add_argument("--out", type=Path, default=OUT, help="the JSON written")
    ap.add_argument("--samples", type=int, default=6,
                    help="orientations over the mesh's period for the pinning landscape")
    a = ap.parse_args()
    runs = {"minimise": a.min_dir, "dynamics": a.dyn_dir}
    metas = {k: json.loads((d / "checkpoint" / "meta.json").read_text()) for k, d in runs.items()}
    header = metas["minimise"]["header"]
    meshes = [(header["size"], header["layer_elements"])] + [
        (float(s), float(L)) for s, L in (m.split(":") for m in (
            a.meshes if a.meshes is not None else ["0.25:3", "0.2:4"]))]
    first = build(header, *meshes[0])
    states, kappas, rows = {}, {}, []
    for name, d in runs.items():
        meta, got, _ = load_state_checkpoint(d / "checkpoint", first, ("w",))
        kappas[name] = (1 + header["past"]) * meta["kappa_fold"]
        states[name] = got["w"]
    comm = MPI.COMM_WORLD
    for i, (size, layer) in enumerate(meshes):
        model = first if i == 0 else build(header, size, layer)
        row = {"size": model.shell_size, "layer_elements": layer, "dofs": model.num_dofs()}
        ends = {}
        for name in runs:
            model.set_kappa(kappas[name])
            if i == 0:
                set_state(model, states[name])
            else:
                set_state(first, states[name])
                transfer(first, model)
            row[name] = converge(model)
            ends[name] = get_state(model)
            if i == 0:
                states[name] = ends[name]
        if a.samples > 1:
            row["landscape"] = landscape(model, header, ends["dynamics"], kappas["dynamics"],
                                         a.samples)
        e_min, e_dyn = row["minimise"]["energy"], row["dynamics"]["energy"]
        row["relative_difference"] = (e_min - e_dyn) / abs(e_dyn)
        if i == 0:
            row["orbit_share"] = orbit_share(model, ends["minimise"], ends["dynamics"])
            row["dynamics_turned"] = aligned(model, header, ends, kappas["minimise"])
            row["dynamics_turned"]["relative_difference"] = (
                (e_min - row["dynamics_turned"]["energy"]) / abs(e_min))
        rows.append(row)
        if comm.rank == 0:
            a.out.write_text(json.dumps({"header": header, "runs": {k: str(v) for k, v in
                                                                   runs.items()},
                                         "meshes": rows}, indent=1) + "\n")
    if comm.rank == 0:
        print(f"{'size':>5} {'layer':>5} {'DOFs':>7} {'E minimise':>16} {'E dynamics':>16} "
              f"{'rel. diff':>10} {'orbit grad.':>11} {'pinning':>9}")
        for r in rows:
            og = max(r[n]["orbit_gradient"] or 0.0 for n in runs)
            pin = r.get("landscape", {}).get("amplitude", float("nan"))
            print(f"{r['size']:5.2f} {r['layer_elements']:5g} {r['dofs']:7d} "
                  f"{r['minimise']['energy']:16.12f} {r['dynamics']['energy']:16.12f} "
                  f"{r['relative_difference']:10.2e} {og:11.2e} {pin:9.2e}")
        t = rows[0]["dynamics_turned"]
        print(f"first mesh: the dynamics' landing turned by {t['turn_deg']:.2f} deg to the "
              f"minimiser's orientation and converged: E {t['energy']:.12f}, relative "
              f"difference {t['relative_difference']:.2e}, distance {t['distance_after']:.2e}")
        share = rows[0]["orbit_share"]
        print(f"first mesh: |difference|_M = {share['difference_mass_norm']:.4g}, along the "
              f"orbit mode {share.get('along_orbit_mode', float('nan')):.4g}")


if __name__ == "__main__":
    main()
