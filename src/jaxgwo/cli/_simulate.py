"""``jaxgwo simulate``: fly the simulator and write a flight record (or the default dataset)."""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
from pathlib import Path

DESCRIPTION = """\
Simulate a small helicopter flight test and write a flight record (CSV or NPZ).

The excitation goes on the --channel cyclic(s) (both: lateral first, then longitudinal);
the other cyclic carries small pilot-like corrections.  On the R-50 a weak pilot-like
attitude/velocity hold keeps it near hover, and the logged cyclics are the totals.
Effects: time_delay[delay_s] sensor_lag[cutoff_hz] rotor_flapping[tau_f]
cross_coupling[gain] structural_mode[freq_hz,zeta_p,zeta_z] rate_limit[rate]
backlash[width] saturation[limit]; add axis=lateral|longitudinal to restrict one.

Examples:
  jaxgwo simulate --plant r50 --channel lateral --excitation sweep --seed 1 --out lat.csv
  jaxgwo simulate --plant paper --effect time_delay:delay_s=0.04 --effect sensor_lag:cutoff_hz=8 --out d.csv
  jaxgwo simulate --default-dataset src/jaxgwo/data     # regenerate the embedded dataset
"""

EXCITATIONS = ("sweep", "chirp", "doublet", "3211", "multisine")
DEFAULT_DURATION = {"sweep": 90.0, "chirp": 60.0, "doublet": 10.0, "3211": 12.0, "multisine": 60.0}


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "simulate",
        help="simulate a helicopter flight test and write a flight record",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--plant", choices=("paper", "r50"), default="r50", help="plant model (default: r50)")
    p.add_argument("--channel", choices=("lateral", "longitudinal", "both"), default="lateral",
                   help="cyclic(s) to excite (default: lateral)")
    p.add_argument("--excitation", choices=EXCITATIONS, default="sweep", help="input signal (default: sweep)")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:param=value,...]",
                   help="unmodelled effect to add; repeatable")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="PRNG seed (default 0; default dataset: 50)")
    p.add_argument("--out", metavar="FILE", help="output flight record, .csv or .npz")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="excitation length per channel in seconds (default: sweep 90, chirp 60, "
                        "doublet 10, 3211 12, multisine 60)")
    p.add_argument("--sample-rate", type=float, default=100.0, metavar="HZ", help="logging rate (default 100)")
    p.add_argument("--amplitude", type=float, default=0.1, metavar="A",
                   help="excitation amplitude, normalised cyclic (default 0.1)")
    p.add_argument("--f-start", type=float, default=0.25, metavar="HZ",
                   help="sweep/chirp/multisine start frequency (default 0.25 Hz)")
    p.add_argument("--f-stop", type=float, default=12.0, metavar="HZ",
                   help="sweep/chirp/multisine stop frequency (default 12 Hz)")
    p.add_argument("--gust-rms", type=float, default=1.0, metavar="RAD_S2",
                   help="gust moment rms on roll; pitch gets 0.4 of it (default 1.0 rad/s^2)")
    p.add_argument("--gust-time-constant", type=float, default=1.5, metavar="S", help="Dryden L/V (default 1.5 s)")
    p.add_argument("--snr-db", type=float, default=math.inf, metavar="DB",
                   help="rate signal-to-noise ratio in dB (default: no SNR-based noise)")
    p.add_argument("--noise-std", type=float, default=0.002, metavar="RAD_S",
                   help="absolute white gyro noise (default 0.002 rad/s)")
    p.add_argument("--off-axis-rms", type=float, default=0.01, metavar="A",
                   help="rms of the pilot-like corrections on the other cyclic, normalised "
                        "(default 0.01)")
    p.add_argument("--hold", choices=("auto", "on", "off"), default="auto",
                   help="pilot hold loop (auto: on for r50, off for paper)")
    p.add_argument("--truth", action="store_true", help="also write p_true, q_true, exc_*, servo_* columns")
    p.add_argument("--attitude", action="store_true",
                   help="also log the estimated attitude phi, theta (rad; the raw gyro integrated, which "
                        "diagnose reads the gyro filter against)")
    p.add_argument("--default-dataset", metavar="DIR",
                   help="write the embedded default dataset (an identification and a "
                        "validation CSV per channel) into DIR instead")
    p.set_defaults(func=run)
    return p


def _check(args) -> None:
    if args.default_dataset is None and not args.out:
        raise ValueError("--out FILE is required (or use --default-dataset DIR)")
    if args.out:
        out = Path(args.out)
        if out.suffix.lower() not in (".csv", ".npz"):
            raise ValueError(f"--out must end in .csv or .npz, got {out.name!r}")
        if not out.parent.resolve().is_dir():
            raise ValueError(f"--out directory does not exist: {out.parent}")
    positive = {"--sample-rate": args.sample_rate, "--amplitude": args.amplitude, "--f-start": args.f_start,
                "--f-stop": args.f_stop, "--gust-time-constant": args.gust_time_constant}
    for name, value in positive.items():
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value:g}")
    for name, value in {"--gust-rms": args.gust_rms, "--noise-std": args.noise_std,
                        "--off-axis-rms": args.off_axis_rms}.items():
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be >= 0, got {value:g}")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise ValueError(f"--duration must be positive, got {args.duration:g}")
    if not args.f_start < args.f_stop <= args.sample_rate / 2:
        raise ValueError(f"need --f-start < --f-stop <= Nyquist ({args.sample_rate / 2:g} Hz)")


def _excitation(kind, key, t, args, duration, start):
    from jaxgwo import _signals as sig

    if kind == "sweep":
        return sig.frequency_sweep(t, f_start_hz=args.f_start, f_stop_hz=args.f_stop, duration_s=duration,
                                   amplitude=args.amplitude, start_s=start), f"sweep {args.f_start:g}-{args.f_stop:g} Hz"
    if kind == "chirp":
        return sig.sid_chirp(t, f_start_hz=args.f_start, f_stop_hz=args.f_stop, t_rec_s=duration,
                             magnitude=args.amplitude, t_fade_in_s=min(5.0, 0.1 * duration),
                             t_fade_out_s=min(2.0, 0.05 * duration), start_s=start), (
            f"ArduPilot SID chirp SID_F_START_HZ={args.f_start:g} SID_F_STOP_HZ={args.f_stop:g} SID_T_REC={duration:g}")
    if kind == "doublet":
        return sig.doublet(t, amplitude=args.amplitude, pulse_s=0.5, start_s=start + 1.0), "doublet, 0.5 s pulses"
    if kind == "3211":
        return sig.multistep_3211(t, amplitude=args.amplitude, unit_s=0.4, start_s=start + 1.0), "3-2-1-1, 0.4 s unit"
    period = 20.0
    ms = sig.odd_multisine(key, period_s=period, sample_rate_hz=args.sample_rate, f_min_hz=args.f_start,
                           f_max_hz=args.f_stop, amplitude=args.amplitude)
    import jax.numpy as jnp

    inside = (t >= start) & (t < start + duration)
    return jnp.where(inside, ms(t - start), 0.0), (
        f"random-odd multisine, period {period:g} s, detection lines at "
        f"{', '.join(f'{f:g}' for f in ms.detection_frequencies_hz[:8])} ... Hz")


def _write_default_dataset(directory: str, seed: int) -> int:
    import jax

    from jaxgwo._data import DEFAULT_DATASET_FILES, save_record
    from jaxgwo._simulate import default_dataset_records

    d = Path(directory)
    if not d.is_dir():
        raise ValueError(f"--default-dataset directory does not exist: {d}")
    records = default_dataset_records(jax.random.key(seed))
    for name, rec in records.items():
        path = save_record(rec, d / DEFAULT_DATASET_FILES[name])
        print(f"wrote {path} ({rec.n_samples} samples, {rec.duration:.1f} s)")
    return 0


def run(args) -> int:
    _check(args)
    from jaxgwo._simulate import DEFAULT_DATASET_SEED

    if args.default_dataset is not None:
        return _write_default_dataset(args.default_dataset, DEFAULT_DATASET_SEED if args.seed is None else args.seed)

    import jax
    import jax.numpy as jnp

    from jaxgwo._data import save_record
    from jaxgwo._effects import effects_from_strings
    from jaxgwo._plants import PaperPlant, R50Plant
    from jaxgwo._signals import pilot_corrections
    from jaxgwo._simulate import Disturbance, HoldLoop, simulate

    effects = effects_from_strings(args.effect)  # validates before any work
    max_delay = float(max(effects.time_delay.delay_s))
    if max_delay > 0.25:
        raise ValueError(f"time_delay delay_s {max_delay:g} s is longer than the simulator's 0.25 s buffer")
    max_mode = float(max(effects.structural_mode.freq_hz))
    if max_mode > 150.0:  # the 1 ms RK4 step resolves modes up to ~159 Hz
        raise ValueError(f"structural_mode freq_hz {max_mode:g} is above the simulator's 150 Hz limit")
    seed = 0 if args.seed is None else args.seed
    plant = R50Plant.default() if args.plant == "r50" else PaperPlant.default()
    hold_on = args.hold == "on" or (args.hold == "auto" and args.plant == "r50")
    duration = DEFAULT_DURATION[args.excitation] if args.duration is None else args.duration
    fs = args.sample_rate
    axes = {"lateral": (0,), "longitudinal": (1,), "both": (0, 1)}[args.channel]
    pad = 3.0
    starts = [pad + i * (duration + 5.0) for i in range(len(axes))]
    total = starts[-1] + duration + pad
    n = int(round(total * fs))
    t = jnp.arange(n, dtype=jnp.float64) / fs
    key = jax.random.key(seed)
    k_exc, k_off, k_sim = jax.random.split(key, 3)
    columns = [jnp.zeros(n), jnp.zeros(n)]
    meta = {}
    for i, (axis, start) in enumerate(zip(axes, starts), start=1):
        signal, what = _excitation(args.excitation, jax.random.fold_in(k_exc, axis), t, args, duration, start)
        columns[axis] = columns[axis] + signal
        cyclic = ("delta_lat", "delta_lon")[axis]
        meta[f"segment_{i}"] = f"{start:g}-{start + duration:g} s: {what} on {cyclic}, amplitude {args.amplitude:g}"
    for axis in range(2):
        if axis not in axes and args.off_axis_rms > 0:
            columns[axis] = columns[axis] + pilot_corrections(jax.random.fold_in(k_off, axis), n, fs, rms=args.off_axis_rms)
    dist = Disturbance(gust_rms=(args.gust_rms, 0.4 * args.gust_rms), gust_time_constant_s=args.gust_time_constant,
                       snr_db=args.snr_db, noise_std=args.noise_std)
    res = simulate(plant, jnp.stack(columns, axis=1), k_sim, sample_rate_hz=fs, effects=effects,
                   disturbance=dist, hold=HoldLoop.r50() if hold_on else None)
    if not bool(jnp.all(jnp.isfinite(res.rate))):
        raise ValueError("the simulation diverged (non-finite rates); check the effects and --hold")
    meta |= {
        "command": "jaxgwo " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv else "jaxgwo simulate",
        "plant": args.plant, "channel": args.channel, "excitation": args.excitation, "seed": seed,
        "effects": effects.describe(), "hold_loop": "on" if hold_on else "off",
        "turbulence": f"Dryden-like gust {args.gust_rms:g} (roll), {0.4 * args.gust_rms:g} (pitch) rad/s^2 rms, "
                      f"T {args.gust_time_constant:g} s",
        "noise": f"white gyro noise {args.noise_std:g} rad/s rms, snr_db {args.snr_db:g}",
    }  # fmt: skip
    path = save_record(res.to_record(meta, truth=args.truth, attitude=args.attitude), args.out)
    print(f"wrote {os.fspath(path)} ({n} samples at {fs:g} Hz; effects: {effects.describe()})")
    return 0
