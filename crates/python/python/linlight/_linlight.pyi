"""Type stubs of the native module ``linlight._linlight`` (use the ``linlight`` package)."""

from os import PathLike
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

class LinlightError(ValueError):
    """Unusable input; the message is the one the ``linlight`` command prints."""

def techniques() -> List[str]: ...

class Prepared:
    @property
    def technique(self) -> str: ...
    def __len__(self) -> int: ...
    def valid(self) -> npt.NDArray[np.bool_]: ...
    def sample(self, xi: npt.NDArray[np.float32]) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def pdf(self, directions: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]: ...
    def inverse(self, directions: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]: ...

def prepare(
    technique: str,
    begin: npt.NDArray[np.float32],
    end: npt.NDArray[np.float32],
    x: npt.NDArray[np.float32],
    n: npt.NDArray[np.float32],
) -> Prepared: ...
def prepare_ltc(
    begin: npt.NDArray[np.float32],
    end: npt.NDArray[np.float32],
    x: npt.NDArray[np.float32],
    n: npt.NDArray[np.float32],
    view: npt.NDArray[np.float32],
    alpha: Optional[npt.NDArray[np.float32]] = ...,
    ltc_a: Optional[npt.NDArray[np.float32]] = ...,
) -> Prepared: ...

class Image:
    def __init__(
        self, mean: npt.NDArray[np.float32], var: npt.NDArray[np.float32], header: Dict[str, str]
    ) -> None: ...
    @staticmethod
    def read(path: Union[str, PathLike[str]]) -> Image: ...
    def write(self, path: Union[str, PathLike[str]]) -> None: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def mean(self) -> npt.NDArray[np.float32]: ...
    @property
    def var(self) -> npt.NDArray[np.float32]: ...
    @property
    def tail(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def header(self) -> Dict[str, Union[str, int, float]]: ...

def compare(
    a: Image, b: Image, alpha: float = ..., tolerance: float = ..., tile: int = ..., allow_different_scenes: bool = ...
) -> Tuple[str, npt.NDArray[np.float32]]: ...
def render(
    scene: Union[str, PathLike[str]],
    defines: Sequence[Tuple[str, str]],
    spp: Optional[int] = ...,
    passes: int = ...,
    seed: Optional[int] = ...,
    technique: str = ...,
    noise: str = ...,
    mis: Optional[str] = ...,
    light_samples: Optional[int] = ...,
    lights: str = ...,
    cylinders: str = ...,
    cylinder_technique: str = ...,
    cylinder_mis: str = ...,
    threads: Optional[int] = ...,
) -> Tuple[Image, List[str]]: ...
