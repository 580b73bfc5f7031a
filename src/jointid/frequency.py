"""The frequency axis: a small immutable object that stores Hz."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import FrequencyError

__all__ = ["Frequency"]


@dataclass(frozen=True, eq=False)
class Frequency:
    """A strictly increasing, non-negative frequency axis.

    Parameters
    ----------
    hz : array_like, shape (F,)
        Frequency lines in Hz.
    """

    hz: np.ndarray

    def __post_init__(self) -> None:
        hz = np.array(self.hz, dtype=float).reshape(-1)
        if hz.size == 0:
            raise FrequencyError("frequency axis is empty; give at least one line")
        if not np.all(np.isfinite(hz)):
            raise FrequencyError("frequency axis contains NaN or infinite values")
        if np.any(hz < 0):
            raise FrequencyError(f"frequency must be >= 0 Hz, got minimum {hz.min():g} Hz")
        if hz.size > 1 and np.any(np.diff(hz) <= 0):
            raise FrequencyError("frequency axis must be strictly increasing")
        hz.setflags(write=False)
        object.__setattr__(self, "hz", hz)

    @classmethod
    def from_range(cls, start: float, stop: float, step: float) -> "Frequency":
        """Lines ``start, start+step, ...`` up to ``stop`` inclusive (Hz)."""
        if not step > 0:
            raise FrequencyError(f"frequency step must be > 0 Hz, got {step!r}")
        if not stop > start:
            raise FrequencyError(f"frequency start ({start!r} Hz) must be below stop ({stop!r} Hz)")
        n = int(np.floor((stop - start) / step + 1e-9)) + 1
        return cls(start + step * np.arange(n))

    @property
    def omega(self) -> np.ndarray:
        """Angular frequency ``2*pi*f`` in rad/s, shape (F,)."""
        return 2.0 * np.pi * self.hz

    @property
    def size(self) -> int:
        """Number of lines F."""
        return int(self.hz.size)

    def __len__(self) -> int:
        return self.size

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Frequency) and self.hz.shape == other.hz.shape and bool(
            np.allclose(self.hz, other.hz, rtol=1e-12, atol=1e-12)
        )

    def __hash__(self) -> int:  # equal axes (within the tolerance of __eq__) must hash alike
        return hash(self.size)

    def mask(self, start: float | None = None, stop: float | None = None) -> np.ndarray:
        """Boolean mask of the lines in ``[start, stop]`` Hz (either bound optional)."""
        m = np.ones(self.size, dtype=bool)
        if start is not None:
            m &= self.hz >= start - 1e-9
        if stop is not None:
            m &= self.hz <= stop + 1e-9
        return m

    def __getitem__(self, index) -> "Frequency":
        return Frequency(self.hz[index])

    def __repr__(self) -> str:
        if self.size == 1:
            return f"Frequency({self.hz[0]:g} Hz)"
        return f"Frequency({self.hz[0]:g}-{self.hz[-1]:g} Hz, {self.size} lines)"
