# Stubs of the compiled module (python/src/lib.rs). Call the typed wrappers in
# meshsmooth/__init__.py: they check the arguments these functions assume.
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

KIND_NAMES: List[str]
VERSION: str

def smooth(
    points: npt.NDArray[np.float64],
    kinds: npt.NDArray[np.uint8],
    offsets: npt.NDArray[np.int64],
    conn: npt.NDArray[np.uint32],
    fixed: Optional[npt.NDArray[np.bool_]],
    settings: str,
    callback: Optional[Callable[[Dict[str, float]], Optional[bool]]] = None,
    untangle_only: bool = False,
    fields: Optional[Dict[str, npt.NDArray[np.float64]]] = None,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def default_settings() -> str: ...
def quality(
    points: npt.NDArray[np.float64],
    kinds: npt.NDArray[np.uint8],
    offsets: npt.NDArray[np.int64],
    conn: npt.NDArray[np.uint32],
    metric: str,
) -> Tuple[Dict[str, Any], npt.NDArray[np.float64]]: ...
def read(
    path: str,
) -> Tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.uint8],
    npt.NDArray[np.int64],
    npt.NDArray[np.uint32],
    Optional[npt.NDArray[np.bool_]],
]: ...
def write(
    path: str,
    points: npt.NDArray[np.float64],
    kinds: npt.NDArray[np.uint8],
    offsets: npt.NDArray[np.int64],
    conn: npt.NDArray[np.uint32],
    format: Optional[str] = None,
) -> None: ...
def devices() -> List[Dict[str, Any]]: ...
