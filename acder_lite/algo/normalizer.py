"""Running mean/std normaliser with Baselines' clipping (HER's `Normalizer`)."""

from __future__ import annotations

import numpy as np
import torch


class Normalizer:
    """Keeps sum, sum of squares and count (float64) of everything it has seen.

    mean = sum/count, std = sqrt(max(eps^2, sumsq/count - mean^2)); `normalize` returns
    clip((x - mean)/std, -clip, clip). Statistics change only in `update`, so a
    minibatch is normalised with the same numbers throughout one update step.
    """

    def __init__(self, size: int, eps: float = 0.01, clip: float = 5.0):
        self.size, self.eps, self.clip = size, eps, clip
        self.sum = np.zeros(size, np.float64)
        self.sumsq = np.zeros(size, np.float64)
        self.count = 0
        self.mean = np.zeros(size, np.float64)
        self.std = np.ones(size, np.float64)
        self._sync()

    def update(self, x: np.ndarray) -> None:
        x = np.asarray(x, np.float64).reshape(-1, self.size)
        self.sum += x.sum(0)
        self.sumsq += np.square(x).sum(0)
        self.count += x.shape[0]
        self.mean = self.sum / self.count
        self.std = np.sqrt(
            np.maximum(self.eps**2, self.sumsq / self.count - np.square(self.mean))
        )
        self._sync()

    def _sync(self) -> None:
        self._mean_t = torch.as_tensor(self.mean, dtype=torch.float32)
        self._inv_std_t = torch.as_tensor(1.0 / self.std, dtype=torch.float32)

    def normalize(self, x):
        """numpy in, numpy out; torch in, torch out (float32)."""
        if isinstance(x, torch.Tensor):
            return ((x - self._mean_t) * self._inv_std_t).clamp_(-self.clip, self.clip)
        return np.clip((x - self.mean) / self.std, -self.clip, self.clip)

    def state_dict(self) -> dict:
        return dict(sum=self.sum.copy(), sumsq=self.sumsq.copy(), count=self.count)

    def load_state_dict(self, d: dict) -> None:
        self.sum, self.sumsq, self.count = (
            np.array(d["sum"]),
            np.array(d["sumsq"]),
            int(d["count"]),
        )
        if self.count:
            self.mean = self.sum / self.count
            self.std = np.sqrt(
                np.maximum(self.eps**2, self.sumsq / self.count - np.square(self.mean))
            )
        self._sync()
