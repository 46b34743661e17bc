"""The scripts of ``asv_benchmarks/``, imported by their path (the folder is no package)."""

import importlib.util
import sys
from pathlib import Path


def load(name: str):
    """The benchmark script ``name`` (``"field_study"``) as a module."""
    path = Path(__file__).resolve().parents[1] / "asv_benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_benchmark_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module
