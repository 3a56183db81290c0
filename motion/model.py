"""Kalman algebra of :class:`motion.fusion.TrackFilter`: the motion model and
the scalar measurement updates on

    x = [track coordinate s (m), speed u along increasing s (m/s),
         accelerometer bias b (m/s²)]

with the covariance ``P`` kept as its upper triangle.  The accelerometer reads
``a_m = o·(ü + g·i(s)) + b + noise`` (``o = ±1`` the car's orientation,
``i(s)`` the gradient in ‰), so ``u̇ = o·(a_m − b) − g·i(s)``; between two
samples the acceleration is taken linear in time and integrated exactly.

Everything here is a pure function of its arguments: an :data:`Estimate` is
an immutable tuple, and :meth:`KalmanModel.predict` and
:meth:`KalmanModel.update` return new ones.  The arithmetic (and its order)
is the filter's numerical contract: stored snapshots continue bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from enum import IntEnum
from typing import NamedTuple

from .samples import FilterConfig
from .track import MarkerTable

__all__ = [
    "G",
    "PER_MILLE",
    "Estimate",
    "estimate",
    "KalmanModel",
    "Measurement",
    "MeasurementKind",
]

G = 9.81  # m/s², gravity: the gradient's share of the accelerometer reading
PER_MILLE = 1000.0  # gradients are given in ‰


Estimate = tuple[float, float, float, float, float, float, float, float, float]
"""State and covariance (upper triangle) at one instant, SI units::

    (s, u, b, p00, p01, p02, p11, p12, p22)

``s`` the track coordinate (m), ``u`` the speed along increasing coordinate
(m/s), ``b`` the accelerometer bias (m/s²); ``pij`` the covariance of the
i-th and j-th of them.  Always unpacked whole, never indexed.  A plain tuple
rather than a NamedTuple: the filter builds one per sample and per replayed
sample, and a NamedTuple costs four times as much to build.
"""


def estimate(values: Iterable[float]) -> Estimate:
    """An :data:`Estimate` of nine numbers (``ValueError`` for another count)."""
    s, u, b, p00, p01, p02, p11, p12, p22 = (float(v) for v in values)
    return (s, u, b, p00, p01, p02, p11, p12, p22)


class MeasurementKind(IntEnum):
    """What a scalar measurement observes (the number is stored in snapshots)."""

    POSITION = 0  # the track coordinate (a marker read or a projected GNSS fix)
    SPEED = 1  # |u| (GNSS speed over ground)
    # |u| after a run of GNSS speeds the gate rejected: the estimate was wrong,
    # so speed and bias start again (position unknown) and this one is applied.
    SPEED_RESTART = 2
    # The sign of the speed was assumed wrong (motion.direction): the state is
    # mirrored about ``value``, the coordinate where the sign was assumed.
    DIRECTION_FLIP = 3


# (an enum member is looked up on its class at every use: ~0.2 µs in the update loop)
_POSITION = int(MeasurementKind.POSITION)
_RESTART = int(MeasurementKind.SPEED_RESTART)
_FLIP = int(MeasurementKind.DIRECTION_FLIP)


class Measurement(NamedTuple):
    """One scalar measurement attached to a buffer entry."""

    kind: int  # a MeasurementKind
    value: float  # m (POSITION) or m/s (SPEED)
    variance: float  # of the measurement error, in the value's unit squared


class KalmanModel:
    """Prediction and update for one filter configuration and marker table."""

    __slots__ = ("table", "o", "qa", "qb", "gate2", "grad", "restart")

    def __init__(self, table: MarkerTable, cfg: FilterConfig) -> None:
        self.table = table
        self.o = float(cfg.orientation)
        # white acceleration noise: the accelerometer's per-sample noise spread
        # over a sample period, plus the model's own (gradient errors, jerk)
        self.qa = cfg.accel_noise_mps2**2 / cfg.sample_rate_hz + cfg.accel_model_psd
        self.qb = cfg.bias_walk**2
        self.gate2 = cfg.gnss_gate**2
        self.grad = table.has_gradients
        # variances of position, speed and bias when the speed starts again
        self.restart = (
            cfg.unknown_position_sigma**2,
            cfg.unknown_speed_sigma**2,
            cfg.bias_sigma0**2,
        )

    def gravity_along(self, s: float) -> float:
        """The gradient's acceleration at coordinate ``s`` (m/s², 0 without a profile)."""
        return G * self.table.gradient_at(s) / PER_MILLE if self.grad else 0.0

    def predict(self, x: Estimate, dt: float, a0: float, a1: float) -> Estimate:
        """``x`` advanced by ``dt`` seconds, the measured acceleration going
        linearly from ``a0`` to ``a1`` (m/s²) over the step."""
        o = self.o
        s, u, b, p00, p01, p02, p11, p12, p22 = x
        # (gravity_along inlined: this runs for every sample and every replayed one)
        gi = G * self.table.gradient_at(s) / PER_MILLE if self.grad else 0.0
        acc_v = o * ((a0 + a1) * 0.5 - b) - gi  # mean acceleration over the step
        acc_s = o * ((2.0 * a0 + a1) / 3.0 - b) - gi  # its weight in the distance
        # F = [[1, A, Bc], [0, 1, C], [0, 0, 1]]; P' = F P Fᵀ + Q
        A = dt
        Bc = -o * 0.5 * dt * dt
        C = -o * dt
        r00 = p00 + A * p01 + Bc * p02
        r01 = p01 + A * p11 + Bc * p12
        r02 = p02 + A * p12 + Bc * p22
        r11 = p11 + C * p12
        r12 = p12 + C * p22
        qa = self.qa
        dt2 = dt * dt
        return (
            s + u * dt + 0.5 * acc_s * dt * dt,
            u + acc_v * dt,
            b,
            r00 + A * r01 + Bc * r02 + qa * dt2 * dt / 3.0,
            r01 + C * r02 + qa * dt2 * 0.5,
            r02,
            r11 + C * r12 + qa * dt,
            r12,
            p22 + self.qb * dt,
        )

    def update(self, x: Estimate, measurements: Sequence[Measurement]) -> Estimate:
        """``x`` after the scalar Kalman updates of ``measurements``, in order."""
        for kind, z, r in measurements:
            if kind == _RESTART:
                x = self._restarted(x)
            elif kind == _FLIP:
                x = self._flipped(x, z)
                continue
            s, u, b, p00, p01, p02, p11, p12, p22 = x
            if kind == _POSITION:
                y = z - s
                c0, c1, c2 = p00, p01, p02  # P·Hᵀ with H = [1, 0, 0]
                sv = c0 + r
            else:
                # GNSS measures |u|: linearised with the sign of the estimate.
                y = (1.0 if u >= 0.0 else -1.0) * z - u
                c0, c1, c2 = p01, p11, p12  # P·Hᵀ with H = [0, ±1, 0]
                sv = c1 + r
                if kind != _RESTART and y * y > self.gate2 * sv:
                    continue  # an outlier (multipath, re-acquisition glitch)
            k0, k1, k2 = c0 / sv, c1 / sv, c2 / sv
            x = (
                s + k0 * y,
                u + k1 * y,
                b + k2 * y,
                p00 - k0 * c0,
                p01 - k0 * c1,
                p02 - k0 * c2,
                p11 - k1 * c1,
                p12 - k1 * c2,
                p22 - k2 * c2,
            )
        return x

    def _restarted(self, x: Estimate) -> Estimate:
        """``x`` with speed, bias and position unknown (the bias back to 0):
        what a filter that lost track of its speed honestly knows."""
        s, u, _, *_ = x
        ps, pu, pb = self.restart
        return (s, u, 0.0, ps, 0.0, 0.0, pu, 0.0, pb)

    def _flipped(self, x: Estimate, anchor_m: float) -> Estimate:
        """``x`` on the other way from ``anchor_m``: coordinate mirrored about it,
        speed negated (covariance as ``T·P·T``, ``T = diag(-1, -1, 1)``); the bias,
        learnt while the sign was wrong, starts again from its prior."""
        s, u, _, p00, p01, _, p11, _, _ = x
        return (2.0 * anchor_m - s, -u, 0.0, p00, p01, 0.0, p11, 0.0, self.restart[2])

    def speed_rejected(self, x: Estimate, z: float, r: float) -> bool:
        """Whether the gate in :meth:`update` rejects the speed ``z`` (variance ``r``) at ``x``."""
        _, u, _, _, _, _, p11, _, _ = x
        y = (1.0 if u >= 0.0 else -1.0) * z - u
        return y * y > self.gate2 * (p11 + r)
