#!/usr/bin/env python3
"""The coupling's fidelity against ωn·h (issue 20, item 1; docs/coupling.md).

For ωn·h in OMEGA_H (ωn = 889.8 rad/s, the Tsui rotor alone; h = ωn·h/ωn) and for both
`coupling`s, runs build/mjstepper on temporary copies of models/tsui_rigid.xml with the timestep
changed and measures:

  - H3, the rotor's free ring: `ideal_current` drive, detent off, the joint's frictionloss set to 0,
    `input=position` with ctrl 0 and a keyframe putting the rotor at +2 mrad (the drive starts at
    rest at θcmd = 0: the set-up of tests/plugin/coupling_test.cc, which moves qpos after the drive
    has started at 0), sampled after every step up to the first at or past 0.2 s as the test samples
    (the run's log has the state at the start of each step). The frequency is 1/(the mean spacing
    of the upward crossings of the mean); ζ = ln(A1/A2)/(0.1 s·2π·f) from the amplitudes of a tone
    of that frequency least-squares fitted to 0.02-0.07 s and 0.12-0.17 s. Errors against the same
    at 1 µs (consistent coupling). As a cross-check of that ζ (whose two windows each decay by half,
    so their fitted amplitudes depend on where the oscillation's phase falls in them), ζ = σ/(2π·f)
    from e^(−σt)·(c1·cos 2πft + c2·sin 2πft) + c0 least-squares fitted to all of 0.02-0.17 s.
  - The RMS velocity ripple through the Tsui sweep (the model as shipped, only h changed):
    `sweep --speeds 20:200:20rpm --settle 0.3 --measure 0.6`, its relative error at each speed
    against the same sweep (same coupling) at 10 µs; the largest in magnitude over the 10 speeds,
    with its sign.

Writes renders/coupling/fidelity.csv and fidelity.png (each through a temporary renamed into
place) and prints, per error and coupling, the largest ωn·h up to which every point is within 1 %.
One simulation at a time, one thread. Run from the repository: .venv/bin/python
src/tools/python/coupling_curves.py
"""
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")
MODEL = os.path.join(ROOT, "models", "tsui_rigid.xml")
OUT = os.path.join(ROOT, "renders", "coupling")

OMEGA_N = 889.8                       # rad/s, √(T'/J) = √(28.5/0.36e-4)
OMEGA_H = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.25, 1.5]
COUPLINGS = ["consistent", "explicit"]
LIMIT = 1.0                           # %

RING_REFERENCE_H = 1e-6               # s
RING_DURATION = 0.2                   # s
RING_OFFSET = 0.002                   # rad
RING_WINDOWS = [(0.02, 0.07), (0.12, 0.17)]  # s
RING_DECAY_WINDOW = (0.02, 0.17)      # s
RING_SETS = ["shaft.drive=ideal_current", "shaft.detent=none", "shaft.input=position"]

SWEEP_REFERENCE_H = 1e-5              # s
SWEEP_ARGS = ["--speeds", "20:200:20rpm", "--settle", "0.3", "--measure", "0.6"]

# The three errors (one panel each), then the cross-check of ζ (a column, and dotted in ζ's panel).
ERRORS = [("ring_frequency_error_pct", "ring frequency (H3)"),
          ("damping_ratio_error_pct", "ring damping ratio ζ (H3)"),
          ("ripple_largest_error_pct", "sweep RMS velocity ripple, largest over 10 speeds")]
CROSS_CHECK = ("damping_ratio_error_decay_fit_pct", "ring ζ, decaying-tone fit (cross-check)")


def model_text(h, ring):
    with open(MODEL, encoding="utf-8") as f:
        xml = f.read()
    xml, n = re.subn(r'timestep="[^"]*"', f'timestep="{h!r}"', xml, count=1)
    assert n == 1, "no timestep in the model"
    if ring:
        xml, n = re.subn(r'frictionloss="[^"]*"', 'frictionloss="0"', xml)
        assert n == 1, "expected one frictionloss"
        key = f'  <keyframe><key name="offset" qpos="{RING_OFFSET!r}"/></keyframe>\n</mujoco>'
        xml = xml.replace("</mujoco>", key)
    return xml


def simulate(args, tmp, label):
    """Runs mjstepper; returns True when it succeeded. Reports failures and MuJoCo warnings."""
    proc = subprocess.run([CLI] + args, cwd=tmp, capture_output=True, text=True)
    # The coarse-timestep warning --allow-coarse lets through is expected; anything else is shown.
    expected = ("is too coarse for", "  mode ", "  use timestep")
    notes = [line for line in proc.stderr.splitlines()
             if line.strip() and not any(e in line for e in expected)]
    for line in notes:
        print(f"  {label}: {line}", file=sys.stderr)
    if proc.returncode != 0:
        print(f"  {label}: mjstepper exited with {proc.returncode}", file=sys.stderr)
    return proc.returncode == 0


def crossing_frequency(t, x):
    """Hz: the number of periods between the first and last upward crossing of the mean."""
    a, b = x[:-1] - x.mean(), x[1:] - x.mean()
    up = (a < 0) & (b >= 0)
    times = t[:-1][up] + (t[1:] - t[:-1])[up] * (-a[up]) / (b[up] - a[up])
    if len(times) < 2:
        return math.nan
    return (len(times) - 1) / (times[-1] - times[0])


def tone_amplitude(t, x, frequency):
    """Amplitude of c0 + c1·cos(2πft) + c2·sin(2πft) least-squares fitted to x."""
    w = 2 * math.pi * frequency
    basis = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
    c = np.linalg.lstsq(basis, x, rcond=None)[0]
    return math.hypot(c[1], c[2])


def decay_rate(t, x, frequency):
    """1/s: σ of e^(−σt)·(c1·cos 2πft + c2·sin 2πft) + c0 least-squares fitted to x (golden-section
    search on σ in [0, 1000] 1/s, the c's linear at each σ)."""
    w, t = 2 * math.pi * frequency, t - t[0]

    def residual(sigma):
        e = np.exp(-sigma * t)
        basis = np.column_stack([np.ones_like(t), e * np.cos(w * t), e * np.sin(w * t)])
        c = np.linalg.lstsq(basis, x, rcond=None)[0]
        return float(np.sum((basis @ c - x) ** 2))

    ratio = (math.sqrt(5) - 1) / 2
    lo, hi = 0.0, 1000.0
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    ra, rb = residual(a), residual(b)
    while hi - lo > 1e-7:
        if ra < rb:
            hi, b, rb = b, a, ra
            a = hi - ratio * (hi - lo)
            ra = residual(a)
        else:
            lo, a, ra = a, b, rb
            b = lo + ratio * (hi - lo)
            rb = residual(b)
    return (lo + hi) / 2


def ring(h, coupling, tmp):
    """(frequency in Hz, ζ, ζ from the decaying-tone fit) of the released rotor, or NaNs when the
    run fails."""
    model = os.path.join(tmp, "ring.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(model_text(h, ring=True))
    log = os.path.join(tmp, "ring.csv")
    steps = math.ceil(RING_DURATION / h - 1e-9)  # the test steps while time < 0.2 s
    ok = simulate(["run", model, "--duration", repr((steps + 1) * h),
                   "--ctrl", "shaft=constant(0rad)", "--keyframe", "offset",
                   "--set", f"shaft.coupling={coupling}"]
                  + [a for s in RING_SETS for a in ("--set", s)]
                  + ["--log", log, "--allow-coarse", "--quiet"], tmp, f"ring h={h:.4g} {coupling}")
    if not ok:
        return math.nan, math.nan, math.nan
    with open(log, encoding="utf-8") as f:
        header = f.readline().rstrip("\n").split(",")
        assert header[0] == "time[s]" and header[1] == "shaft:theta[rad]", header[:2]
        data = np.array([line.split(",", 2)[:2] for line in f], dtype=float)
    t, q = data[1:, 0], data[1:, 1]  # row k is the state at k·h: the test's samples are 1..steps
    assert len(t) == steps and t[-1] >= RING_DURATION - 1e-12, (len(t), steps, t[-1])
    if not np.all(np.isfinite(q)):
        return math.nan, math.nan, math.nan
    f = crossing_frequency(t, q)
    amplitudes = []
    for start, end in RING_WINDOWS:
        inside = (t >= start) & (t < end)
        amplitudes.append(tone_amplitude(t[inside], q[inside], f))
    decay = math.log(amplitudes[0] / amplitudes[1]) / (RING_WINDOWS[1][0] - RING_WINDOWS[0][0])
    inside = (t >= RING_DECAY_WINDOW[0]) & (t < RING_DECAY_WINDOW[1])
    sigma = decay_rate(t[inside], q[inside], f)
    return f, decay / (2 * math.pi * f), sigma / (2 * math.pi * f)


def sweep(h, coupling, tmp):
    """{speed in r/min: RMS velocity error in r/min}, or None when the sweep fails."""
    model = os.path.join(tmp, "sweep.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(model_text(h, ring=False))
    prefix = os.path.join(tmp, "sweep")
    ok = simulate(["sweep", model] + SWEEP_ARGS
                  + ["--set", f"shaft.coupling={coupling}", "--out", prefix, "--threads", "1",
                     "--quiet"], tmp, f"sweep h={h:.4g} {coupling}")
    if not ok:
        return None
    with open(prefix + ".csv", encoding="utf-8") as f:
        header = f.readline().rstrip("\n").split(",")
        speed, rms = header.index("speed[r/min]"), header.index("velocity_error_rms[r/min]")
        lost = header.index("lost_steps[full steps]")
        rows = [[float(v) for v in line.split(",")] for line in f]
    for r in rows:
        if r[lost] != 0:
            print(f"  sweep h={h:.4g} {coupling}: {r[lost]:+.0f} full steps lost at "
                  f"{r[speed]:.0f} r/min", file=sys.stderr)
    return {round(r[speed], 6): r[rms] for r in rows}


def largest_error(coarse, reference):
    """(signed % error at the speed where it is largest in magnitude, that speed)."""
    if coarse is None or set(coarse) != set(reference):
        return math.nan, math.nan
    errors = {s: 100 * (coarse[s] / reference[s] - 1) for s in reference}
    worst = max(errors, key=lambda s: abs(errors[s]) if math.isfinite(errors[s]) else math.inf)
    return errors[worst], worst


def within_limit(results, coupling, key):
    """Largest ωn·h up to which every point is within LIMIT, and the larger ones back within it."""
    ok = [math.isfinite(e) and abs(e) <= LIMIT
          for e in (results[(wh, coupling)][key] for wh in OMEGA_H)]
    first_fail = ok.index(False) if False in ok else len(ok)
    passed = OMEGA_H[first_fail - 1] if first_fail > 0 else None
    return passed, [wh for wh, good in zip(OMEGA_H[first_fail:], ok[first_fail:]) if good]


def write_csv(results, path):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        columns = [k for k, _ in ERRORS + [CROSS_CHECK]]
        f.write("omega_h[—],coupling[—]," + ",".join(f"{k}[%]" for k in columns) + "\n")
        for coupling in COUPLINGS:
            for wh in OMEGA_H:
                r = results[(wh, coupling)]
                f.write(f"{wh},{coupling}," + ",".join(f"{r[k]:.4f}" for k in columns) + "\n")
    os.replace(tmp, path)


def plot(results, path):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharex=True)
    floor = 1e-3  # %: where a zero error is drawn on the log scale
    x = np.array(OMEGA_H)
    for ax, (key, title) in zip(axes, ERRORS):
        for coupling, colour in zip(COUPLINGS, ["tab:blue", "tab:red"]):
            e = np.array([results[(wh, coupling)][key] for wh in OMEGA_H])
            ax.plot(x, np.maximum(np.abs(e), floor), "-", color=colour, label=coupling)
            for sign, face in [(e >= 0, colour), (e < 0, "white")]:
                ax.plot(x[sign], np.maximum(np.abs(e[sign]), floor), "o", color=colour,
                        markerfacecolor=face)
            if key == "damping_ratio_error_pct":
                e = np.array([results[(wh, coupling)][CROSS_CHECK[0]] for wh in OMEGA_H])
                ax.plot(x, np.maximum(np.abs(e), floor), ":", color=colour, marker="x",
                        label=f"{coupling}, decaying-tone fit")
        ax.axhline(LIMIT, color="k", linestyle="--", linewidth=1, label="1 %")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ticks = [w for w in OMEGA_H if w != 1.25]  # 1.25 and 1.5 would overlap on the log scale
        ax.set_xticks(ticks)
        ax.set_xticklabels([f"{w:g}" for w in ticks], fontsize=8)
        ax.minorticks_off()
        ax.set_xlabel("ωn·h (ωn = 889.8 rad/s)")
        ax.set_ylabel("|error| (%)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, title="filled: > 0, open: < 0", title_fontsize=7)
    fig.suptitle("models/tsui_rigid.xml: error against ωn·h (references: ring 1 µs, sweep 10 µs)")
    fig.tight_layout()
    tmp = path + ".tmp"
    fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def main():
    start = time.monotonic()
    os.makedirs(OUT, exist_ok=True)
    results = {}
    with tempfile.TemporaryDirectory(prefix="coupling_curves_") as tmp:
        f_ref, zeta_ref, fit_ref = ring(RING_REFERENCE_H, "consistent", tmp)
        print(f"ring reference (1 us, consistent): {f_ref:.3f} Hz, zeta {zeta_ref:.6f} "
              f"(decaying-tone fit {fit_ref:.6f})")
        sweep_ref = {}
        for coupling in COUPLINGS:
            sweep_ref[coupling] = sweep(SWEEP_REFERENCE_H, coupling, tmp)
            if sweep_ref[coupling] is None:
                sys.exit(f"the 10 us sweep ({coupling}) failed")
        gap = max(abs(sweep_ref["explicit"][s] / sweep_ref["consistent"][s] - 1)
                  for s in sweep_ref["consistent"])
        print(f"sweep references (10 us): the two couplings' RMS ripple differ by at most "
              f"{100 * gap:.3f} %")
        for coupling in COUPLINGS:
            for wh in OMEGA_H:
                h = wh / OMEGA_N
                f, zeta, fit = ring(h, coupling, tmp)
                ripple, at = largest_error(sweep(h, coupling, tmp), sweep_ref[coupling])
                r = results[(wh, coupling)] = {
                    "ring_frequency_error_pct": 100 * (f / f_ref - 1),
                    "damping_ratio_error_pct": 100 * (zeta / zeta_ref - 1),
                    "damping_ratio_error_decay_fit_pct": 100 * (fit / fit_ref - 1),
                    "ripple_largest_error_pct": ripple}
                print(f"wn*h {wh:4g} (h {1e6 * h:7.2f} us) {coupling:10s}: ring {f:8.3f} Hz "
                      f"({r['ring_frequency_error_pct']:+7.3f} %), zeta {zeta:.6f} "
                      f"({r['damping_ratio_error_pct']:+7.2f} %; fit "
                      f"{r['damping_ratio_error_decay_fit_pct']:+7.2f} %); ripple {ripple:+7.2f} % "
                      f"at {at:g} r/min", flush=True)
    write_csv(results, os.path.join(OUT, "fidelity.csv"))
    plot(results, os.path.join(OUT, "fidelity.png"))
    print(f"largest wn*h with every point up to it within {LIMIT:g} %:")
    for key, title in ERRORS + [CROSS_CHECK]:
        for coupling in COUPLINGS:
            passed, again = within_limit(results, coupling, key)
            extra = f" (within it again at {', '.join(f'{w:g}' for w in again)})" if again else ""
            if passed is not None and passed != OMEGA_H[-1]:
                w0, w1 = passed, OMEGA_H[OMEGA_H.index(passed) + 1]
                e0, e1 = (abs(results[(w, coupling)][key]) for w in (w0, w1))
                if math.isfinite(e1):
                    crossing = w0 + (w1 - w0) * (LIMIT - e0) / (e1 - e0)
                    extra = f" (1 % crossed near {crossing:.2f}, linearly interpolated)" + extra
            print(f"  {title}, {coupling}: {passed if passed is not None else 'none'}{extra}")
    for coupling in COUPLINGS:
        all_ok = [wh for wh in OMEGA_H
                  if all(abs(results[(w, coupling)][k]) <= LIMIT
                         for w in OMEGA_H if w <= wh for k, _ in ERRORS)]
        print(f"  all three ({', '.join(k for k, _ in ERRORS)}), {coupling}: "
              f"{max(all_ok) if all_ok else 'none'}")
    print(f"wrote {os.path.relpath(OUT, ROOT)}/fidelity.csv and fidelity.png in "
          f"{time.monotonic() - start:.0f} s")


if __name__ == "__main__":
    main()
