"""brdfkit in Python: measured BRDFs with NumPy arrays in and out.

MERL tables (:class:`MerlTable`), analytic models (:class:`Model`), neural BRDFs
(:class:`Nbrdf`), RGL-EPFL ``.bsdf`` measurements (:class:`RglBsdf`), fitting (:func:`fit`), the physical checks (:func:`check`) and
resampling (:func:`resample`), all computed by the brdfkit Rust library: the values are
the library's, to the bit. Directions point away from the surface, z is the normal,
and every BRDF value is f_r in 1/sr without the cosine factor. A Mitsuba 3 BSDF for
tables and models is in :mod:`brdfkit.mitsuba`. Guide: ``docs/python.md``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

from ._brdfkit import MerlTable, Model, Nbrdf, RglBsdf, __version__, check, resample
from ._brdfkit import _write_text
from ._brdfkit import FIT_DEFAULTS as _DEFAULTS
from ._brdfkit import fit as _fit

__all__ = ["MerlTable", "Model", "Nbrdf", "RglBsdf", "FitResult", "fit", "check", "resample", "__version__"]


@dataclass(frozen=True)
class FitResult:
    """One fitted model family.

    ``model`` is the fitted :class:`Model` (a tuple of the R, G and B channel models
    for a per-channel fit); ``losses`` maps each of the eight loss names (brdfkit's
    ``cbrt``, ``l2``, ``cosine``, ``log`` and the published ``ngan``, ``low-e1``,
    ``low-e2``, ``bieron-log``: the names ``fit(loss=...)`` takes) to its overall value
    on the full table; ``record`` is the fit record as ``fit-brdf fit --record`` writes
    it (every loss per channel, iterations by stage in ``iterations_run``, wall time,
    termination, every start). ``repr`` shows the iterations as the command line's fit
    table does: the total, then the exploration, warm-up and finish stages.
    """

    label: str
    model: Model | tuple[Model, Model, Model]
    record: dict = field(repr=False)
    _model_file: str = field(repr=False, compare=False)
    _record_file: str = field(repr=False, compare=False)
    _iterations: str = field(repr=False, compare=False)

    @property
    def losses(self) -> dict[str, float]:
        full = self.record["losses_full"]
        return {name: v["overall"] for name, v in full.items() if isinstance(v, dict)}

    def to_json(self) -> str:
        """The fitted model's file as ``fit-brdf fit --out`` writes it (pretty JSON and a
        newline; ``{"per_channel": [r, g, b]}`` for a per-channel fit)."""
        return self._model_file

    def record_json(self) -> str:
        """The fit record's file as ``fit-brdf fit --record`` writes it."""
        return self._record_file

    def save(self, path: str | os.PathLike, record: str | os.PathLike | None = None) -> None:
        """Writes the fitted model to ``path`` (the bytes of ``fit-brdf fit --out``)
        and, if given, the record to ``record`` (``--record``); each file is written
        atomically (whole, or not at all). ``OSError`` if a file cannot be written."""
        _write_text(path, self._model_file)
        if record is not None:
            _write_text(record, self._record_file)

    def __repr__(self) -> str:
        r = self.record
        return (
            f"FitResult({self.label}: {r['loss']} loss {self.losses[r['loss']]:.4e}, "
            f"iterations {self._iterations}, {r['wall_time_s']:.2f} s, {r['termination']}; "
            f"model={self.model!r})"
        )


def _fitted(params: dict) -> Model | tuple[Model, Model, Model]:
    """The fitted model, or the three channel models of a per-channel fit."""
    if "per_channel" in params:
        r, g, b = (Model.from_json(m) for m in params["per_channel"])
        return (r, g, b)
    return Model.from_json(params)


def _model_item(m: Any) -> Any:
    """A dict becomes the Model it describes; anything else goes to the library."""
    return Model.from_json(m) if isinstance(m, dict) else m


def fit(
    table: MerlTable,
    model: str | Model | dict | os.PathLike | Sequence[str | Model | dict | os.PathLike] = _DEFAULTS["model"],
    loss: str = _DEFAULTS["loss"],
    starts: int = _DEFAULTS["starts"],
    *,
    progress: Callable[[dict[str, Any]], object] | None = None,
    **choices: Any,
) -> FitResult | list[FitResult]:
    """Fits an analytic model to a table, as ``fit-brdf fit`` does, with its defaults
    (one set, the library's: ``brdfkit._brdfkit.FIT_DEFAULTS``).

    ``model`` is a model name, a model JSON file (a path), a :class:`Model` or its JSON
    dict (the start), or several of these: a comma-separated string or any sequence
    (then a list of results, one per family, in order). ``loss`` is one of the eight
    loss names (``low-e1`` or ``low_e1``: either spelling). ``choices`` are the other
    settings of ``fit-brdf fit`` with underscores for dashes: ``weighting``,
    ``solver``, ``finish``, ``sample_fraction``, ``theta_d_max`` (θd cutoff, degrees),
    ``theta_max`` (θi and θo cutoff, degrees), ``per_channel``, ``seed``, ``fix`` (a
    name, a comma-separated string or a sequence of names), ``robust``,
    ``robust_scale``, ``energy_conserving``, ``full_iters`` (a count, ``"all"`` or
    ``"auto"``), ``explore_cells``, ``losses`` (``"own"``: brdfkit's four losses in
    the record, the default; ``"all"``: also the four published metrics), and the
    structural choices ``distribution``,
    ``masking``, ``fresnel``, ``normalization``. ``progress`` is called with one dict
    per event (``event`` is ``plan``, ``iter`` or ``start_done``), from the fitting
    threads; an exception it raises is raised when the fit returns.

    Errors name the argument at fault: ``ValueError`` for a bad value (an unknown
    model or loss, ``starts=0``, an unknown ``fix`` name), ``TypeError`` for an
    argument of the wrong kind, ``FileNotFoundError`` for a missing model file,
    ``RuntimeError`` if the fit itself fails.
    """
    single = isinstance(model, (str, Model, dict, os.PathLike)) and not (
        isinstance(model, str) and "," in model
    )
    if isinstance(model, Sequence) and not isinstance(model, str):
        model = [_model_item(m) for m in model]
    else:
        model = _model_item(model)
    fix = choices.pop("fix", None)
    if isinstance(fix, str):
        fix = fix.split(",")
    elif fix is not None:
        fix = list(fix)
    if isinstance(choices.get("full_iters"), int) and not isinstance(choices["full_iters"], bool):
        choices["full_iters"] = str(choices["full_iters"])
    out = _fit(table, model, loss=loss, starts=starts, fix=fix, progress=progress, **choices)
    results = [
        FitResult(label, _fitted(json.loads(params)), json.loads(record), params, record, iters)
        for label, params, record, iters in out
    ]
    return results[0] if single and len(results) == 1 else results
