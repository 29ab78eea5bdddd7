"""Input checks shared by every package: one clear ValueError per problem."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def as_float_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Convert ``value`` to a float64 array, naming ``name`` if it cannot be."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None


def require_finite(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Return ``value`` as float64, raising ValueError if any entry is NaN or inf."""
    arr = as_float_array(name, value)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def require_positive(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and > 0, else raise ValueError."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return v


def require_nonnegative(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and >= 0, else raise ValueError."""
    v = float(value)
    if not np.isfinite(v) or v < 0.0:
        raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
    return v


def require_last_dim(name: str, arr: NDArray[np.float64], size: int) -> NDArray[np.float64]:
    """Raise ValueError unless ``arr`` has shape ``(..., size)``."""
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ValueError(f"{name} must have shape (..., {size}), got {arr.shape}")
    return arr


def require_angle_below(name: str, value: float, limit: float) -> float:
    """Return ``value`` (rad) as float if finite with ``|value| < limit``, else raise ValueError."""
    a = float(value)
    if not np.isfinite(a) or abs(a) >= limit:
        raise ValueError(f"{name} must be finite and below {np.degrees(limit):g}°, got {value!r}")
    return a
