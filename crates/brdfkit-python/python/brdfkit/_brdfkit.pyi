"""Type stubs of the extension module (the classes are re-exported by `brdfkit`)."""

import os
from typing import Any, Callable, Literal

import numpy as np
import numpy.typing as npt

_Dirs = npt.ArrayLike
_Interp = Literal["nearest", "linear"]

class MerlTable:
    """A measured isotropic BRDF on the MERL (θh, θd, φd) grid."""

    @staticmethod
    def read(path: str | os.PathLike[str]) -> MerlTable:
        """Reads a MERL binary table; OSError (FileNotFoundError, ...) or ValueError."""
    @staticmethod
    def from_values(values: npt.NDArray[np.float64]) -> MerlTable:
        """A table from a (3, nθh, nθd, nφd) array of f_r in 1/sr, NaN for missing."""
    def write(self, path: str | os.PathLike[str]) -> None:
        """Writes the table atomically."""
    @property
    def dims(self) -> tuple[int, int, int]:
        """(nθh, nθd, nφd)."""
    @property
    def path(self) -> str | None:
        """The file the table was read from."""
    @property
    def valid_fraction(self) -> float:
        """Fraction of cells with a sample."""
    @property
    def values(self) -> npt.NDArray[np.float64]:
        """f_r in 1/sr, a new (3, nθh, nθd, nφd) array, NaN where missing."""
    @property
    def valid_mask(self) -> npt.NDArray[np.bool_]:
        """True where the table has a sample, (nθh, nθd, nφd)."""
    def lookup(self, wi: _Dirs, wo: _Dirs, interp: _Interp = "nearest") -> npt.NDArray[np.float64]:
        """f_r at each pair: (N, 3) in, (N, 3) out, NaN where there is no sample."""

class Model:
    """An analytic BRDF model with its parameters (the JSON contract)."""

    @staticmethod
    def from_json(description: str | dict[str, Any]) -> Model:
        """A model from its JSON description (text or dict); ValueError if invalid."""
    @staticmethod
    def default(name: str) -> Model:
        """The model `name` at its default start."""
    def to_json(self, pretty: bool = False) -> str:
        """The JSON description."""
    @property
    def name(self) -> str:
        """The model's name."""
    @property
    def params(self) -> dict[str, Any]:
        """The `params` object of the JSON description."""
    @property
    def param_names(self) -> list[str]:
        """Names of the flat parameter vector."""
    @property
    def param_vector(self) -> npt.NDArray[np.float64]:
        """The flat parameter vector."""
    def eval(self, wi: _Dirs, wo: _Dirs) -> npt.NDArray[np.float64]:
        """f_r (1/sr, no cosine) at each pair: (N, 3) in, (N, 3) out."""

class Nbrdf:
    """A neural BRDF: the six .npy weight files DIR/NAME_*.npy."""

    @staticmethod
    def load(path: str | os.PathLike[str]) -> Nbrdf:
        """Loads DIR/NAME."""
    @property
    def name(self) -> str:
        """The material's name."""

def check(source: Model | MerlTable) -> dict[str, Any]:
    """The physical-check report (`fit-brdf check --json`)."""

def resample(
    source: Model | MerlTable | Nbrdf,
    dims: tuple[int, int, int] = (90, 90, 180),
    interp: _Interp = "nearest",
) -> MerlTable:
    """A table on the grid `dims` from a model, a table or a neural BRDF."""

def fit(
    table: MerlTable,
    model: str | Model,
    *,
    loss: str = "cbrt",
    weighting: str = "solid-angle",
    solver: str = "lm",
    starts: int = 8,
    finish: int = 1,
    sample_fraction: float = 1.0,
    theta_d_max: float | None = None,
    theta_max: float | None = None,
    per_channel: bool = False,
    seed: int = 0,
    fix: list[str] | None = None,
    robust: str = "none",
    robust_scale: float | None = None,
    energy_conserving: bool = False,
    full_iters: str = "auto",
    explore_cells: int = 1024,
    distribution: str | None = None,
    masking: str | None = None,
    fresnel: str | None = None,
    normalization: str | None = None,
    progress: Callable[[dict[str, Any]], object] | None = None,
) -> list[tuple[str, str, str]]:
    """(label, fitted model JSON, fit record JSON) per family."""
