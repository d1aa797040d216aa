"""brdfkit.RglBsdf: an RGL-EPFL .bsdf file opened, evaluated, described and resampled,
to the bit of the Rust API (`eval_flat`, what `fit-brdf eval --bsdf` runs), with typed
errors for missing and malformed files."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import brdfkit
from conftest import read_merl_numpy


@pytest.fixture(scope="module")
def felt(refs):
    return brdfkit.RglBsdf.open(refs.file("felt.bsdf"))


def test_eval_is_the_cli_eval_to_the_bit(refs, felt):
    wi, wo = refs.f64("wi"), refs.f64("wo")
    got = felt.eval(wi, wo)
    assert got.shape == (len(wi), 3) and got.dtype == np.float64
    np.testing.assert_array_equal(got, refs.f64("rgl_eval"))
    # Below the horizon is 0, and negative stored values come back as they are.
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    assert below.any() and (got[below] == 0).all()
    assert (got < 0).any()


def test_eval_takes_arrays_as_the_table_lookup_does(refs, felt):
    wi, wo = refs.f64("wi")[:50], refs.f64("wo")[:50]
    want = felt.eval(wi, wo)
    # float32 input, lists, Fortran order, and one (3,) direction as one row.
    np.testing.assert_array_equal(felt.eval(wi.tolist(), np.asfortranarray(wo)), want)
    np.testing.assert_array_equal(felt.eval(wi[3], wo[3]), want[3:4])
    with pytest.raises(ValueError, match="wi: shape"):
        felt.eval(wi[:, :2], wo)
    with pytest.raises(ValueError, match="as many of each"):
        felt.eval(wi, wo[:10])
    with pytest.raises(ValueError, match="unit"):
        felt.eval(2 * wi, wo)


def test_info_is_the_cli_info(refs, felt):
    info = felt.info
    want = refs.json("rgl_info")
    want["file"] = info["file"]
    assert info == want
    assert info["format"] == "rgl-epfl-bsdf" and info["description"] == "test felt"
    assert info["negative_values"] > 0


def test_resample_is_the_library_table(refs, felt, tmp_path):
    t = felt.resample((10, 10, 20))
    assert isinstance(t, brdfkit.MerlTable) and t.dims == (10, 10, 20)
    np.testing.assert_array_equal(
        t.values, read_merl_numpy(refs.file("rgl_10_10_20.binary")), strict=True
    )
    assert felt.resample().dims == (90, 90, 180)
    with pytest.raises(ValueError, match="dims"):
        felt.resample((10, 10))


def test_errors_name_the_file_and_the_field(refs, tmp_path):
    with pytest.raises(FileNotFoundError, match="none.bsdf"):
        brdfkit.RglBsdf.open(tmp_path / "none.bsdf")
    good = refs.file("felt.bsdf").read_bytes()
    cut = tmp_path / "cut.bsdf"
    cut.write_bytes(good[: len(good) - 100])
    with pytest.raises(ValueError, match=r"cut\.bsdf: field `\w+`"):
        brdfkit.RglBsdf.open(cut)
    table = tmp_path / "t.bsdf"
    shutil.copy(refs.file("rgl_10_10_20.binary"), table)
    with pytest.raises(ValueError, match=r"t\.bsdf.*not a Mitsuba tensor file"):
        brdfkit.RglBsdf.open(table)
    r = repr(brdfkit.RglBsdf.open(refs.file("felt.bsdf")))
    assert "RGB, isotropic" in r and "felt.bsdf" in r
