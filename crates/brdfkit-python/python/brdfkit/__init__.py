"""brdfkit in Python: measured BRDFs with NumPy arrays in and out.

MERL tables (:class:`MerlTable`), analytic models (:class:`Model`), neural BRDFs
(:class:`Nbrdf`), fitting (:func:`fit`), the physical checks (:func:`check`) and
resampling (:func:`resample`), all computed by the brdfkit Rust library: the values are
the library's, to the bit. Directions point away from the surface, z is the normal,
and every BRDF value is f_r in 1/sr without the cosine factor. A Mitsuba 3 BSDF for
tables and models is in :mod:`brdfkit.mitsuba`. Guide: ``docs/python.md``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Callable

from ._brdfkit import MerlTable, Model, Nbrdf, check, resample
from ._brdfkit import fit as _fit

__all__ = ["MerlTable", "Model", "Nbrdf", "FitResult", "fit", "check", "resample"]


@dataclass(frozen=True)
class FitResult:
    """One fitted model family.

    ``model`` is the fitted :class:`Model` (a tuple of the R, G and B channel models
    for a per-channel fit); ``losses`` maps each loss name (``cbrt``,
    ``l2``, ``cosine``, ``log``) to its overall value on the full table; ``record`` is
    the fit record as ``fit-brdf fit --record`` writes it (every loss per channel,
    iterations, wall time, termination, every start).
    """

    label: str
    model: Model | tuple[Model, Model, Model]
    record: dict = field(repr=False)

    @property
    def losses(self) -> dict[str, float]:
        full = self.record["losses_full"]
        return {name: v["overall"] for name, v in full.items() if isinstance(v, dict)}

    def __repr__(self) -> str:
        r = self.record
        return (
            f"FitResult({self.label}: {r['loss']} loss {self.losses[r['loss']]:.4e}, "
            f"{r['iterations']} iterations, {r['wall_time_s']:.2f} s, {r['termination']}; "
            f"model={self.model!r})"
        )


def _fitted(params: dict) -> Model | tuple[Model, Model, Model]:
    """The fitted model, or the three channel models of a per-channel fit."""
    if "per_channel" in params:
        r, g, b = (Model.from_json(m) for m in params["per_channel"])
        return (r, g, b)
    return Model.from_json(params)


def fit(
    table: MerlTable,
    model: str | Model | dict | os.PathLike = "cook-torrance",
    loss: str = "cbrt",
    starts: int = 8,
    *,
    progress: Callable[[dict[str, Any]], object] | None = None,
    **choices: Any,
) -> FitResult | list[FitResult]:
    """Fits an analytic model to a table, as ``fit-brdf fit`` does, with its defaults.

    ``model`` is a model name, a comma-separated list of names or model JSON files
    (then a list of results, one per family), a :class:`Model` or its JSON dict (the
    start). ``choices`` are the other settings of ``fit-brdf fit`` with underscores
    for dashes: ``weighting``, ``solver``, ``finish``, ``sample_fraction``,
    ``theta_d_max`` and ``theta_max`` (θi/θo cutoff) (degrees), ``per_channel``, ``seed``, ``fix`` (names),
    ``robust``, ``robust_scale``, ``energy_conserving``, ``full_iters`` (a count,
    ``"all"`` or ``"auto"``), ``explore_cells``, and the structural choices ``distribution``,
    ``masking``, ``fresnel``, ``normalization``. ``progress`` is called with one dict
    per event (``event`` is ``plan``, ``iter`` or ``start_done``), from the fitting
    threads; an exception it raises is raised when the fit returns.
    """
    if isinstance(model, dict):
        model = Model.from_json(model)
    elif isinstance(model, os.PathLike):
        model = os.fspath(model)
    fix = choices.pop("fix", None)
    if isinstance(fix, str):
        fix = fix.split(",")
    if isinstance(choices.get("full_iters"), int) and not isinstance(choices["full_iters"], bool):
        choices["full_iters"] = str(choices["full_iters"])
    out = _fit(table, model, loss=loss, starts=starts, fix=fix, progress=progress, **choices)
    results = [
        FitResult(label, _fitted(json.loads(params)), json.loads(record))
        for label, params, record in out
    ]
    single = isinstance(model, Model) or "," not in model
    return results[0] if single and len(results) == 1 else results
