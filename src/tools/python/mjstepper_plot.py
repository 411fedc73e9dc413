#!/usr/bin/env python3
"""Plots of the CSVs mjstepper writes (matplotlib, headless Agg backend).

  mjstepper_plot.py log RUN.csv --out RUN.png          runner log: speed, velocity error, currents,
                                                       load angle of every stepper against time
  mjstepper_plot.py log RUN.csv --versus speed --out E.png
                                                       every stepper's velocity error against its
                                                       commanded speed
  mjstepper_plot.py sweep A.csv [B.csv ...] --labels "no damping" "all damped" --out SWEEP.png
                                                       sweeps: velocity-error ripple against speed
  mjstepper_plot.py resonance PREFIX_psd.csv --out PREFIX.png
                                                       a resonance test's PSDs and shapers
  mjstepper_plot.py size P_J_demand.csv P_J_pullout.csv --out P_J.png
                                                       a sized joint: demand against pull-out

The PNG is written to OUT.tmp.png and renamed, so it is never half-written.
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

RPM = 60.0 / (2.0 * math.pi)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    # (An empty cell, as under Klipper's `shapers:` column, reads as NaN.)
    columns = {name: [float(r[i]) if r[i] else math.nan for r in data]
               for i, name in enumerate(header)}
    return header, columns


def save(fig, out):
    if out.startswith("/dev/fd/"):
        # The mjstepper command's own temporary, made exclusively and renamed by it (plot.cc).
        fig.savefig(out, dpi=110, format="png")
        return
    tmp = out + ".tmp.png"
    try:
        os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
        fig.savefig(tmp, dpi=110)
        os.replace(tmp, out)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    finally:
        plt.close(fig)


def column(c, stepper, signal):
    """(values, unit) of `stepper:signal[unit]`: the unit comes from the CSV header, which the
    signal table writes (src/core/signals.cc), not from this file."""
    prefix = f"{stepper}:{signal}["
    for name, values in c.items():
        if name.startswith(prefix):
            return values, name[len(prefix):-1]
    raise KeyError(f"no column {prefix}...] in the log")


def steppers_of(header):
    return [name.split(":")[0] for name in header if name.endswith(":omega[rad/s]")]


def plot_log(path, out, title=None):
    header, c = read_csv(path)
    t = c["time[s]"]
    names = steppers_of(header)
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for name in names:
        omega = [w * RPM for w in c[f"{name}:omega[rad/s]"]]
        omega_cmd = [w * RPM for w in c[f"{name}:omega_cmd[rad/s]"]]
        axes[0].plot(t, omega, lw=0.7, label=f"{name} speed")
        axes[0].plot(t, omega_cmd, lw=1.0, ls="--", label=f"{name} command")
        axes[1].plot(t, [e * RPM for e in c[f"{name}:velocity_error[rad/s]"]], lw=0.6, label=name)
        ia, current_unit = column(c, name, "current_a")
        axes[2].plot(t, ia, lw=0.6, label=f"{name} ia")
        axes[2].plot(t, column(c, name, "current_b")[0], lw=0.6, label=f"{name} ib")
        delta, angle_unit = column(c, name, "load_angle")
        axes[3].plot(t, delta, lw=0.6, label=name)
    axes[0].set_ylabel("speed (r/min)")
    axes[1].set_ylabel("velocity error (r/min)")
    if names:
        axes[2].set_ylabel(f"phase current ({current_unit})")
        axes[3].set_ylabel(f"load angle ({angle_unit})")
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=7)
    fig.suptitle(title or os.path.basename(path))
    fig.tight_layout()
    save(fig, out)


def finish(fig, ax, xlabel, ylabel, title, out):
    """Labels, grid and title of a one-axes figure, then saves it."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.set_title(title)
    fig.tight_layout()
    save(fig, out)


def plot_versus_speed(path, out, title=None):
    """Every stepper's velocity error against its commanded speed, in one axes (ramps)."""
    header, c = read_csv(path)
    fig, ax = plt.subplots(figsize=(9, 4.8))
    for name in steppers_of(header):
        speed = [w * RPM for w in c[f"{name}:omega_cmd[rad/s]"]]
        error = [e * RPM for e in c[f"{name}:velocity_error[rad/s]"]]
        ax.plot(speed, error, lw=0.5, label=name)
    ax.legend(fontsize=8)
    finish(fig, ax, "commanded speed (r/min)", "velocity error (r/min)",
           title or os.path.basename(path), out)


CARRIAGE_SPEED = "carriage_speed[mm/s]"  # a linear axis's sweep, map and pull-out


def at_carriage(c, rpm):
    """Rotor speeds (r/min) of a linear axis's CSV `c` as mm/s at its carriage (the CSV's own
    ratio of carriage_speed[mm/s] to speed[r/min], the axis's one constant)."""
    ratio = next(v / n for v, n in zip(c[CARRIAGE_SPEED], c["speed[r/min]"]) if n != 0)
    return [abs(ratio) * v for v in rpm]


def plot_sweep(paths, labels, out, title=None):
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    linear = True
    for path, label in zip(paths, labels):
        _, c = read_csv(path)
        linear = linear and CARRIAGE_SPEED in c
    for path, label in zip(paths, labels):
        _, c = read_csv(path)
        ripple = c["velocity_error_peak_to_peak[r/min]"]
        n = c[CARRIAGE_SPEED] if linear else c["speed[r/min]"]
        axes[0].plot(n, at_carriage(c, ripple) if linear else ripple, marker=".", lw=1,
                     label=label)
        axes[1].plot(n, c["dominant_frequency[Hz]"], marker=".", lw=0.8, label=label)
    unit = "mm/s at the carriage" if linear else "r/min"
    axes[0].set_ylabel(f"velocity error, peak-to-peak ({unit})")
    axes[1].set_ylabel("dominant frequency (Hz)")
    axes[1].set_xlabel(f"commanded speed ({unit})")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title or "constant-speed sweep")
    fig.tight_layout()
    save(fig, out)


def plot_pullout(path, out, title=None):
    _, c = read_csv(path)
    fig, ax = plt.subplots(figsize=(9, 5))
    linear = CARRIAGE_SPEED in c
    if linear:  # a linear axis: mm/s and N at its carriage
        n, torque = c[CARRIAGE_SPEED], c["pull_out_force[N]"]
    else:
        n, torque = c["speed[r/min]"], c["pull_out_torque[N·m]"]
    ax.plot(n, torque, marker=".", lw=1)
    unloaded = [i for i, flag in enumerate(c["slipped_before_load[1/0]"]) if flag > 0]
    if unloaded:
        ax.plot([n[i] for i in unloaded], [torque[i] for i in unloaded], "rx",
                label="slipped before any load")
        ax.legend(fontsize=8)
    ax.set_ylim(bottom=0)
    finish(fig, ax, "carriage speed (mm/s)" if linear else "speed (r/min)",
           "pull-out force at the carriage (N)" if linear else "pull-out torque (N·m)",
           title or os.path.basename(path), out)


def plot_size(demand_path, pullout_path, out, title=None):
    """A joint of `mjstepper size`: its torque-speed demand along the move (|τ| against |ω|,
    rotor side: the torque the move needs) and what the motor did in the simulated cycle, beside
    its motor's simulated pull-out curve, the worst point marked with its margin."""
    _, d = read_csv(demand_path)
    _, p = read_csv(pullout_path)
    if "carriage_speed[mm/s]" in d:  # a linear axis: mm/s and N at its carriage
        # the rotor's rad/s and N·m per carriage mm/s and N: the CSV's own constant ratios
        k = next(c / w for c, w in zip(d["carriage_speed[mm/s]"], d["speed[rad/s]"]) if w != 0)
        f = next(fo / t for fo, t in zip(d["force[N]"], d["torque[N·m]"]) if t != 0)
        speed_of, torque_of = (lambda w: abs(k * w)), (lambda t: abs(f * t))
        labels = ("carriage speed (mm/s)", "force at the carriage (N)")
        curve = ([abs(v) for v in p["carriage_speed[mm/s]"]], p["pull_out_force[N]"])
    else:
        speed_of, torque_of = (lambda w: abs(w) * RPM), abs
        labels = ("rotor speed (r/min)", "rotor torque (N·m)")
        curve = (p["speed[r/min]"], p["pull_out_torque[N·m]"])
    speed = [speed_of(v) for v in d["speed[rad/s]"]]
    torque = [torque_of(v) for v in d["torque[N·m]"]]
    fig, ax = plt.subplots(figsize=(9, 5))
    ax.plot(curve[0], curve[1], "k.-", lw=1.5, label="pull-out (simulated on the bench)")
    ax.plot([speed_of(v) for v in d["motor_speed[rad/s]"]],
            [torque_of(v) for v in d["motor_torque[N·m]"]], "-", color="tab:blue", lw=0.6,
            alpha=0.5, label="the motor in the simulated cycle, |τm + τdet| (10 ms mean)")
    ax.plot(speed, torque, "-", color="tab:orange", lw=1.0,
            label="demand: the torque the move needs (inverse dynamics)")
    margins = d["margin[1]"]
    k = min(range(len(margins)), key=margins.__getitem__)
    ax.plot([speed[k]], [torque[k]], "o", color="tab:red",
            label=f"worst point: margin {100 * margins[k]:.0f} %")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8, loc="upper right")
    finish(fig, ax, labels[0], labels[1], title or os.path.basename(demand_path), out)


def plot_map(path, out, title=None):
    """Heat map of the velocity ripple over speed (x) and the varied parameter (y); lost steps
    marked."""
    header, c = read_csv(path)
    parameter = header[0]
    values = sorted(set(c[parameter]))
    linear = CARRIAGE_SPEED in c  # a linear axis: speeds and ripple in mm/s at its carriage
    key = CARRIAGE_SPEED if linear else "speed[r/min]"
    ripples = c["velocity_error_peak_to_peak[r/min]"]
    if linear:
        ripples = at_carriage(c, ripples)
    speeds = sorted(set(c[key]))
    grid = [[0.0] * len(speeds) for _ in values]
    lost = []
    for v, n, ripple, steps in zip(c[parameter], c[key], ripples, c["lost_steps[full steps]"]):
        grid[values.index(v)][speeds.index(n)] = ripple
        if steps != 0:
            lost.append((n, v))
    unit = "mm/s at the carriage" if linear else "r/min"
    fig, ax = plt.subplots(figsize=(9, 5))
    mesh = ax.pcolormesh(speeds, values, grid, shading="nearest", cmap="magma")
    fig.colorbar(mesh, ax=ax, label=f"velocity error, peak-to-peak ({unit})")
    if lost:
        ax.plot([n for n, _ in lost], [v for _, v in lost], "c.", ms=4, label="lost steps")
        ax.legend(fontsize=8, loc="upper right")
    finish(fig, ax, f"commanded speed ({unit})", parameter, title or os.path.basename(path), out)


def plot_resonance(path, out, title=None):
    """A resonance test's frequency response (PREFIX_psd.csv of `mjstepper resonance-test`): the
    PSD of each axis and their sum against frequency, and on a second axis each fitted shaper's
    remaining vibration V(f) (the largest over the test damping ratios), as users know the plot."""
    header, c = read_csv(path)
    f = c["freq"]
    fig, ax = plt.subplots(figsize=(10, 6))
    for name, style in (("psd_x", "-"), ("psd_y", "-"), ("psd_z", "-"), ("psd_xyz", "--")):
        ax.plot(f, c[name], style, lw=1, label=name.replace("psd_", "").upper())
    ax.set_ylim(bottom=0)
    ax.ticklabel_format(axis="y", style="scientific", scilimits=(0, 0))
    ax.set_ylabel("PSD over frequency, as Klipper plots it ((mm/s²)²/Hz²)")
    ax.legend(loc="upper left", fontsize=8)
    twin = ax.twinx()
    # Klipper's CSV: the shapers' columns follow the empty `shapers:` one, each NAME(FREQ).
    for key in header[header.index("shapers:") + 1:]:
        twin.plot(f, c[key], ":", lw=1.2, label=key)
    twin.set_ylim(0, 1)
    twin.set_ylabel("shaper vibration reduction (remaining fraction)")
    twin.legend(loc="upper right", fontsize=7)
    finish(fig, ax, "frequency (Hz)", "PSD over frequency, as Klipper plots it ((mm/s²)²/Hz²)",
           title or os.path.basename(path), out)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="kind", required=True)
    log = sub.add_parser("log")
    log.add_argument("csv")
    log.add_argument("--out", required=True)
    log.add_argument("--title")
    log.add_argument("--versus", choices=["time", "speed"], default="time",
                     help="x axis: time (all signals) or commanded speed (velocity errors)")
    sweep = sub.add_parser("sweep")
    sweep.add_argument("csv", nargs="+")
    sweep.add_argument("--labels", nargs="+")
    sweep.add_argument("--out", required=True)
    sweep.add_argument("--title")
    heat = sub.add_parser("map")
    heat.add_argument("csv")
    heat.add_argument("--out", required=True)
    heat.add_argument("--title")
    pullout = sub.add_parser("pullout")
    pullout.add_argument("csv")
    pullout.add_argument("--out", required=True)
    pullout.add_argument("--title")
    size = sub.add_parser("size")
    size.add_argument("csv", nargs=2, help="PREFIX_JOINT_demand.csv PREFIX_JOINT_pullout.csv")
    size.add_argument("--out", required=True)
    size.add_argument("--title")
    resonance = sub.add_parser("resonance")
    resonance.add_argument("csv")
    resonance.add_argument("--out", required=True)
    resonance.add_argument("--title")
    args = parser.parse_args(argv)
    if args.kind == "resonance":
        plot_resonance(args.csv, args.out, args.title)
    elif args.kind == "log" and args.versus == "speed":
        plot_versus_speed(args.csv, args.out, args.title)
    elif args.kind == "log":
        plot_log(args.csv, args.out, args.title)
    elif args.kind == "map":
        plot_map(args.csv, args.out, args.title)
    elif args.kind == "pullout":
        plot_pullout(args.csv, args.out, args.title)
    elif args.kind == "size":
        plot_size(args.csv[0], args.csv[1], args.out, args.title)
    else:
        labels = args.labels or [os.path.basename(p) for p in args.csv]
        if len(labels) != len(args.csv):
            parser.error("give one label per CSV")
        plot_sweep(args.csv, labels, args.out, args.title)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (OSError, ValueError, KeyError, IndexError) as e:
        # A user's error (a path that cannot be written, a CSV that is not ours): one line, no
        # traceback. A bug in this script still shows its traceback.
        what = f"{e.filename}: {e.strerror}" if isinstance(e, OSError) and e.filename else e
        sys.exit(f"mjstepper plot: {type(e).__name__}: {what}")
