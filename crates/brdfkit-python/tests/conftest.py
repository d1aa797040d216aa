"""Shared fixtures of the brdfkit Python tests.

The bit-equality tests compare against values the Rust API computed: `cargo test -p
brdfkit-python` (tests/pytest.rs) writes them into a directory named by `BRDFKIT_REFS`
and runs pytest. Run directly, without it, those tests are skipped with that reason.
Under CI (`CI` set) nothing may be skipped: a missing reference directory, Mitsuba or
LLVM 19 is a failure.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
GOLD = ROOT / "data-measured" / "merl" / "gold-paint"
# The grid of the reference table (tests/pytest.rs: DIMS).
DIMS = (24, 24, 48)


def under_ci() -> bool:
    return os.environ.get("CI", "") not in ("", "0", "false")


def unavailable(why: str):
    """Fails under CI, skips with the reason otherwise."""
    if under_ci():
        pytest.fail(f"cannot run under CI: {why}")
    pytest.skip(why)


class Refs:
    """The reference directory written by tests/pytest.rs."""

    def __init__(self, path: Path):
        self.path = path

    def f64(self, name: str, cols: int = 3) -> np.ndarray:
        return np.fromfile(self.path / f"{name}.f64", dtype="<f8").reshape(-1, cols)

    def json(self, name: str):
        return json.loads((self.path / f"{name}.json").read_text())

    def file(self, name: str) -> Path:
        return self.path / name


@pytest.fixture(scope="session")
def refs() -> Refs:
    d = os.environ.get("BRDFKIT_REFS")
    if not d:
        unavailable("BRDFKIT_REFS is unset: run through `cargo test -p brdfkit-python`")
    return Refs(Path(d))


@pytest.fixture(scope="module")
def gold(refs):
    """The reference table `gold.binary`, read by the package (a `brdfkit.MerlTable`)."""
    import brdfkit

    return brdfkit.MerlTable.read(refs.file("gold.binary"))


def bits_equal(a: np.ndarray, b: np.ndarray) -> bool:
    """Same shape and the same float64 bit patterns (NaN included)."""
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def read_merl_numpy(path) -> np.ndarray:
    """A MERL binary table read by NumPy alone (docs/merl-format.md): the header dims,
    the raw planes times the scales, NaN for a negative (missing) raw value."""
    raw = Path(path).read_bytes()
    dims = np.frombuffer(raw[:12], dtype="<i4")
    body = np.frombuffer(raw[12:], dtype="<f8").reshape(3, *dims)
    scales = np.array([1 / 1500, 1.15 / 1500, 1.66 / 1500]).reshape(3, 1, 1, 1)
    return np.where(body < 0, np.nan, body * scales)


def mitsuba_variant(variant: str):
    """Mitsuba with `variant` set and the brdfkit plugins registered."""
    try:
        import mitsuba as mi
    except ImportError as e:
        unavailable(f"Mitsuba 3 is not installed ({e}): pip install -r python/requirements.txt")
    if variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        unavailable(
            "llvm_ad_rgb needs LLVM 19: set DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 "
            "(Debian: apt-get install libllvm19)"
        )
    mi.set_variant(variant)
    import brdfkit.mitsuba

    brdfkit.mitsuba.register()
    return mi
