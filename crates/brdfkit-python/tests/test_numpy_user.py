"""The package as a NumPy user expects it (issue 29): each probe of the issue, as it
was written, and the rules that answer them: unit directions, one array rule, one
vocabulary with the command line, iterations by stage, FileNotFoundError for every
missing input, and what users reach for."""

from __future__ import annotations

import inspect
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import GOLD, ROOT, bits_equal

import brdfkit
from brdfkit import _brdfkit

UNIT = r"directions must be unit vectors \(within 0\.000001\)"


@pytest.fixture(scope="module")
def pairs(refs):
    """200 reference pairs, every one unit length (some below the horizon)."""
    return refs.f64("wi")[:200], refs.f64("wo")[:200]


# 1. Directions ------------------------------------------------------------------------


def test_eval_refuses_a_direction_that_is_not_unit_length():
    m = brdfkit.Model.default("cook-torrance")
    # The probe: [[0, 0, 0.5]] gave 0.179 where [[0, 0, 1]] gives 0.119.
    with pytest.raises(ValueError, match=r"^row 0: \|wi\| = 0\.5, \|wo\| = 1: " + UNIT):
        m.eval([[0, 0, 0.5]], [[0, 0, 1]])
    assert m.eval([[0, 0, 1]], [[0, 0, 1]]).shape == (1, 3)


def test_lookup_refuses_scaled_directions_naming_the_first_row(gold, pairs):
    wi, wo = pairs
    # The probe: `lookup(2*wi, wo)` differed from `lookup(wi, wo)` on every row.
    with pytest.raises(ValueError, match=r"^row 0: \|wi\| = 2, \|wo\| = 1: " + UNIT):
        gold.lookup(2 * wi, wo)
    bad = wo.copy()
    bad[57] *= 1 + 2e-6
    with pytest.raises(ValueError, match=r"^row 57: \|wi\| = 0?\.?[0-9]+, \|wo\| = 1\.000002"):
        gold.lookup(wi, bad, interp="linear")
    nan = wi.copy()
    nan[3, 0] = np.nan
    with pytest.raises(ValueError, match=r"^row 3: \|wi\| = NaN"):
        gold.lookup(nan, wo)
    # Within the tolerance, and float32 unit vectors (rounded to ~1e-7), are accepted.
    gold.lookup(wi * (1 + 0.9e-6), wo)
    gold.lookup(wi.astype(np.float32), wo.astype(np.float32))


@pytest.mark.parametrize("entry", ["lookup", "eval", "_lookup_seconds"])
def test_every_function_taking_directions_checks_them(gold, pairs, entry):
    wi, wo = pairs
    call = {
        "lookup": lambda a, b: gold.lookup(a, b),
        "eval": lambda a, b: brdfkit.Model.default("lambert").eval(a, b),
        "_lookup_seconds": lambda a, b: _brdfkit._lookup_seconds(gold, a, b, "nearest"),
    }[entry]
    call(wi, wo)
    short = wo.copy()
    short[199] *= 0.5
    with pytest.raises(ValueError, match=r"^row 199: .*" + UNIT):
        call(wi, short)
    with pytest.raises(ValueError, match=r"^row 0: .*" + UNIT):
        call(np.zeros((2, 3)), np.zeros((2, 3)))


def test_below_the_horizon_is_nan_for_tables_and_zero_for_models(gold):
    up, under = [0.0, 0.0, 1.0], [0.6, 0.0, -0.8]
    assert np.isnan(gold.lookup(under, up)).all() and np.isnan(gold.lookup(up, under)).all()
    m = brdfkit.Model.default("cook-torrance")
    assert (m.eval(under, up) == 0).all() and (m.eval(up, under) == 0).all()


# 2. One array rule ---------------------------------------------------------------------

KINDS = ["float64", "float32", "int", "list", "tuple", "fortran", "strided"]


def as_kind(a: np.ndarray, kind: str):
    """`a` (float64) as another input kind NumPy converts to float64; returns the input
    and the float64 array it stands for."""
    if kind == "float64":
        return a, a
    if kind == "float32":
        b = a.astype(np.float32)
        return b, b.astype(np.float64)
    if kind == "int":
        b = np.rint(a).astype(np.int64)
        return b, b.astype(np.float64)
    if kind == "list":
        return a.tolist(), a
    if kind == "tuple":
        return tuple(tuple(r) if np.ndim(r) else r for r in a.tolist()), a
    if kind == "fortran":
        return np.asfortranarray(a), a
    if kind == "strided":
        wide = np.zeros((*a.shape[:-1], 2 * a.shape[-1]))
        wide[..., ::2] = a
        return wide[..., ::2], a
    raise AssertionError(kind)


def axis_pairs():
    """Unit directions with integer coordinates (the `int` kind keeps them exact)."""
    wi = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    wo = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 1, 0]], dtype=np.float64)
    return wi, wo


def assert_takes_kind(f, pairs, kind):
    """f(wi, wo) of the pairs as `kind` is f of the float64 pairs, bit for bit."""
    wi, wo = axis_pairs() if kind == "int" else pairs
    a, a64 = as_kind(wi, kind)
    b, b64 = as_kind(wo, kind)
    assert bits_equal(f(a, b), f(a64, b64))


@pytest.mark.parametrize("kind", KINDS)
def test_lookup_takes_every_kind(gold, pairs, kind):
    assert_takes_kind(gold.lookup, pairs, kind)


@pytest.mark.parametrize("kind", KINDS)
def test_eval_takes_every_kind(pairs, kind):
    assert_takes_kind(brdfkit.Model.default("cook-torrance").eval, pairs, kind)


@pytest.mark.parametrize("kind", KINDS)
def test_from_values_takes_every_kind(gold, kind):
    v = gold.values[:, :6, :6, :12]
    if kind == "int":
        v = np.rint(1000 * np.nan_to_num(v))  # an integer array has no NaN
    x, x64 = as_kind(v, kind)
    t = brdfkit.MerlTable.from_values(x)
    assert t.dims == (6, 6, 12)
    assert np.array_equal(t.values, brdfkit.MerlTable.from_values(x64).values, equal_nan=True)


def test_from_values_probes(gold):
    v = gold.values
    # The probes: float32, integers and nested lists used to raise TypeError.
    t32 = brdfkit.MerlTable.from_values(v.astype(np.float32))
    assert np.array_equal(t32.values, brdfkit.MerlTable.from_values(v.astype(np.float32).astype(np.float64)).values, equal_nan=True)
    ints = np.ones((3, 2, 2, 4), dtype=np.int32)
    assert (brdfkit.MerlTable.from_values(ints).values == 1).all()
    assert brdfkit.MerlTable.from_values(ints.tolist()).dims == (2, 2, 4)


@pytest.mark.parametrize(
    ("arg", "shape", "call"),
    [
        ("values", "(2, 2, 2, 2)", lambda t: brdfkit.MerlTable.from_values(np.zeros((2, 2, 2, 2)))),
        ("values", "(3, 4)", lambda t: brdfkit.MerlTable.from_values(np.zeros((3, 4)))),
        ("wi", "(4, 2)", lambda t: t.lookup(np.zeros((4, 2)), np.zeros((4, 3)))),
        ("wo", "(2, 2, 3)", lambda t: t.lookup(np.zeros((4, 3)), np.zeros((2, 2, 3)))),
        ("wi", "(4,)", lambda t: brdfkit.Model.default("lambert").eval([0, 0, 1, 0], [0, 0, 1])),
    ],
)
def test_shape_errors_name_the_argument_and_the_shape_expected(gold, arg, shape, call):
    with pytest.raises(ValueError) as e:
        call(gold)
    msg = str(e.value)
    assert msg.startswith(f"{arg}: shape {shape}, expected ("), msg


def test_unconvertible_arrays_name_the_argument(gold):
    with pytest.raises(ValueError, match=r"^values: cannot be converted to a float64 array"):
        brdfkit.MerlTable.from_values([[[[1.0, 2.0]], [[3.0]]]])
    with pytest.raises(ValueError, match=r"^wi: cannot be converted to a float64 array"):
        gold.lookup("up", [0, 0, 1])
    with pytest.raises(TypeError, match=r"^wo: cannot be converted to a float64 array"):
        gold.lookup([0, 0, 1], {"z": 1})


@pytest.mark.parametrize("kind", ["tuple", "list", "ndarray", "range"])
def test_resample_takes_any_sequence_of_dims(gold, kind):
    dims = {"tuple": (8, 8, 16), "list": [8, 8, 16], "ndarray": np.array([8, 8, 16]), "range": range(8, 25, 8)}[kind]
    t = brdfkit.resample(gold, dims)
    want = (8, 16, 24) if kind == "range" else (8, 8, 16)
    assert t.dims == want
    assert bits_equal(t.values, brdfkit.resample(gold, want).values)
    assert brdfkit.resample(brdfkit.Model.default("lambert"), dims).dims == want


def test_resample_dims_errors(gold):
    with pytest.raises(ValueError, match=r"^dims: expected a sequence of three integers .* got 2 values"):
        brdfkit.resample(gold, [8, 8])
    with pytest.raises(TypeError, match=r"^dims: expected a sequence of three integers"):
        brdfkit.resample(gold, "8,8,16")
    with pytest.raises(TypeError, match=r"^dims: "):
        brdfkit.resample(gold, [8.5, 8, 16])
    with pytest.raises(ValueError, match=r"^dims: "):
        brdfkit.resample(gold, (0, 1, 1))


@pytest.mark.parametrize("kind", ["str", "list", "tuple"])
def test_fit_takes_any_sequence_of_models(gold, kind):
    names = ["lambert", "cook-torrance"]
    model = {"str": ",".join(names), "list": names, "tuple": tuple(names)}[kind]
    rs = brdfkit.fit(gold, model, starts=1, distribution="ggx")
    assert [r.label for r in rs] == names
    assert rs[1].model.params["distribution"] == "ggx"
    ref = brdfkit.fit(gold, "lambert", starts=1)
    assert rs[0].model == ref.model


def test_fit_sequences_mix_models_names_dicts_and_paths(gold, tmp_path):
    start = brdfkit.Model.default("ward")
    path = tmp_path / "start.json"
    path.write_text(brdfkit.Model.default("lambert").to_json())
    rs = brdfkit.fit(gold, [start, "lambert", {"model": "lambert"}, path], starts=1)
    assert [r.label for r in rs] == ["ward", "lambert", "lambert", f"lambert ({path})"]
    one = brdfkit.fit(gold, ["lambert"], starts=1)
    assert isinstance(one, list) and len(one) == 1
    assert isinstance(brdfkit.fit(gold, path, starts=1), brdfkit.FitResult)
    with pytest.raises(TypeError, match=r"^model: expected a model name .* a sequence"):
        brdfkit.fit(gold, 3)
    with pytest.raises(TypeError, match=r"^model: "):
        brdfkit.fit(gold, ["lambert", 3])
    fixed = brdfkit.fit(gold, "cook-torrance", starts=1, fix=("rho_d",))
    assert fixed.model.params["rho_d"] == brdfkit.Model.default("cook-torrance").params["rho_d"]


# 3. One vocabulary ---------------------------------------------------------------------

LOSSES = ["cbrt", "l2", "cosine", "log", "ngan", "low-e1", "low-e2", "bieron-log"]


def test_loss_names_are_one_vocabulary(gold):
    r = brdfkit.fit(gold, "lambert", starts=1, losses="all")
    assert sorted(r.losses) == sorted(LOSSES)
    for name in LOSSES:
        assert name in brdfkit.FitResult.__doc__
    # The probe: `r.losses` had `low_e1`, which `fit(loss=...)` refused. Every key of
    # `r.losses` is a loss `fit` takes, and the record names it the same way.
    for name in r.losses:
        got = brdfkit.fit(gold, "lambert", loss=name, starts=1)
        assert got.record["loss"] == name
        assert got.losses[got.record["loss"]] == got.record["losses_full"][name]["overall"]
    a = brdfkit.fit(gold, "lambert", loss="low_e1", starts=1)
    b = brdfkit.fit(gold, "lambert", loss="low-e1", starts=1)
    assert a.record["loss"] == b.record["loss"] == "low-e1"
    assert a.model == b.model


def test_the_record_names_settings_as_the_arguments_do(gold):
    """One vocabulary for settings too: each setting in force is in the record under
    the name of the `fit` argument that set it, with the argument's value (degrees);
    `starts` is `starts_per_pass`, the record's `starts` being the list of starts."""
    args = dict(sample_fraction=0.5, theta_d_max=75.0, theta_max=80.0, seed=3)
    r = brdfkit.fit(gold, "lambert", starts=2, **args)
    for name, value in args.items():
        assert r.record[name] == pytest.approx(value), name
    assert r.record["starts_per_pass"] == 2 == len(r.record["starts"])


@pytest.mark.parametrize(
    ("kwargs", "start"),
    [
        ({"model": "phongg"}, "model phongg: unknown model `phongg`"),
        ({"model": "lambert", "starts": 0}, "starts: "),
        ({"model": "lambert", "fix": "nope"}, "fix: lambert: "),
        ({"model": "lambert", "fix": "rho_d"}, "fix: lambert: every parameter is fixed"),
        ({"model": "lambert", "sample_fraction": 0.0}, "sample_fraction: 0: must lie in (0, 1]"),
        ({"model": "lambert", "theta_max": 95.0}, "theta_max: "),
        ({"model": "lambert", "theta_d_max": -1.0}, "theta_d_max: "),
        ({"model": "lambert", "distribution": "ggx"}, "distribution applies to cook-torrance"),
        ({"model": "lambert", "loss": "l3"}, "loss: unknown loss `l3`"),
        ({"model": "lambert", "weighting": "area"}, "weighting: "),
        ({"model": "lambert", "solver": "newton"}, "solver: unknown solver `newton`"),
        ({"model": "lambert", "robust": "tukey"}, "robust: unknown robust loss `tukey`"),
        ({"model": "cook-torrance", "masking": "x"}, "masking: "),
    ],
)
def test_messages_name_python_arguments_not_flags(gold, kwargs, start):
    with pytest.raises(ValueError) as e:
        brdfkit.fit(gold, **kwargs)
    msg = str(e.value)
    assert msg.startswith(start), msg
    assert "--" not in msg, msg


# 4. Iterations -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def gold_64():
    """The gold-paint proxy on a 64 x 64 x 128 grid: enough cells for the warm-up
    (more than four times its 65,536 cells)."""
    return brdfkit.resample(brdfkit.Nbrdf.load(GOLD), (64, 64, 128))


def test_iterations_by_stage_match_the_progress_events(gold_64):
    """The probe: a default fit printed `0 iterations` although the callback saw the
    warm-up's iterations. The stages in the record are the events counted."""
    events = []
    r = brdfkit.fit(gold_64, "cook-torrance", progress=events.append)
    assert r.record["iterations"] == 0, "the default keeps the warm-up optimum"
    assert r.record["warm_up_cells"] and r.record["iterations_run"]["explore"] > 0
    run = r.record["iterations_run"]
    sub = sum(1 for e in events if e["event"] == "iter" and e["warm_up"])
    full = sum(1 for e in events if e["event"] == "iter" and not e["warm_up"])
    assert run["explore"] + run["warm_up"] == sub > 0
    assert run["finish"] == full
    total = run["explore"] + run["warm_up"] + run["finish"]
    want = f"iterations {total} (explore {run['explore']} + warm-up {run['warm_up']} + finish {run['finish']})"
    assert want in repr(r), repr(r)
    assert not re.search(r"\b0 iterations", repr(r))


def test_repr_shows_the_figure_of_the_command_line_table(refs, gold):
    """tests/pytest.rs writes the library's fit table (`comparison_text`, what
    `fit-brdf fit` prints) of the reference fit; `repr` shows its iterations."""
    table = refs.file("fit_table.txt").read_text()
    r = brdfkit.fit(gold, "cook-torrance", starts=2)
    figure = re.search(r"iterations (\d+ \(explore \d+ \+ warm-up \d+ \+ finish \d+\))", repr(r))
    assert figure, repr(r)
    row = next(line for line in table.splitlines() if line.startswith("cook-torrance "))
    assert figure.group(1) in row, (row, repr(r))


# 5. Missing files ----------------------------------------------------------------------


def test_every_loader_raises_file_not_found(tmp_path, gold):
    missing = tmp_path / "nope"
    loaders = {
        "MerlTable.read": lambda: brdfkit.MerlTable.read(missing / "t.binary"),
        # The probe: `Nbrdf.load("/tmp/nope/gold")` raised ValueError.
        "Nbrdf.load": lambda: brdfkit.Nbrdf.load("/tmp/nope/gold"),
        "Nbrdf.load (path)": lambda: brdfkit.Nbrdf.load(missing / "gold"),
        "Model.from_json (path)": lambda: brdfkit.Model.from_json(missing / "m.json"),
        "Model.from_json (str)": lambda: brdfkit.Model.from_json(str(missing / "m.json")),
        "fit (model file)": lambda: brdfkit.fit(gold, str(missing / "m.json")),
        "fit (os.PathLike)": lambda: brdfkit.fit(gold, missing / "m.json"),
    }
    for name, load in loaders.items():
        with pytest.raises(FileNotFoundError, match="nope"):
            load()
        print(name, "ok")


def test_malformed_weights_are_value_errors(tmp_path):
    for part in ("fc1", "b1", "fc2", "b2", "fc3", "b3"):
        (tmp_path / f"bad_{part}.npy").write_bytes(b"not an npy file")
    with pytest.raises(ValueError, match=r"bad_fc1\.npy: not a valid \.npy file"):
        brdfkit.Nbrdf.load(tmp_path / "bad")


# 6. What users reach for ---------------------------------------------------------------


def test_version_is_the_crate_version():
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())
    assert brdfkit.__version__ == cargo["workspace"]["package"]["version"]
    assert brdfkit._brdfkit.__version__ == brdfkit.__version__


def test_models_compare_by_their_json_description():
    a, b = brdfkit.Model.default("cook-torrance"), brdfkit.Model.default("cook-torrance")
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a == brdfkit.Model.from_json(a.to_json(pretty=True))
    assert a != brdfkit.Model.default("ward")
    changed = dict(a.params, alpha=0.25)
    assert a != brdfkit.Model.from_json({"model": "cook-torrance", "params": changed})
    assert a != a.to_json() and (a == 1) is False


def test_from_json_takes_a_path_or_says_it_takes_text(tmp_path):
    m = brdfkit.Model.default("ward")
    p = tmp_path / "ward.json"
    p.write_text(m.to_json(pretty=True))
    assert brdfkit.Model.from_json(p) == m
    assert brdfkit.Model.from_json(str(p)) == m
    # The probe: a path used to be read as JSON text ("not valid JSON").
    with pytest.raises(FileNotFoundError, match=r"takes JSON text, a dict or the path"):
        brdfkit.Model.from_json("no-such-model.json")
    with pytest.raises(TypeError, match=r"takes JSON text, a dict or the path"):
        brdfkit.Model.from_json(object())
    with pytest.raises(ValueError):
        brdfkit.Model.from_json("{not json")


def test_save_writes_what_fit_out_and_record_write(refs, gold, tmp_path):
    """tests/pytest.rs writes the reference fit's files with the functions
    `fit-brdf fit --out` and `--record` write with (`Outcome::params_file`,
    `record_file`)."""
    r = brdfkit.fit(gold, "cook-torrance", starts=2)
    out, rec = tmp_path / "params.json", tmp_path / "fit.json"
    r.save(out, record=rec)
    assert out.read_bytes() == refs.file("fit_params.json").read_bytes()
    assert r.to_json() == out.read_text()
    assert r.record_json() == rec.read_text() and rec.read_text().endswith("}\n")
    ref_record = refs.file("fit_record.json").read_text()
    no_time = re.compile(r'"wall_time_s": [^,\n]+')
    assert no_time.sub("", rec.read_text()) == no_time.sub("", ref_record)
    assert brdfkit.Model.from_json(out) == r.model
    r.save(tmp_path / "only.json")
    assert not (tmp_path / "fit.json.tmp").exists()
    with pytest.raises(OSError):
        r.save(tmp_path / "no-dir" / "p.json")


def test_every_fit_argument_is_documented():
    """Every keyword of the library call appears in `fit`'s docstring, its stub and
    docs/python.md (the probe: `theta_max` was missing from the guide)."""
    names = [p for p in inspect.signature(_brdfkit.fit).parameters if p not in ("table", "model")]
    assert "theta_max" in names and len(names) > 15
    doc = brdfkit.fit.__doc__
    stub = (Path(brdfkit.__file__).parent / "__init__.pyi").read_text()
    guide = (ROOT / "docs" / "python.md").read_text()
    for n in names:
        assert re.search(rf"\b{n}\b", doc), f"{n} not in brdfkit.fit's docstring"
        assert re.search(rf"\b{n}\b", stub), f"{n} not in __init__.pyi"
        assert f"`{n}`" in guide, f"{n} not in docs/python.md"


def test_nbrdf_loads_from_any_path_kind():
    assert brdfkit.Nbrdf.load(GOLD).name == brdfkit.Nbrdf.load(str(GOLD)).name == "gold-paint"
