"""brdfkit in Python: measured BRDFs with NumPy arrays in and out."""

import os
from dataclasses import dataclass
from typing import Any, Callable, Literal

from ._brdfkit import MerlTable as MerlTable
from ._brdfkit import Model as Model
from ._brdfkit import Nbrdf as Nbrdf
from ._brdfkit import check as check
from ._brdfkit import resample as resample

__all__ = ["MerlTable", "Model", "Nbrdf", "FitResult", "fit", "check", "resample"]

@dataclass(frozen=True)
class FitResult:
    """One fitted model family."""

    label: str
    model: Model | tuple[Model, Model, Model]
    record: dict[str, Any]
    @property
    def losses(self) -> dict[str, float]:
        """Each loss's overall value on the full table."""

def fit(
    table: MerlTable,
    model: str | Model | dict[str, Any] | os.PathLike[str] = "cook-torrance",
    loss: Literal["cbrt", "l2", "cosine", "log"] = "cbrt",
    starts: int = 8,
    *,
    progress: Callable[[dict[str, Any]], object] | None = None,
    weighting: Literal["solid-angle", "uniform"] = ...,
    solver: str = ...,
    finish: int = ...,
    sample_fraction: float = ...,
    theta_d_max: float | None = ...,
    theta_max: float | None = ...,
    per_channel: bool = ...,
    seed: int = ...,
    fix: str | list[str] | None = ...,
    robust: str = ...,
    robust_scale: float | None = ...,
    energy_conserving: bool = ...,
    full_iters: int | Literal["all", "auto"] = ...,
    explore_cells: int = ...,
    distribution: str | None = ...,
    masking: str | None = ...,
    fresnel: str | None = ...,
    normalization: str | None = ...,
) -> FitResult | list[FitResult]:
    """Fits an analytic model to a table, as `fit-brdf fit` does."""
