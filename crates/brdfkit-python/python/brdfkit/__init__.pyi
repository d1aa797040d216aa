"""brdfkit in Python: measured BRDFs with NumPy arrays in and out."""

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Callable, Literal

from ._brdfkit import MerlTable as MerlTable
from ._brdfkit import Model as Model
from ._brdfkit import Nbrdf as Nbrdf
from ._brdfkit import RglBsdf as RglBsdf
from ._brdfkit import __version__ as __version__
from ._brdfkit import check as check
from ._brdfkit import resample as resample

__all__ = ["MerlTable", "Model", "Nbrdf", "FitResult", "fit", "check", "resample", "__version__"]

_Loss = Literal[
    "cbrt", "l2", "cosine", "log", "ngan", "low-e1", "low-e2", "bieron-log",
    "low_e1", "low_e2", "bieron_log", "bbm-log",
]
_ModelArg = str | Model | dict[str, Any] | os.PathLike[str]

@dataclass(frozen=True)
class FitResult:
    """One fitted model family: `label`, the fitted `model` (a tuple of three for a
    per-channel fit) and the fit `record` (the dict `fit-brdf fit --record` writes)."""

    label: str
    model: Model | tuple[Model, Model, Model]
    record: dict[str, Any]
    @property
    def losses(self) -> dict[str, float]:
        """Each of the eight losses' overall value on the full table, by loss name."""
    def to_json(self) -> str:
        """The fitted model's file, as `fit-brdf fit --out` writes it."""
    def record_json(self) -> str:
        """The fit record's file, as `fit-brdf fit --record` writes it."""
    def save(self, path: str | os.PathLike[str], record: str | os.PathLike[str] | None = None) -> None:
        """Writes the model file to `path` and the record to `record` (atomically)."""

def fit(
    table: MerlTable,
    model: _ModelArg | Sequence[_ModelArg] = ...,
    loss: _Loss = ...,
    starts: int = ...,
    *,
    progress: Callable[[dict[str, Any]], object] | None = None,
    weighting: Literal["solid-angle", "uniform"] = ...,
    solver: str = ...,
    finish: int = ...,
    sample_fraction: float = ...,
    theta_d_max: float | None = None,
    theta_max: float | None = None,
    per_channel: bool = ...,
    seed: int = ...,
    fix: str | Sequence[str] | None = None,
    robust: str = ...,
    robust_scale: float | None = None,
    energy_conserving: bool = False,
    full_iters: int | Literal["all", "auto"] = ...,
    explore_cells: int = ...,
    losses: Literal["own", "all"] = ...,
    distribution: str | None = None,
    masking: str | None = None,
    fresnel: str | None = None,
    normalization: str | None = None,
) -> FitResult | list[FitResult]:
    """Fits an analytic model to a table, as `fit-brdf fit` does, with its defaults.

    table: the measured table.
    model: a model name, a model JSON file, a Model or its dict (the start), or a
        comma-separated str or sequence of them (then a list of results).
    loss: the loss minimised (`low-e1` and `low_e1` are the same).
    starts: starts per pass.
    progress: called with one dict per event (`plan`, `iter`, `start_done`).
    weighting: the cell weights.
    solver: `lm`, `gauss-newton`, `lbfgs`, `nelder-mead`, ...
    finish: starts finished on all cells after the ranking.
    sample_fraction: the stratified fraction of the cells fitted, in (0, 1].
    theta_d_max: leave out cells with θd above this angle (degrees).
    theta_max: leave out cells with θi or θo above this angle (degrees).
    per_channel: every parameter per channel (default: the shape shared).
    seed: seed of the starts and the subsample.
    fix: parameters (names or groups) held at their start values.
    robust: the robust loss (`none`, `huber`, `cauchy`, ...).
    robust_scale: its scale (None: automatic).
    energy_conserving: bound the directional albedo by 1.
    full_iters: iterations on all cells after the warm-up: a count, `all` or `auto`.
    explore_cells: size of the exploration subsample of a ranked fit.
    distribution, masking, fresnel: cook-torrance's structural choices.
    normalization: ward's normalisation.

    Raises ValueError (a bad value, naming the argument), TypeError (an argument of
    the wrong kind), FileNotFoundError (a missing model file), RuntimeError (the fit
    failed).
    """
