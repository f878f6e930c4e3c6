"""Energy audit of a run: no step may create energy.

Per step k -> k+1 the audit computes the energy error [J]::

    energy_error[k+1] = (E[k+1] - E[k]) - W_drive[k]

with E the stored ``energy`` (kinetic + gravitational + springs; a compliant contact model adds
its elastic energy to it) and W_drive the work of the prescribed crank rotation over the step.
Everything else in the model only removes energy: dampers, friction, restitution below one and
the scheme's numerical dissipation (rho_inf < 1). A step whose energy error is above

    tolerance[k] = energy_tol * S[k]  +  ENERGY_FLOOR_J,
    S[k] = max_{j <= k} max(|E[j]|, E[j] - V_g[j])

created energy: it counts as not converged, with the consequence of
``solver.on_nonconvergence`` (an error naming the step, time and gain, or the flag in
``converged``). So does a run of steps that together created more than the same tolerance,
each of them within it: the audit's *window gain* at step k,

    window[k] = C[k] - min_{j <= k} C[j],   C[k] = sum_{i <= k} energy_error[i]  (C[0] = 0),

is the energy the steps since the lowest point of the cumulative error created together (the
step's own error is the window of one step, so this criterion holds the per-step one). A gain
reported starts the next window (the min is taken from that step on), so that the steps after
it are judged by what they add, not flagged again for the same joules. Without the window a
run could climb by many steps each just within the tolerance: rigid impacts with
e_N = 1 on several contacts at once gain energy by Newton's law (a run without a cage at e_N = 1
and mu = 0 went from 33.6 J to 42.2 J in 0.073 s, its largest step 0.0048 of the scale). The
time loop's retries (:data:`simcore.kernels.RetrySettings`) test the step alone.

Drive work
----------
The drive is the rheonomic constraint phi_crank = phi0 + omega0 t; its multiplier, stored as
``drive_torque[k+1]``, is the constraint impulse of the step k -> k+1 divided by h (smooth part
and impulsive part of an impact in that step). The crank turns at exactly omega0, so the drive's
work over the step is ``drive_torque[k+1] * omega0 * h``. (A trapezoid of the stored torque
mixes the impulse of an impact into the neighbouring step: on the paper's case with the
constant drive it misplaces up to 4.8 J of a 34 J run per step, while the step-end value
balances to 1e-4 J.) A compliant run writes one row per output interval of many steps; its
``drive_torque`` is the torque averaged over the interval (its torque impulse, the sum of
h * torque over the interval's steps, over the interval's length), so that the same product is
the drive's work over the interval, whatever the steps (fixed or adaptive).

Tolerance
---------
``solver.energy_tol`` is relative to the energy scale S of the run up to the step (kinetic
energy of the mechanism plus what the drive put in), plus an absolute floor of
``ENERGY_FLOOR_J`` for runs whose energy is near zero. S is the largest of |E| and of E without
gravity's potential V_g (kinetic, spring and contact energy): V_g's datum is arbitrary (the
origin), so |E| alone can stay near 0 while the mechanism moves (released from rest, E stays at
its start while V_g turns into kinetic energy), and the floor alone would then judge a step's
rounding of joules of kinetic energy. The time loop of the nonsmooth model computes S and the
per-step criterion with the same operations (:data:`simcore.kernels.RetrySettings`), so that
both judge a step's own gain alike; the window (above) is the audit's alone: a step it flags
was not retried, and under ``error`` it stops the run. The default 5e-3 comes from
measurements (``docs/reliability.md``): the largest gain of one step is 1.3e-3 of the energy in
conservative runs (e_N = 1, mu = 0, no cage damping, rho_inf = 1; dt 1e-5 to 1.6e-4 s, omega0
50 and 300 rad/s, both drives), 2.7e-3 in the worst of 250 random resolved runs, 1.6e-6 in the
paper's case; the runs that blow up gain from 0.6 % to 1e5 times their energy in one step.
"""

from __future__ import annotations

import numpy as np

#: absolute floor of the per-step tolerance [J] (rounding of an energy of a few joules)
ENERGY_FLOOR_J = 1e-9


def drive_rate(model) -> float:
    """Prescribed crank speed of the model's drive [rad/s]; 0 without a prescribed rotation."""
    from ..kernels import JOINT_ANGLE

    for kind, _bi, _bj, geom in model.joints:
        if kind == JOINT_ANGLE:
            return float(geom[1])
    return 0.0


class EnergyAudit:
    """Energy balance of every step, checked chunk by chunk inside the time loop.

    Parameters
    ----------
    model : simcore.model.Model
        The model being integrated (for the drive's rate).
    dt : float
        Time step h [s].
    n_steps : int
        Number of steps of the run.
    energy_tol : float
        Relative tolerance (see the module docstring) [-].
    t0 : float
        Time of the first output row [s] (a restarted run, e.g. a compliant zoom).

    Attributes
    ----------
    error : numpy.ndarray
        Energy error of the step ending at each time [J] (0 at t = 0).
    window : numpy.ndarray
        Window gain at each time [J] (see the module docstring).
    cumulative : numpy.ndarray
        Cumulative energy error C at each time [J].
    lowest : numpy.ndarray
        C where the window of each time starts [J].
    tolerance : numpy.ndarray
        Their tolerance [J].
    """

    def __init__(self, model, dt: float, n_steps: int, energy_tol: float, t0: float = 0.0):
        self.rate = drive_rate(model)
        self.t0 = float(t0)
        self.dt = float(dt)
        self.energy_tol = float(energy_tol)
        self.error = np.zeros(n_steps + 1)
        self.window = np.zeros(n_steps + 1)
        self.cumulative = np.zeros(n_steps + 1)  # C (0 at t = 0)
        self.lowest = np.zeros(n_steps + 1)  # where each row's window starts, C there
        self.tolerance = np.zeros(n_steps + 1)
        self._scale = 0.0
        self._lowest = 0.0  # the start of the current window, C there

    def check(self, energy: np.ndarray, drive_torque: np.ndarray, converged: np.ndarray,
              k0: int, k1: int, scale_terms: np.ndarray | None = None) -> int:
        """Audit steps k0 .. k1-1 (outputs at indices k0+1 .. k1); set ``converged`` to 0 on
        every step that created energy beyond the tolerance, alone or in a window of steps.

        Parameters
        ----------
        scale_terms : numpy.ndarray, optional
            What rows k0 .. k1-1 add to the energy scale [J]
            (:func:`simcore.kernels.energy_scale_terms_into`); None: |E| of those rows (exact
            for a model without gravity).

        Returns
        -------
        int
            Index k of the first of these steps whose window gain is beyond the tolerance, or
            -1.
        """
        e_prev = energy[k0:k1]
        e_next = energy[k0 + 1:k1 + 1]
        work = drive_torque[k0 + 1:k1 + 1] * self.rate * self.dt
        err = (e_next - e_prev) - work
        terms = np.abs(e_prev) if scale_terms is None else scale_terms
        scale = np.maximum.accumulate(np.maximum(terms, self._scale))
        self._scale = float(scale[-1])
        tol = self.energy_tol * scale + ENERGY_FLOOR_J
        cumulative = self.cumulative[k0] + np.cumsum(err)
        lowest = np.empty_like(cumulative)
        bad = []
        start = 0
        while start < cumulative.size:
            part = np.minimum.accumulate(np.minimum(cumulative[start:], self._lowest))
            lowest[start:] = part
            # the step's own error too, as the time loop tests it (C[k] - C[k-1] is err[k]
            # only to rounding)
            over = np.flatnonzero(~((cumulative[start:] - part <= tol[start:])
                                    & (err[start:] <= tol[start:])))  # NaN: bad
            if not over.size:
                self._lowest = float(part[-1])
                break
            j = start + int(over[0])
            if not np.isfinite(cumulative[j]):  # every row from here on
                bad.extend(range(j, cumulative.size))
                break
            bad.append(j)
            # a gain reported is the start of the next window: the rows after it are judged
            # by what they add, not flagged again for the same gain
            self._lowest = float(cumulative[j])
            start = j + 1
        bad = np.asarray(bad, dtype=int)
        self.error[k0 + 1:k1 + 1] = err
        self.cumulative[k0 + 1:k1 + 1] = cumulative
        self.lowest[k0 + 1:k1 + 1] = lowest
        self.window[k0 + 1:k1 + 1] = cumulative - lowest
        self.tolerance[k0 + 1:k1 + 1] = tol
        converged[k0 + 1 + bad] = 0
        return int(k0 + bad[0]) if bad.size else -1

    def message(self, k: int) -> str:
        """One line about step k (output row k+1) that created energy."""
        i = k + 1
        gain, tol = self.error[i], self.tolerance[i]
        if not np.isfinite(gain):
            return (f"energy audit: non-finite energy at step {i} "
                    f"(t = {self.t0 + i * self.dt:.6g} s)")
        scale = max((tol - ENERGY_FLOOR_J) / self.energy_tol, ENERGY_FLOOR_J)
        allowed = f"allowed: {tol:.3g} J, solver.energy_tol = {self.energy_tol:g}"
        if gain > tol:
            return (f"energy audit: step {i} (t = {self._time(i):.6g} s) created {gain:.4g} J "
                    f"({gain / scale:.3g} of the run's energy scale {scale:.4g} J; {allowed})")
        window = self.window[i]
        first = self._window_start(i) + 1
        return (f"energy audit: steps {first} to {i} (t = {self._time(first - 1):.6g} to "
                f"{self._time(i):.6g} s) created {window:.4g} J together ({window / scale:.3g} "
                f"of the run's energy scale {scale:.4g} J; {allowed}), each within the "
                f"tolerance, the largest {self.error[first:i + 1].max():.3g} J")

    def _time(self, i: int) -> float:
        return self.t0 + i * self.dt

    def _window_start(self, i: int) -> int:
        """The output row where the window of row i starts (the last row before it whose C is
        the window's lowest, ``lowest[i]``, which is a copy of that row's C)."""
        return int(np.flatnonzero(self.cumulative[:i + 1] == self.lowest[i])[-1])

    def trim(self, n_rows: int) -> None:
        """Keep the first ``n_rows`` output rows (a run stopped early)."""
        for name in ("error", "window", "cumulative", "lowest", "tolerance"):
            setattr(self, name, getattr(self, name)[:n_rows])

    def gains(self) -> np.ndarray:
        """Indices (output rows) of the steps flagged: their own gain or their window's beyond
        the tolerance (a non-finite energy too)."""
        within = (self.window <= self.tolerance) & (self.error <= self.tolerance)
        return np.flatnonzero(~within)

    def summary(self, energy: np.ndarray) -> dict:
        """Attributes for the dataset: largest gain, relative to the scale, and the balance.

        ``energy_balance_J`` = E_end - E_0 - total drive work: the drift of a conservative run
        (e_N = 1, mu = 0, no dampers, rho_inf = 1); negative (the energy dissipated) otherwise.
        """
        k = int(np.argmax(self.error))
        w = int(np.argmax(self.window))
        scale = max(self._scale, float(np.max(np.abs(energy))), ENERGY_FLOOR_J)
        return {
            "energy_max_gain_J": float(self.error[k]),
            "energy_max_gain_time_index": k,
            "energy_max_gain_relative": float(self.error[k] / scale),
            "energy_max_window_gain_J": float(self.window[w]),
            "energy_max_window_gain_time_index": w,
            "energy_max_window_gain_relative": float(self.window[w] / scale),
            "energy_balance_J": float(np.sum(self.error)),
            "energy_balance_relative": float(np.sum(self.error) / scale),
            "energy_tol": self.energy_tol,
            "n_energy_gain_steps": int(self.gains().size),
        }
