"""Demos run and end with their own asserts."""

import importlib.util
import pathlib

import pytest

DEMOS = pathlib.Path(__file__).parent.parent / "demos"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, DEMOS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_main_demo(shared_tmp):
    out = _load("main").run(shared_tmp / "demo", quick=True)
    assert out["snap_onset"]["kappa_R"] == 1.35 and out["axisymmetric"]["kappa_R"] == -0.72
    assert out["buckled"]["kappa_R"] == pytest.approx(-0.72, rel=1e-9)
