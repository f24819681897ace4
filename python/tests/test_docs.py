"""Every public item of the package has a docstring, so that help() and an editor explain it."""

import importlib
import inspect

import pytest

MODULES = ["terzaghi", "terzaghi.batch", "terzaghi.fleet", "terzaghi.mujoco", "terzaghi.envs",
           "terzaghi._terzaghi"]


def undocumented(modname):
    try:
        m = importlib.import_module(modname)
    except ImportError as e:  # terzaghi.mujoco without mujoco, terzaghi.envs without gymnasium, terzaghi.fleet without dask
        pytest.skip(f"{modname}: {e}")
    missing = [] if (m.__doc__ or "").strip() else [modname]
    names = getattr(m, "__all__", None) or [n for n in dir(m) if not n.startswith("_")]
    for n in names:
        o = getattr(m, n)
        if inspect.ismodule(o) or not getattr(o, "__module__", "").startswith("terzaghi"):
            continue
        if not (o.__doc__ or "").strip():
            missing.append(f"{modname}.{n}")
        if inspect.isclass(o):
            for k, v in vars(o).items():
                if k.startswith("_"):
                    continue
                if isinstance(v, (staticmethod, classmethod)):
                    v = v.__func__
                if callable(v) or isinstance(v, property):
                    if not (v.__doc__ or "").strip():
                        missing.append(f"{modname}.{n}.{k}")
    return missing


@pytest.mark.parametrize("modname", MODULES)
def test_every_public_item_has_a_docstring(modname):
    assert undocumented(modname) == []
