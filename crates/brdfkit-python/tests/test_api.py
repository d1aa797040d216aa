"""The Python API against the Rust library (bit for bit) and against NumPy."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from conftest import DIMS, GOLD, bits_equal, read_merl_numpy

import brdfkit


def test_values_are_the_file_read_by_numpy(refs, gold):
    v = gold.values
    assert v.shape == (3, *DIMS) and v.dtype == np.float64
    expect = read_merl_numpy(refs.file("gold.binary"))
    assert np.array_equal(v, expect, equal_nan=True)
    assert np.array_equal(gold.valid_mask, ~np.isnan(expect[0]))
    assert 0.5 < gold.valid_fraction < 1.0
    assert gold.dims == DIMS


def test_repr_says_what_it_is(gold):
    r = repr(gold)
    assert r.startswith("MerlTable(dims=(24, 24, 48), valid=") and "gold.binary" in r
    m = brdfkit.Model.default("lambert")
    assert repr(m).startswith("Model(lambert, params={")


@pytest.mark.parametrize("interp", ["nearest", "linear"])
def test_lookup_is_the_rust_lookup_to_the_bit(refs, gold, interp):
    wi, wo = refs.f64("wi"), refs.f64("wo")
    out = gold.lookup(wi, wo, interp=interp)
    expect = refs.f64(f"lookup_{interp}")
    assert out.shape == (len(wi), 3)
    assert bits_equal(out, expect)
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    assert below.any() and np.isnan(out[below]).all()
    assert np.isfinite(out[~below]).mean() > 0.99


def test_lookup_takes_strided_lists_and_single_directions(refs, gold):
    wi, wo = refs.f64("wi")[:50], refs.f64("wo")[:50]
    base = gold.lookup(wi, wo)
    wide = np.zeros((50, 6))
    wide[:, ::2] = wi  # a strided view: copied to a contiguous array first
    assert bits_equal(gold.lookup(wide[:, ::2], wo.tolist()), base)
    assert bits_equal(gold.lookup(wi[7], wo[7]), base[7:8])


def test_model_eval_is_the_rust_eval_to_the_bit(refs):
    m = brdfkit.Model.from_json(refs.json("model"))
    out = m.eval(refs.f64("wi"), refs.f64("wo"))
    assert bits_equal(out, refs.f64("eval"))
    below = (refs.f64("wi")[:, 2] <= 0) | (refs.f64("wo")[:, 2] <= 0)
    assert (out[below] == 0).all() and (out[~below] > 0).any()


def test_model_json_round_trip():
    text = '{"model": "ward", "params": {"rho_d": 0.2, "rho_s": [0.1, 0.2, 0.3], "alpha_x": 0.3}}'
    a = brdfkit.Model.from_json(text)
    b = brdfkit.Model.from_json({"model": a.name, "params": a.params})
    assert a.to_json() == b.to_json()
    assert a.name == "ward" and a.params["rho_s"] == [0.1, 0.2, 0.3]
    assert len(a.param_names) == len(a.param_vector)
    assert brdfkit.Model.from_json(a.to_json(pretty=True)).to_json() == a.to_json()


def test_check_is_the_rust_report(refs):
    m = brdfkit.Model.from_json(refs.json("model"))
    assert brdfkit.check(m) == refs.json("check")


def test_check_of_a_table(gold):
    r = brdfkit.check(gold)
    assert isinstance(r, dict) and "passed" in r


def test_resample_a_model_is_the_rust_table(refs):
    m = brdfkit.Model.from_json(refs.json("model"))
    t = brdfkit.resample(m, (10, 10, 20))
    assert bits_equal(t.values, read_merl_numpy(refs.file("model_10_10_20.binary")))


def test_resample_an_nbrdf_is_the_rust_table(refs):
    n = brdfkit.Nbrdf.load(GOLD)
    assert n.name == "gold-paint" and "gold-paint" in repr(n)
    t = brdfkit.resample(n, DIMS)
    assert bits_equal(t.values, read_merl_numpy(refs.file("gold.binary")))


def test_resample_a_table_onto_another_grid(gold):
    t = brdfkit.resample(gold, (12, 12, 24), interp="linear")
    assert t.dims == (12, 12, 24) and t.path is None
    # The coarse table's cells sit on the fine grid's nodes where the angles agree.
    assert np.nanmax(t.values) <= np.nanmax(gold.values) * (1 + 1e-12)


def test_write_then_read_is_the_same_file(refs, gold, tmp_path):
    p = tmp_path / "copy.binary"
    gold.write(p)
    assert p.read_bytes() == refs.file("gold.binary").read_bytes()
    assert bits_equal(brdfkit.MerlTable.read(p).values, gold.values)


def test_from_values_round_trip(gold):
    t = brdfkit.MerlTable.from_values(gold.values)
    assert t.dims == gold.dims
    np.testing.assert_allclose(t.values, gold.values, rtol=1e-15, equal_nan=True)
    assert np.array_equal(t.valid_mask, gold.valid_mask)


def strip_times(v):
    """The record without its wall times (they differ from run to run)."""
    if isinstance(v, dict):
        return {k: strip_times(x) for k, x in v.items() if "time" not in k}
    if isinstance(v, list):
        return [strip_times(x) for x in v]
    return v


def test_fit_is_the_rust_fit(refs, gold):
    expect = refs.json("fit")
    r = brdfkit.fit(gold, "cook-torrance", starts=2)
    assert r.label == expect["label"] == "cook-torrance"
    assert r.model.to_json() == brdfkit.Model.from_json(expect["params"]).to_json()
    assert strip_times(r.record) == strip_times(expect["record"])
    assert r.losses["cbrt"] == expect["record"]["losses_full"]["cbrt"]["overall"]
    # The defaults are the command line's: brdfkit's own four losses.
    assert set(r.losses) == {"cbrt", "l2", "cosine", "log"}
    assert brdfkit._brdfkit.FIT_DEFAULTS["losses"] == "own"
    every = brdfkit.fit(gold, "cook-torrance", starts=2, losses="all")
    assert set(every.losses) == {
        "cbrt", "l2", "cosine", "log", "ngan", "low-e1", "low-e2", "bieron-log"
    }
    assert every.losses["cbrt"] == r.losses["cbrt"]
    assert "cook-torrance" in repr(r)


def test_fit_reports_progress_and_raises_what_the_callback_raises(gold):
    events = []
    brdfkit.fit(gold, "lambert", starts=2, progress=events.append)
    kinds = {e["event"] for e in events}
    assert kinds == {"plan", "iter", "start_done"}
    assert all(e["family"] == "lambert" for e in events)

    def boom(e):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        brdfkit.fit(gold, "lambert", starts=1, progress=boom)


def test_fit_choices_and_lists(gold):
    rs = brdfkit.fit(gold, "lambert,cook-torrance", starts=1, distribution="ggx")
    assert [r.label for r in rs] == ["lambert", "cook-torrance"]
    assert rs[1].model.params["distribution"] == "ggx"
    start = brdfkit.Model.default("cook-torrance").params["rho_d"]
    fixed = brdfkit.fit(gold, "cook-torrance", starts=1, fix="rho_d")
    assert fixed.model.params["rho_d"] == start
    assert fixed.model.params["rho_s"] != brdfkit.Model.default("cook-torrance").params["rho_s"]
    per = brdfkit.fit(gold, "lambert", starts=1, per_channel=True)
    assert isinstance(per.model, tuple) and len(per.model) == 3
    for rule in (0, 3, "all", "auto"):
        assert brdfkit.fit(gold, "lambert", starts=1, full_iters=rule).label == "lambert"


def test_errors_are_python_exceptions_with_the_rust_messages(tmp_path, gold):
    missing = tmp_path / "nope.binary"
    with pytest.raises(FileNotFoundError, match=r"nope\.binary"):
        brdfkit.MerlTable.read(missing)
    with pytest.raises(IsADirectoryError, match="is a directory, not a table file"):
        brdfkit.MerlTable.read(tmp_path)
    short = tmp_path / "short.binary"
    short.write_bytes(np.array([2, 2, 4], "<i4").tobytes() + b"\0" * 8)
    with pytest.raises(ValueError) as e:
        brdfkit.MerlTable.read(short)
    assert str(e.value) == (
        f"{short}: truncated: dims 2 x 2 x 4 need 396 bytes (12 + 3 x 16 x 8), the file has 20"
    )
    with pytest.raises(ValueError, match=r"unknown model `glass` \(known: lambert"):
        brdfkit.Model.from_json({"model": "glass"})
    with pytest.raises(ValueError, match=r"parameter `alpha` = -1 is outside its domain"):
        brdfkit.Model.from_json({"model": "cook-torrance", "params": {"alpha": -1}})
    with pytest.raises(ValueError, match="interp `cubic`"):
        gold.lookup(np.zeros((1, 3)), np.zeros((1, 3)), interp="cubic")
    with pytest.raises(ValueError, match=r"wo: shape \(4, 2\), expected \(N, 3\)"):
        gold.lookup(np.zeros((4, 3)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="4 wi directions, 5 wo directions"):
        gold.lookup(np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="unknown loss `l3`"):
        brdfkit.fit(gold, "lambert", loss="l3")
    with pytest.raises(ValueError, match="^starts: "):
        brdfkit.fit(gold, "lambert", starts=0)
    for rule in ("some", -1):
        with pytest.raises(
            ValueError, match=rf"full_iters: '{rule}': expected a number of iterations, 'all' or 'auto'"
        ):
            brdfkit.fit(gold, "lambert", full_iters=rule)
    with pytest.raises(ValueError, match="dims"):
        brdfkit.resample(gold, (0, 1, 1))


def test_long_calls_release_the_gil(refs, gold):
    """A Python thread keeps running while a lookup of 2 M pairs runs."""
    wi = np.tile(refs.f64("wi"), (100, 1))
    wo = np.tile(refs.f64("wo"), (100, 1))
    ticks, done = [0], threading.Event()

    def spin():
        while not done.is_set():
            ticks[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = ticks[0]
        for _ in range(3):
            gold.lookup(wi, wo, interp="linear")
        during = ticks[0] - before
    finally:
        done.set()
        t.join()
    assert during > 1000, f"the other thread ran {during} times during the lookups"
