"""Envelopes of a dispersed Monte Carlo's time histories: the 1st, 50th and 99th percentiles of the
altitude, speed, total angle of attack and pitch across the cases at each time of a fixed grid.

Each case's history is kept on a fixed grid (default every :data:`HISTORY_DT_S` = 0.1 s, float32),
so memory is :data:`~casrecon.simulation.batch.HISTORY_SAMPLE_BYTES` = 16 bytes per case and grid
time: 6.4 kB per case for a 40 s drop, besides the per-case columns; only the first
:data:`HISTORY_MAX_CASES` cases keep one (64 MB for a 40 s drop, however many cases are run).

At a time t the altitude's percentiles are over every case, a landed case counting as on the ground
(0 m), so they stay exact through the touchdown window (p1 reaches 0 when 1 % of the cases have
landed). The other quantities are not defined after touchdown: their percentiles are over the
cases still in flight at t, and ``n_in_flight`` says how many those are.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from casrecon.simulation.batch import HISTORY_CHANNELS

#: Default spacing of the history grid, s.
HISTORY_DT_S = 0.1
#: Histories are kept for the first this many cases only (the envelopes' sample: the 1st and 99th
#: percentiles of 10 000 cases are each 100 cases deep), which bounds their memory whatever the
#: number of cases.
HISTORY_MAX_CASES = 10_000
#: Percentiles of the envelopes, %.
PERCENTILES = (1, 50, 99)
#: Column of the time grid (flight time since release) and of the number of cases in flight.
TIME_COLUMN, IN_FLIGHT_COLUMN = "flight_time_s", "n_in_flight"
#: The channel that counts a landed case as 0 (on the ground) instead of leaving it out.
GROUND_CHANNEL = "h_agl_m"


def envelope_column(channel: str, percentile: int | str) -> str:
    """Name of an envelope column: the channel with ``_p<percentile>`` (or ``_nominal`` for the
    centre flight) put before its unit, so the name still ends in it: ``h_agl_m`` ->
    ``h_agl_p99_m``."""
    base, unit = channel.rsplit("_", 1)
    tag = "nominal" if percentile == "nominal" else f"p{percentile}"
    return f"{base}_{tag}_{unit}"


@dataclass(frozen=True, eq=False)
class Histories:
    """Every case's history on a fixed time grid.

    Attributes
    ----------
    dt_s : float
        Grid spacing, s; sample k is at k dt_s after release.
    data : (n, n_times, 4) float32 array
        :data:`~casrecon.simulation.batch.HISTORY_CHANNELS` per case and time; NaN once the case
        has landed (the first n cases of the run, at most :data:`HISTORY_MAX_CASES`).
    impacted : (n,) bool array
        The case reached the ground (its NaNs mean "landed", not "not simulated").
    nominal : (n_times_nominal, 4) float32 array
        The centre (undispersed) flight's history.
    """

    dt_s: float
    data: np.ndarray
    impacted: np.ndarray
    nominal: np.ndarray

    @property
    def time_s(self) -> np.ndarray:
        """The grid, s since release."""
        return self.dt_s * np.arange(self.data.shape[1])

    @property
    def n_cases(self) -> int:
        """Cases with a history (the envelopes' sample)."""
        return int(self.data.shape[0])

    @property
    def nbytes(self) -> int:
        """Memory of the per-case histories, bytes."""
        return int(self.data.nbytes)

    def envelopes(self) -> dict[str, np.ndarray]:
        """The envelope table: time (s), cases in flight, then per channel its :data:`PERCENTILES` and
        the nominal flight (NaN where it has landed), named by :func:`envelope_column`."""
        t = self.time_s
        flying = ~np.isnan(self.data[:, :, 0])
        out = {TIME_COLUMN: t, IN_FLIGHT_COLUMN: flying.sum(axis=0).astype(float)}
        for c, channel in enumerate(HISTORY_CHANNELS):
            values = self.data[:, :, c]
            if channel == GROUND_CHANNEL:
                values = np.where(np.isnan(values) & self.impacted[:, None], np.float32(0.0), values)
            with warnings.catch_warnings():  # "All-NaN slice": no case in flight there, NaN as intended
                warnings.simplefilter("ignore", RuntimeWarning)
                pct = np.nanpercentile(values, PERCENTILES, axis=0)
            for p, row in zip(PERCENTILES, pct):
                out[envelope_column(channel, p)] = row.astype(float)
            nominal = np.full(t.size, np.nan)
            k = min(t.size, self.nominal.shape[0])
            nominal[:k] = self.nominal[:k, c]
            out[envelope_column(channel, "nominal")] = nominal
        return out
