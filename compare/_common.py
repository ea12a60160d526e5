"""Pieces shared by the observables: the freud-style result base class and
JSON cleaning."""
import math

import numpy as np


class Result:
    """Base for the observables: configure in the constructor, ``compute``
    stores results in ``self._result`` and returns self; reading a result
    before ``compute`` raises RuntimeError."""

    _result = None

    def _get(self, key):
        if self._result is None:
            raise RuntimeError(f"{type(self).__name__}: call compute(run) before reading results")
        return self._result[key]


def clean_json(x):
    """JSON-safe: numpy scalars to Python, arrays to lists, NaN/inf to None."""
    if isinstance(x, dict):
        return {str(k): clean_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean_json(v) for v in x]
    if isinstance(x, np.ndarray):
        return clean_json(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
