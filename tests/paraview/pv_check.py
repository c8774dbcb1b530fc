"""ParaView env: open the fields of a real run in ParaView and check them against dolfinx.

    xvfb-run -a pvbatch tests/paraview/pv_check.py DIR

DIR/expected.json comes from tests/paraview/make_fields.py (main env). This opens its VTX file
with ParaView's ADIOS2VTXReader, asserts the time step, point and cell counts, the array names,
component counts, per-component and magnitude ranges (relative tolerance 1e-9 of the array's
largest magnitude: the file holds float64, so only rounding may differ), then renders the
displacement-warped shell coloured by mean_curvature_change to DIR/fields.png and checks that the
picture is not blank. Any mismatch or error exits with status 1 (the script's own ``os._exit``,
after printing the traceback), whatever pvbatch does with an uncaught exception.
"""

import json
import os
import sys
import traceback
from pathlib import Path

from paraview import servermanager  # noqa: F401 (initialises the server manager)
from paraview.simple import (
    ADIOS2VTXReader,
    ColorBy,
    GetActiveViewOrCreate,
    GetColorTransferFunction,
    GetDisplayProperties,
    ResetCamera,
    SaveScreenshot,
    Show,
    Text,
    WarpByVector,
)

RTOL = 1e-9


def check(out):
    exp = json.loads((out / "expected.json").read_text())
    errors = []

    reader = ADIOS2VTXReader(FileName=exp["file"])
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) if hasattr(reader.TimestepValues, "__len__") \
        else [reader.TimestepValues]
    if not any(abs(t - exp["time"]) <= 1e-12 * max(1.0, abs(exp["time"])) for t in times):
        errors.append(f"time {exp['time']} not among the file's steps {times}")
    reader.UpdatePipeline(exp["time"])
    info = _check_read(reader, exp, f"{exp['file']} at t = {exp['time']}", "dolfinx has", RTOL,
                       errors)
    if errors:
        raise AssertionError("ParaView check failed:\n  " + "\n  ".join(errors))

    # Screenshot: the shell warped by its displacement (magnified so that the largest
    # displacement is 15 % of the shell's size), coloured by mean_curvature_change.
    bounds = info.GetBounds()
    size = max(bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4])
    umax = exp["arrays"]["displacement"]["magnitude"][1]
    factor = 0.15 * size / umax if umax > 0 else 1.0
    warp = WarpByVector(Input=reader, Vectors=["POINTS", "displacement"], ScaleFactor=factor)
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = [1000, 800]
    view.OrientationAxesVisibility = 1
    disp = Show(warp, view)
    ColorBy(disp, ("POINTS", "mean_curvature_change"))
    lut = GetColorTransferFunction("mean_curvature_change")
    lut.RescaleTransferFunction(*exp["arrays"]["mean_curvature_change"]["ranges"][0])
    disp.SetScalarBarVisibility(view, True)
    label = Text(Text=f"shells: displacement x {factor:.3g}, colour: mean_curvature_change, "
                      f"kappa h = {exp['kappa_h']:.3g}")
    GetDisplayProperties(label, view).FontSize = 14
    Show(label, view)
    view.CameraPosition = [2.5 * size, -3.0 * size, 1.8 * size]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    ResetCamera(view)
    png = out / "fields.png"
    SaveScreenshot(str(png), view, ImageResolution=[1000, 800])

    # The picture shows something: enough pixels differ from the background corner.
    from vtkmodules.numpy_interface import dataset_adapter as dsa
    from vtkmodules.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(str(png))
    r.Update()
    img = dsa.WrapDataObject(r.GetOutput()).PointData[0]
    bg = img[0]
    diff = abs(img[:, :3].astype(float) - bg[:3].astype(float))
    covered = float((diff.sum(axis=1) > 30).mean())
    print(f"pv_check: screenshot {png}: {covered:.0%} of the pixels differ from the background")
    if covered < 0.05:
        raise AssertionError(f"screenshot {png} is (nearly) blank: {covered:.1%} covered")
    print("pv_check: ParaView opens the fields; names and ranges match dolfinx")
    check_shape(exp["shape"])
    check_postbuckled_cap(exp["postbuckled_cap"])


def _compare_arrays(pd, expected, rtol, errors):
    """Each expected array's presence, component count, per-component and magnitude ranges
    (tolerance ``rtol`` times the array's largest magnitude), printed and appended to
    ``errors`` on a mismatch."""
    for name, e in expected.items():
        if name not in pd.keys():
            errors.append(f"array {name!r} missing (have {sorted(pd.keys())})")
            continue
        a = pd[name]
        nc = a.GetNumberOfComponents()
        if nc != e["components"]:
            errors.append(f"{name}: {nc} components, expected {e['components']}")
            continue
        scale = max(abs(v) for r in e["ranges"] + [e["magnitude"]] for v in r) or 1.0
        tol = rtol * scale
        got = [a.GetRange(i) for i in range(nc)] + ([a.GetRange(-1)] if nc > 1 else [])
        want = e["ranges"] + ([e["magnitude"]] if nc > 1 else [])
        labels = [f"component {i}" for i in range(nc)] + (["magnitude"] if nc > 1 else [])
        for lab, g, w in zip(labels, got, want, strict=False):
            dev = max(abs(g[0] - w[0]), abs(g[1] - w[1]))
            ok = dev <= tol
            print(f"  {name:28s} {lab:12s} ParaView [{g[0]:+.10e}, {g[1]:+.10e}]  "
                  f"expected [{w[0]:+.10e}, {w[1]:+.10e}]  |diff| {dev:.1e} "
                  f"{'ok' if ok else 'FAIL'}")
            if not ok:
                errors.append(f"{name} {lab}: ParaView {g}, expected {w} (tolerance {tol:.1e})")


def _check_read(reader, exp, label, source, rtol, errors):
    """Point and cell counts and the point arrays' names and ranges of what ``reader`` read,
    against ``exp``; appends to ``errors``; returns the reader's data information."""
    info = reader.GetDataInformation()
    for what, got in (("points", info.GetNumberOfPoints()), ("cells", info.GetNumberOfCells())):
        if got != exp[what]:
            errors.append(f"{what}: ParaView reads {got}, {source} {exp[what]}")
    pd = reader.PointData
    print(f"pv_check: {label}: {info.GetNumberOfPoints()} points, "
          f"{info.GetNumberOfCells()} cells, point arrays {sorted(pd.keys())}")
    _compare_arrays(pd, exp["arrays"], rtol, errors)
    return info


def check_postbuckled_cap(exp):
    """The surface model's post-buckled cap (VTX, as ``shells postbuckle --model surface``
    writes it) in ParaView's ADIOS2VTXReader: its time step, counts, array names and ranges."""
    reader = ADIOS2VTXReader(FileName=exp["file"])
    reader.UpdatePipelineInformation()
    reader.UpdatePipeline(exp["time"])
    errors = []
    _check_read(reader, exp, f"{exp['file']} at t = {exp['time']}", "dolfinx has", RTOL, errors)
    if errors:
        raise AssertionError("ParaView check of the post-buckled cap failed:\n  "
                             + "\n  ".join(errors))
    print("pv_check: ParaView opens the surface model's post-buckled cap; names and ranges "
          "match")


def check_shape(exp):
    """The 1D model's post-buckled sphere (.vts, a revolved meridian) in ParaView's own XML
    structured-grid reader: point and cell counts, array names and ranges."""
    from paraview.simple import XMLStructuredGridReader

    reader = XMLStructuredGridReader(FileName=[exp["file"]])
    reader.UpdatePipeline()
    errors = []
    # the CSV the expectation is rebuilt from holds 10 significant digits
    _check_read(reader, exp, exp["file"], "shells wrote", 1e-8, errors)
    if errors:
        raise AssertionError("ParaView check of the post-buckled shape failed:\n  "
                             + "\n  ".join(errors))
    print("pv_check: ParaView opens the 1D post-buckled sphere; names and ranges match")


def main(argv) -> int:
    """Run the checks; 0 when all pass, 1 (with the traceback printed) on any failure."""
    if len(argv) != 2:
        print("usage: pvbatch pv_check.py DIR", file=sys.stderr)
        return 2
    try:
        check(Path(argv[1]).resolve())
    except BaseException:  # any failure, whatever its type, is the check's
        traceback.print_exc()
        print("pv_check: FAILED", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    # The exit status is this script's own, not pvbatch's handling of an uncaught exception:
    # os._exit after flushing, so nothing in ParaView's shutdown can turn a failure into 0.
    status = main(sys.argv)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
