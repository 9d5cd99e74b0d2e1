"""Error figures shared by the modules that score a model."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike


def rms(values: ArrayLike, axis: int | None = None) -> Any:
    r"""Root mean square :math:`\sqrt{\overline{v^2}}` (over ``axis``; all values by default)."""
    values = np.asarray(values, dtype=float)
    return np.sqrt(np.mean(values**2, axis=axis))
