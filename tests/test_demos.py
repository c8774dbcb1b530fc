"""Demos run and end with their own asserts."""

import importlib.util
import pathlib

DEMOS = pathlib.Path(__file__).parent.parent / "demos"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, DEMOS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_main_demo(shared_tmp):
    s = _load("main").run(shared_tmp / "demo")
    assert s["cells"] > 1000
