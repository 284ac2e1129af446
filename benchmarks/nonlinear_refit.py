"""Cost of the diagnosis's nonlinear output-error refit, the part of a diagnosis that dominates its time.

    python benchmarks/nonlinear_refit.py              # both cores
    python benchmarks/nonlinear_refit.py --cpus 1     # pinned to one core

On the embedded dataset's lateral identification record (simulated R-50, the paper model
identified on it as the base), the rate-limit candidate's output error
(:class:`jaxgwo._diagnose_which.NonlinearOutputError`), timed after compilation as medians
of interleaved repeats:

* one evaluation of the error (the reference every ratio is taken against);
* a ``vmap`` of 11 evaluations, the batch a central-difference gradient needs;
* the polish's value and gradient (:func:`jaxgwo._diagnose_which._nl_value_and_grad`,
  central differences in one ``vmap``), against ``jax.jacfwd`` and ``jax.grad`` of the
  same error, with the largest difference between the three gradients;
* one whole ``fit_nonlinear_candidates`` call (rate limit, backlash, saturation and the
  null refit) with the diagnosis's pack size, once, after a warm-up call.

Writes benchmarks/results/nonlinear_refit.md; the load average at the start and end is
recorded, because on a shared machine it moves every number.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--repeats", type=int, default=15, help="repeats of each timed call")
    ap.add_argument("--cpus", type=int, default=0, help="pin the process to this many cores "
                    "(0: leave it alone); must be set before JAX starts its thread pool")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    return ap.parse_args()


sys.path.insert(0, HERE)
from machine import cpu_model, pin_cpus  # noqa: E402


def main() -> int:
    args = _args()
    pin_cpus(args.cpus)
    import equinox as eqx
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaxgwo
    from jaxgwo._atomic import atomic_write_text
    from jaxgwo._data import default_dataset
    from jaxgwo._diagnose import DiagnoseSettings, _time_pairs
    from jaxgwo._diagnose_which import (
        ModelSpec,
        _nl_value_and_grad,
        fit_nonlinear_candidates,
        nonlinear_objectives,
    )
    from jaxgwo._identify import identify_channels

    load0 = os.getloadavg()
    settings = DiagnoseSettings()
    rec = default_dataset().identification["lateral"]
    nominal = identify_channels({"lateral": [rec]}, settings.identify)["lateral"]
    spec = ModelSpec(np.asarray(nominal.model.to_array(), float))
    train = _time_pairs([rec], "lateral", settings.identify)
    (obj,) = nonlinear_objectives(spec, train, ["rate_limit"])
    _k, tau, m, ws, zs = (abs(float(v)) for v in spec.params)
    x = jnp.asarray(np.log([2.0, ws, zs, tau, m]))
    xs = x + 1e-3 * jnp.arange(11.0)[:, None]

    f = lambda o, v: o.gain_and_mse(v)[1]  # noqa: E731
    one = eqx.filter_jit(f)
    batch = eqx.filter_jit(lambda o, vs: jax.vmap(lambda v: f(o, v))(vs))
    fwd = eqx.filter_jit(lambda o, v: (f(o, v), jax.jacfwd(lambda w: f(o, w))(v)))
    rev = eqx.filter_jit(jax.value_and_grad(f, argnums=1))
    calls = {
        "one evaluation": lambda: one(obj, x),
        "vmap of 11 evaluations": lambda: batch(obj, xs),
        "value and gradient, central differences (the polish's)": lambda: _nl_value_and_grad(obj, x),
        "value and gradient, jax.jacfwd": lambda: fwd(obj, x),
        "value and gradient, jax.grad (reverse mode)": lambda: rev(obj, x),
    }
    compile_s = {}
    for name, call in calls.items():
        t0 = time.perf_counter()
        jax.block_until_ready(call())
        compile_s[name] = time.perf_counter() - t0
    times = {name: [] for name in calls}
    for _ in range(args.repeats):  # interleaved, so that load hits every row alike
        for name, call in calls.items():
            t0 = time.perf_counter()
            jax.block_until_ready(call())
            times[name].append(time.perf_counter() - t0)
    med = {name: statistics.median(v) for name, v in times.items()}
    g_fd = np.asarray(_nl_value_and_grad(obj, x)[1])
    g_fwd = np.asarray(fwd(obj, x)[1])
    g_rev = np.asarray(rev(obj, x)[1])
    scale = float(np.max(np.abs(g_fwd)))
    dev_fd = float(np.max(np.abs(g_fd - g_fwd))) / scale
    dev_rev = float(np.max(np.abs(g_rev - g_fwd))) / scale

    names = ["rate_limit", "backlash", "saturation"]
    kw = dict(wolves=settings.nonlinear_wolves, iterations=settings.nonlinear_iterations, include_null=True)
    t0 = time.perf_counter()
    fit_nonlinear_candidates(spec, train, names, jax.random.key(0), **kw)
    warm = time.perf_counter() - t0
    t0 = time.perf_counter()
    fits = fit_nonlinear_candidates(spec, train, names, jax.random.key(0), **kw)
    whole = time.perf_counter() - t0
    load1 = os.getloadavg()

    ref = med["one evaluation"]
    L = ["# Nonlinear refit cost", "",
         f"`python benchmarks/nonlinear_refit.py {' '.join(sys.argv[1:])}`".replace(" `", "`"), "",
         f"{cpu_model()} ({platform.machine()}, {len(os.sched_getaffinity(0))} cores used), JAX {jax.__version__}, "
         f"float64, jaxgwo {getattr(jaxgwo, '__version__', '?')}; load average {load0[0]:.2f} at the start, "
         f"{load1[0]:.2f} at the end.", "",
         f"Embedded dataset, lateral identification record ({int(np.sum(np.asarray(obj.mask)))} samples at "
         f"{1.0 / obj.dt:g} Hz), rate-limit output error at rate 2 rad/s on the nominal servo and rotor term; "
         f"medians of {args.repeats} interleaved repeats after compilation.", "",
         "| call | median ms | x one evaluation | first call (compile) s |", "|---|---|---|---|"]  # fmt: skip
    for name in calls:
        L.append(f"| {name} | {1e3 * med[name]:.1f} | {med[name] / ref:.1f} | {compile_s[name]:.1f} |")
    L += ["",
          f"Largest gradient difference, relative to the largest jax.jacfwd component: central differences "
          f"{dev_fd:.1e}, reverse mode {dev_rev:.1e}.", "",
          f"One `fit_nonlinear_candidates` call (rate limit, backlash, saturation and the null refit; "
          f"{settings.nonlinear_wolves} wolves, {settings.nonlinear_iterations} iterations): {whole:.1f} s "
          f"({warm:.1f} s for the first call, compilation included); null refit error "
          f"{fits[-1].train_mse:.4g}, best candidate's "
          f"{min(f.train_mse for f in fits[:-1]):.4g}.", ""]  # fmt: skip
    os.makedirs(args.out, exist_ok=True)
    atomic_write_text(os.path.join(args.out, "nonlinear_refit.md"), "\n".join(L))
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    sys.exit(main())
