"""Type stubs of the extension module (the classes are re-exported by `brdfkit`).

Array arguments take anything `numpy.asarray(x, dtype=numpy.float64)` takes (float32
or integer arrays, nested lists and tuples, Fortran-order arrays, strided views); the
shape is checked and an error names the argument. Directions must be unit vectors
(|w| within 1e-6 of 1), else ValueError naming the first offending row.
"""

import os
from collections.abc import Sequence
from typing import Any, Callable, Literal

import numpy as np
import numpy.typing as npt

__version__: str

_Dirs = npt.ArrayLike
_Interp = Literal["nearest", "linear"]
_Path = str | os.PathLike[str]

class MerlTable:
    """A measured isotropic BRDF on the MERL (θh, θd, φd) grid."""

    @staticmethod
    def read(path: _Path) -> MerlTable:
        """Reads a MERL binary table (any dims).

        path: the table file.
        Raises FileNotFoundError (missing), IsADirectoryError, PermissionError or another
        OSError (unreadable), ValueError (not a valid table: truncated, bad header).
        """
    @staticmethod
    def from_values(values: npt.ArrayLike) -> MerlTable:
        """A table from f_r in 1/sr.

        values: a (3, nθh, nθd, nφd) array (R, G, B planes); NaN marks a missing cell.
        Raises ValueError (the shape, or dims out of range), TypeError or ValueError
        (not convertible to float64).
        """
    def write(self, path: _Path) -> None:
        """Writes the table atomically (whole, or not at all).

        path: the file written. Raises OSError if it cannot be written.
        """
    @property
    def dims(self) -> tuple[int, int, int]:
        """(nθh, nθd, nφd)."""
    @property
    def path(self) -> str | None:
        """The file the table was read from (None for a table made in memory)."""
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
        """f_r (1/sr, no cosine) at each pair (wi[k], wo[k]), an (N, 3) float64 array.

        wi, wo: (N, 3) unit directions pointing away from the surface (a (3,) direction
            is one row); NaN where either is below the horizon (z ≤ 0) or the cell has
            no sample.
        interp: "nearest" (the MERL reference lookup) or "linear".
        Raises ValueError (a shape, unequal lengths, a direction not of unit length,
        an unknown interp).
        """

class Model:
    """An analytic BRDF model with its parameters (the JSON contract). Two models are
    equal when their JSON descriptions are."""

    @staticmethod
    def from_json(description: str | dict[str, Any] | os.PathLike[str]) -> Model:
        """A model from its JSON description.

        description: the JSON text (a str starting with `{`), its dict, or the path of a
            model JSON file (any other str, or an os.PathLike).
        Raises ValueError (invalid JSON, an unknown model, a parameter out of its
        domain), FileNotFoundError (no such file), TypeError (another kind of object).
        """
    @staticmethod
    def default(name: str) -> Model:
        """The model `name` at its default start. Raises ValueError (unknown name)."""
    def to_json(self, pretty: bool = False) -> str:
        """The JSON description, compact or pretty-printed (`pretty`)."""
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
        """f_r (1/sr, no cosine) at each pair (wi[k], wo[k]), an (N, 3) float64 array.

        wi, wo: (N, 3) unit directions pointing away from the surface (a (3,) direction
            is one row); 0 where either is below the horizon (z ≤ 0).
        Raises ValueError (a shape, unequal lengths, a direction not of unit length).
        """
    def __eq__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

class Nbrdf:
    """A neural BRDF: the six .npy weight files DIR/NAME_*.npy."""

    @staticmethod
    def load(path: _Path) -> Nbrdf:
        """Loads DIR/NAME (the stem of the six weight files).

        Raises FileNotFoundError (a weight file is missing), ValueError (a malformed
        file: not .npy, wrong dtype or shape, a non-finite weight), OSError (unreadable).
        """
    @property
    def name(self) -> str:
        """The material's name."""

class RglBsdf:
    """An RGL-EPFL ``.bsdf`` measurement, evaluated as Mitsuba 3's ``measured`` plugin."""

    @staticmethod
    def open(path: _Path) -> RglBsdf:
        """Reads a ``.bsdf`` file (told by its bytes): FileNotFoundError, or ValueError
        naming the file and the field."""
        ...
    def eval(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """f_r (no cosine, linear RGB, 0 below the horizon) at (N, 3) pairs: (N, 3)."""
        ...
    @property
    def info(self) -> dict[str, Any]:
        """What ``fit-brdf info --json`` reports."""
        ...
    def resample(self, dims: Sequence[int] | None = None) -> MerlTable:
        """The file as a MERL table (weighted mean of both orders of each pair, negatives as 0; docs/rgl.md)."""
        ...
    @property
    def path(self) -> os.PathLike[str]: ...

def check(source: Model | MerlTable) -> dict[str, Any]:
    """The physical-check report (`fit-brdf check --json`) of a model or a table.

    Raises ValueError for another kind of source.
    """

def resample(
    source: Model | MerlTable | Nbrdf,
    dims: Sequence[int] = (90, 90, 180),
    interp: _Interp = "nearest",
) -> MerlTable:
    """A table on the grid `dims` from a model, a table or a neural BRDF.

    source: what is tabulated.
    dims: (nθh, nθd, nφd), any sequence of three integers.
    interp: how a table is looked up ("nearest" or "linear").
    Raises ValueError (dims out of range, an unknown interp), TypeError (dims not
    three integers).
    """

FIT_DEFAULTS: dict[str, Any]
"""The defaults of `fit` (the library's one set, shared with `fit-brdf fit`)."""

def fit(
    table: MerlTable,
    model: str | Model | Sequence[str | Model | os.PathLike[str]],
    *,
    progress: Callable[[dict[str, Any]], object] | None = None,
    **settings: Any,
) -> list[tuple[str, str, str, str]]:
    """(label, model file text, record file text, iterations by stage) per family
    (`brdfkit.fit` documents every setting; their defaults are `FIT_DEFAULTS`)."""

def _write_text(path: _Path, text: str) -> None:
    """Writes `text` to `path` atomically."""
