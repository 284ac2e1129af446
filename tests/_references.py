"""Independent references the tests share (plain NumPy and SciPy, no jaxgwo)."""

import numpy as np
import scipy.signal


def lsim_of_delayed_held_input(num, den, t, u, delay: float, fine: int) -> np.ndarray:
    """``scipy.signal.lsim`` of ``num/den`` driven by the held (zero-order) input ``u``
    delayed by ``delay`` (zero before the record), on a grid ``fine`` times finer than the
    samples ``t`` and read back at them.  Exact where ``delay`` is a whole number of fine
    steps, which is asserted."""
    dt = float(t[1] - t[0])
    shift = int(round(delay * fine / dt))
    if abs(shift * dt / fine - delay) > 1e-9 * dt:
        raise ValueError(f"delay {delay} is not a whole number of fine steps of {dt / fine}")
    u_fine = np.repeat(np.asarray(u, float), fine)
    u_fine = np.r_[np.zeros(shift), u_fine[: u_fine.size - shift]]
    t_fine = t[0] + np.arange(u_fine.size) * dt / fine
    _t, y, _x = scipy.signal.lsim((num, den), u_fine, t_fine, interp=False)
    return y[::fine]
