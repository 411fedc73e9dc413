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

And, on the same grid of h (fidelity_more.csv and fidelity_more.png):

  - The two-mass modes of models/tsui_coupling.xml (72.2 and 260.0 Hz), as
    tests/plugin/coupling_test.cc measures them: `ideal_current` drive, detent off, the rotor's
    frictionloss set to 0, ctrl 0 (the shipped `input=velocity`), a keyframe putting the rotor at
    0.01 rad/s and the load at 0.01·b rad/s (b = (T' + k − J_r·ω²)/k: the mode's shape, so one
    mode alone), the rotor's angle after every step up to the first at or past 10 of the mode's
    periods, the frequency π·(crossings − 1)/(last − first) from the crossings of zero. Errors
    against the same at 1 µs (consistent coupling). A run MuJoCo resets, or whose ring grows (the
    largest |θ| of the last quarter of the samples above that of the first), is unstable: no error.
  - The lost steps of models/arm3.xml's 2 kg lift (`run --mass payload=2 --duration 2` with the
    ctrl profiles of docs/coupling.md, `--set J.coupling=C` on the three): the count of each joint
    at the end against the same run at 10 µs; the error is whether the three counts equal the
    reference's. The arm's own fastest mode (from `mjstepper info` on a copy with the payload's
    mass and inertia scaled to 2 kg, at qpos0) gives its ω·h beside the grid's.
  - H6 on MuJoCo's side (tests/paper/tsui_plugin_test.cc,
    H6_WorkDeliveredToMuJoCoConvergesAtFirstOrder): the 0.8 s ramp of models/tsui_rigid.xml to
    200 r/min, E_in − E_copper − Δ(L·|i|²/2) − (W_MuJoCo − W_detent) as a fraction of E_in, from
    the signals of the log. W_MuJoCo = Σ τ_k·Δθ_k is the work of the torque handed over; the log
    has not that torque (with the consistent coupling it is not the motor's), so it is taken from
    the rotor's own step, (J + h·B)·(v' − v) = h·(τ + τ_f − B·v), θ' = θ + h·v':
    τ·Δθ = J·(v' − v)·v' + h·B·v'² − τ_f·h·v', with MuJoCo's dry friction τ_f = −Fs·sgn(v')
    (sliding). With the explicit coupling τ_k is the logged torque_total: the script prints how
    far the two differ.

Writes renders/coupling/fidelity.csv and fidelity.png, fidelity_more.csv and fidelity_more.png
(each through a temporary renamed into place) and prints, per error and coupling, the largest ωn·h
up to which every point is within 1 % (for the arm: the counts equal). One simulation at a time,
one thread. Run from the repository: .venv/bin/python src/tools/python/coupling_curves.py
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
from matplotlib import ticker  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")
MODEL = os.path.join(ROOT, "models", "tsui_rigid.xml")
OUT = os.path.join(ROOT, "renders", "coupling")

OMEGA_N = 889.8                       # rad/s, √(T'/J) = √(28.5/0.36e-4)
OMEGA_H = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.25, 1.5, 1.78]  # 1.78: h = 2.0 ms
COUPLINGS = ["consistent", "explicit", "substepped"]
LIMIT = 1.0                           # %

RING_REFERENCE_H = 1e-6               # s
RING_DURATION = 0.2                   # s
RING_OFFSET = 0.002                   # rad
RING_WINDOWS = [(0.02, 0.07), (0.12, 0.17)]  # s
RING_DECAY_WINDOW = (0.02, 0.17)      # s
RING_SETS = ["shaft.drive=ideal_current", "shaft.detent=none", "shaft.input=position"]

SWEEP_REFERENCE_H = 1e-5              # s
SWEEP_ARGS = ["--speeds", "20:200:20rpm", "--settle", "0.3", "--measure", "0.6"]

# The two-mass modes of models/tsui_coupling.xml (tests/plugin/test_model.h, two_mass): rotor J_r,
# load J_l, coupling spring k, the motor's hold T' = Nr·Km·I.
TWO_MASS_MODEL = os.path.join(ROOT, "models", "tsui_coupling.xml")
TWO_MASS = {"rotor": 0.36e-4, "load": 0.72e-4, "coupling": 50.0, "holding": 50 * 0.3 * 1.9}
TWO_MASS_REFERENCE_H = 1e-6           # s
TWO_MASS_SPEED = 0.01                 # rad/s: the rotor's start speed
TWO_MASS_PERIODS = 10
TWO_MASS_SETS = ["shaft.drive=ideal_current", "shaft.detent=none"]

# The arm's 2 kg lift (docs/coupling.md, "Lost steps of models/arm3.xml").
ARM_MODEL = os.path.join(ROOT, "models", "arm3.xml")
ARM_JOINTS = ["base", "shoulder", "elbow"]
ARM_PAYLOAD = ("payload", 2.0)        # body, kg
ARM_ARGS = ["--mass", "payload=2", "--duration", "2", "--ctrl", "base=constant(5rad)",
            "--ctrl", "shoulder=constant(-12rad)", "--ctrl", "elbow=constant(8rad)"]
ARM_REFERENCE_H = 1e-5                # s

# H6 on MuJoCo's side: the Tsui ramp of tests/paper/tsui_plugin_test.cc.
H6_RAMP = 0.8                         # s, to 200 r/min
H6_CTRL = "shaft=ramp(0rpm,200rpm,0.8s)"
H6_CHECK_H = 5e-5                     # s: the model's own step, where the test printed the balance
TSUI_DETENT = [(4, 0.006, 0.0), (2, 0.014, math.pi), (1, 0.011, math.pi / 2)]  # src/core/presets.cc
TSUI_TEETH = 50
TSUI_INDUCTANCE = 2.2e-3              # H
SLIDING = 0.05                        # rad/s: below it the dry friction may not be sliding

# The three errors (one panel each), then the cross-check of ζ (a column, and dotted in ζ's panel).
ERRORS = [("ring_frequency_error_pct", "ring frequency (H3)"),
          ("damping_ratio_error_pct", "ring damping ratio ζ (H3)"),
          ("ripple_largest_error_pct", "sweep RMS velocity ripple, largest over 10 speeds")]
CROSS_CHECK = ("damping_ratio_error_decay_fit_pct", "ring ζ, decaying-tone fit (cross-check)")
# The added errors (fidelity_more.csv and .png); the arm's passes when its counts equal the
# reference's.
MORE_ERRORS = [("slow_mode_error_pct", "two-mass slow mode (72.2 Hz)"),
               ("fast_mode_error_pct", "two-mass fast mode (260.0 Hz)"),
               ("arm_counts_differ", "arm3 lost steps (2 kg): counts equal the 10 µs run's"),
               ("h6_residual_pct", "H6 on MuJoCo's side, the Tsui ramp (% of E_in)")]


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
    ok = simulate(["sweep", model, "--allow-coarse"] + SWEEP_ARGS
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


def two_mass_frequencies():
    """rad/s: the two-mass eigenfrequencies, det(K − ω²·M) = 0 (tests/plugin/test_model.h)."""
    jr, jl, k, t = (TWO_MASS[n] for n in ("rotor", "load", "coupling", "holding"))
    a, b, c = jr * jl, -(jr * k + jl * (t + k)), t * k
    root = math.sqrt(b * b - 4 * a * c)
    return math.sqrt((-b - root) / (2 * a)), math.sqrt((-b + root) / (2 * a))


def zero_crossing_frequency(t, x):
    """rad/s: π·(crossings − 1)/(last − first) from the crossings of 0 (test_model.h)."""
    cross = np.nonzero((x[:-1] > 0) != (x[1:] > 0))[0]
    if len(cross) < 2:
        return math.nan
    times = t[cross] - x[cross] * (t[cross + 1] - t[cross]) / (x[cross + 1] - x[cross])
    return math.pi * (len(times) - 1) / (times[-1] - times[0])


def two_mass_ring(h, coupling, omega, tmp):
    """The mode of ω excited alone: (its frequency in rad/s, '' when measured, else why not:
    'reset' or 'grew')."""
    with open(TWO_MASS_MODEL, encoding="utf-8") as f:
        xml = f.read()
    xml, n = re.subn(r'timestep="[^"]*"', f'timestep="{h!r}"', xml, count=1)
    assert n == 1, "no timestep in the two-mass model"
    xml, n = re.subn(r'frictionloss="[^"]*"', 'frictionloss="0"', xml)
    assert n == 1, "expected one frictionloss (the rotor's)"
    k = TWO_MASS["coupling"]
    shape = (TWO_MASS["holding"] + k - TWO_MASS["rotor"] * omega ** 2) / k  # load/rotor
    speeds = f"{TWO_MASS_SPEED!r} {TWO_MASS_SPEED * (shape - 1)!r}"  # shaft, coupling (the twist)
    xml = xml.replace("</mujoco>", f'  <keyframe><key name="mode" qpos="0 0" qvel="{speeds}"/>'
                      "</keyframe>\n</mujoco>")
    model = os.path.join(tmp, "two_mass.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(xml)
    log = os.path.join(tmp, "two_mass.csv")
    steps = math.ceil(TWO_MASS_PERIODS * 2 * math.pi / omega / h - 1e-9)
    ok = simulate(["run", model, "--duration", repr((steps + 1) * h), "--keyframe", "mode",
                   "--set", f"shaft.coupling={coupling}"]
                  + [a for s in TWO_MASS_SETS for a in ("--set", s)]
                  + ["--log", log, "--allow-coarse", "--quiet"], tmp,
                  f"two-mass {omega / (2 * math.pi):.1f} Hz h={h:.4g} {coupling}")
    if not ok:
        return math.nan, "reset"
    with open(log, encoding="utf-8") as f:
        header = f.readline().rstrip("\n").split(",")
        assert header[0] == "time[s]" and header[1] == "shaft:theta[rad]", header[:2]
        data = np.array([line.split(",", 2)[:2] for line in f], dtype=float)
    t, q = data[1:, 0], data[1:, 1]  # the states after steps 1 … N, as the test samples
    assert len(t) == steps, (len(t), steps)
    quarter = len(q) // 4
    if not np.all(np.isfinite(q)) or np.max(np.abs(q[-quarter:])) > np.max(np.abs(q[:quarter])):
        return math.nan, "grew"
    return zero_crossing_frequency(t, q), ""


def arm_text(h=None):
    """models/arm3.xml with the timestep h, or (h None) with the payload's mass and inertia scaled
    to ARM_PAYLOAD as --mass does (for `info`, which has no --mass)."""
    with open(ARM_MODEL, encoding="utf-8") as f:
        xml = f.read()
    if h is not None:
        xml, n = re.subn(r'timestep="[^"]*"', f'timestep="{h!r}"', xml, count=1)
        assert n == 1, "no timestep in the arm"
        return xml
    body, mass = ARM_PAYLOAD
    pattern = (rf'(<body name="{body}"[^>]*>\s*<inertial [^>]*?)mass="([^"]*)" '
               r'diaginertia="([^"]*)"')
    match = re.search(pattern, xml)
    assert match, "no payload inertial in the arm"
    scale = mass / float(match.group(2))
    inertia = " ".join(repr(scale * float(v)) for v in match.group(3).split())
    return (xml[:match.start()] + f'{match.group(1)}mass="{mass!r}" diaginertia="{inertia}"'
            + xml[match.end():])


def arm_fastest_mode(tmp):
    """rad/s: the arm's fastest mode at qpos0 with the 2 kg payload (`mjstepper info`)."""
    model = os.path.join(tmp, "arm_payload.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(arm_text())
    proc = subprocess.run([CLI, "info", model], cwd=tmp, capture_output=True, text=True)
    modes = [float(f) for f in re.findall(r"^    mode \d+ at ([0-9.]+) Hz:", proc.stdout, re.M)]
    assert proc.returncode == 0 and modes, proc.stdout + proc.stderr
    return 2 * math.pi * max(modes)


def arm_lost_steps(h, coupling, tmp):
    """(base, shoulder, elbow) full steps lost at the end of the lift, or None when it fails."""
    model = os.path.join(tmp, "arm.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(arm_text(h))
    proc = subprocess.run([CLI, "run", model] + ARM_ARGS
                          + [a for j in ARM_JOINTS for a in ("--set", f"{j}.coupling={coupling}")]
                          + ["--allow-coarse", "--quiet"], cwd=tmp, capture_output=True, text=True)
    expected = ("is too coarse for", "  mode ", "  use timestep")
    for line in proc.stderr.splitlines():
        if line.strip() and not any(e in line for e in expected):
            print(f"  arm h={h:.4g} {coupling}: {line}", file=sys.stderr)
    if proc.returncode != 0:
        print(f"  arm h={h:.4g} {coupling}: mjstepper exited with {proc.returncode}",
              file=sys.stderr)
        return None
    names = re.findall(r"^  (\w+): ", proc.stdout, re.M)
    counts = [int(c) for c in re.findall(r"lost steps ([+-]?\d+)", proc.stdout)]
    assert names == ARM_JOINTS and len(counts) == 3, proc.stdout
    return tuple(counts)


def rotor_constants():
    """(J, B, Fs) of models/tsui_rigid.xml's rotor: the armature and the body's inertia about the
    axis, the actuator's damping, the joint's frictionloss."""
    with open(MODEL, encoding="utf-8") as f:
        xml = f.read()
    armature = re.findall(r' armature="([^"]*)"', xml)
    damping = re.findall(r' damping="([^"]*)"', xml)
    friction = re.findall(r' frictionloss="([^"]*)"', xml)
    inertia = re.findall(r' diaginertia="([^"]*)"', xml)
    assert len(armature) == len(damping) == len(friction) == len(inertia) == 1
    return (float(armature[0]) + float(inertia[0].split()[2]), float(damping[0]),
            float(friction[0]))


def h6_balance(h, coupling, tmp):
    """The Tsui ramp's balance E_in − E_copper − ΔE_L − (W_MuJoCo − W_detent) in J, and a dict
    of E_in, W_MuJoCo from the rotor's step, the same from torque_total (the explicit coupling's
    torque), the bound on the dry friction's share where it may not slide, lost steps; or None."""
    model = os.path.join(tmp, "ramp.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(model_text(h, ring=False))
    steps, t = 0, 0.0
    while t < H6_RAMP - 0.5 * h:  # the test's loop: mj_step while time < 0.8 − h/2
        t += h
        steps += 1
    log = os.path.join(tmp, "ramp.csv")
    ok = simulate(["run", model, "--duration", repr((steps + 1) * h), "--ctrl", H6_CTRL,
                   "--set", f"shaft.coupling={coupling}", "--log", log, "--allow-coarse",
                   "--quiet"], tmp, f"ramp h={h:.4g} {coupling}")
    if not ok:
        return None
    with open(log, encoding="utf-8") as f:
        header = f.readline().rstrip("\n").split(",")
        names = ["theta[rad]", "omega[rad/s]", "torque_total[N·m]", "current_a[A]",
                 "current_b[A]", "energy_input[J]", "energy_copper[J]",
                 "lost_steps[full steps]"]
        columns = [header.index("shaft:" + n) for n in names]
        data = np.loadtxt(f, delimiter=",", usecols=columns, ndmin=2)
    assert len(data) == steps + 1, (len(data), steps)  # row N: the state after the N steps
    theta, omega, torque, ia, ib, e_in, e_cu, lost = data.T
    inertia, damping, friction = rotor_constants()
    v0, v1, d_theta = omega[:-1], omega[1:], np.diff(theta)
    # τ + τ_f from the step, times Δθ = h·v', less the dry friction's work −Fs·|Δθ|.
    delivered = float(np.sum((inertia * (v1 - v0) / h + damping * v1) * h * v1)
                      + friction * np.sum(h * np.abs(v1)))
    detent = sum(amplitude / (order * TSUI_TEETH)
                 * (math.cos(order * TSUI_TEETH * theta[-1] + phase)
                    - math.cos(order * TSUI_TEETH * theta[0] + phase))
                 for order, amplitude, phase in TSUI_DETENT)
    stored = 0.5 * TSUI_INDUCTANCE * (ia[-1] ** 2 + ib[-1] ** 2 - ia[0] ** 2 - ib[0] ** 2)
    slow = np.abs(v1) < SLIDING
    info = {"input": e_in[-1], "delivered": delivered,
            "delivered_torque_total": float(np.sum(torque[:-1] * d_theta)),
            "friction_bound": 2 * friction * float(np.sum(h * np.abs(v1[slow]))),
            "lost": lost[-1]}
    return e_in[-1] - e_cu[-1] - stored - (delivered - detent), info


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


def passes(results, wh, coupling, key):
    """Whether the point is within LIMIT (the arm's: its counts equal the reference's)."""
    e = results[(wh, coupling)][key]
    if key == "arm_counts_differ":
        return e == 0
    return math.isfinite(e) and abs(e) <= LIMIT


def write_more_csv(results, path):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("omega_h[—],coupling[—],h[s],slow_mode_omega_h[—],fast_mode_omega_h[—],"
                "slow_mode_error_pct[%],fast_mode_error_pct[%],slow_mode_unstable[—],"
                "fast_mode_unstable[—],arm_omega_h[—],arm_lost_base[full steps],"
                "arm_lost_shoulder[full steps],arm_lost_elbow[full steps],"
                "arm_counts_equal[—],h6_residual_pct[% of E_in]\n")
        for coupling in COUPLINGS:
            for wh in OMEGA_H:
                r = results[(wh, coupling)]
                lost = r["arm_lost"] or (math.nan,) * 3
                f.write(f"{wh},{coupling},{r['h']:.6g},{r['slow_mode_omega_h']:.4f},"
                        f"{r['fast_mode_omega_h']:.4f},{r['slow_mode_error_pct']:.4f},"
                        f"{r['fast_mode_error_pct']:.4f},{r['slow_mode_unstable'] or '—'},"
                        f"{r['fast_mode_unstable'] or '—'},{r['arm_omega_h']:.4f},"
                        + ",".join(f"{c:+.0f}" for c in lost)
                        + f",{int(r['arm_counts_differ'] == 0)},{r['h6_residual_pct']:.5f}\n")
    os.replace(tmp, path)


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
        for coupling, colour in zip(COUPLINGS, ["tab:blue", "tab:red", "tab:green"]):
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
        ticks = [w for w in OMEGA_H if w not in (1.25, 1.78)]  # neighbours overlap on log scale
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


def plot_more(results, references, arm_ratio, path):
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    floor, top = 1e-3, 300.0  # %: where a zero error is drawn; where an unstable point is
    x = np.array(OMEGA_H)
    colours = dict(zip(COUPLINGS, ["tab:blue", "tab:red", "tab:green"]))
    for ax, (key, title) in zip(axes.flat, MORE_ERRORS):
        if key == "arm_counts_differ":
            continue
        for coupling in COUPLINGS:
            colour = colours[coupling]
            e = np.array([results[(wh, coupling)][key] for wh in OMEGA_H])
            fine = np.isfinite(e)
            ax.plot(x[fine], np.maximum(np.abs(e[fine]), floor), "-", color=colour,
                    label=coupling)
            for sign, face in [(fine & (e >= 0), colour), (fine & (e < 0), "white")]:
                ax.plot(x[sign], np.maximum(np.abs(e[sign]), floor), "o", color=colour,
                        markerfacecolor=face)
            if not fine.all():
                shift = {"consistent": 0.97, "explicit": 1.03}.get(coupling, 1.0)  # side by side
                ax.plot(x[~fine] * shift, np.full((~fine).sum(), top), "X", color=colour,
                        markersize=9, label=f"{coupling}: unstable")
        ax.axhline(LIMIT, color="k", linestyle="--", linewidth=1, label="1 %")
        if key == "h6_residual_pct":
            ax.axhline(0.01, color="k", linestyle=":", linewidth=1, label="H6's own 1e-4")
        ax.set_yscale("log")
        ax.set_ylim(floor / 2, top * 3)
        ax.set_ylabel("|error| (%)" if key != "h6_residual_pct" else "|residual| (% of E_in)")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8, title="filled: > 0, open: < 0", title_fontsize=7)
    ax = axes.flat[2]
    markers = dict(zip(ARM_JOINTS, ["s", "o", "^"]))
    for coupling, shift in zip(COUPLINGS, [0.985, 1.015, 1.0]):
        for joint, j in zip(ARM_JOINTS, range(3)):
            d = np.array([(results[(wh, coupling)]["arm_lost"] or (math.nan,) * 3)[j]
                          - references["arm"][coupling][j] for wh in OMEGA_H], dtype=float)
            ax.plot(x * shift, d, "-" + markers[joint], color=colours[coupling],
                    markerfacecolor="white" if joint == "base" else colours[coupling],
                    linewidth=0.8, label=f"{coupling}: {joint}")
    ax.axhline(0, color="k", linestyle="--", linewidth=1, label="counts equal")
    ax.set_ylabel("lost steps − the 10 µs run's (full steps)")
    ax.set_title(MORE_ERRORS[2][1], fontsize=10)
    ax.legend(fontsize=7, ncol=2)
    for ax in axes.flat:
        ax.set_xscale("log")
        ticks = [w for w in OMEGA_H if w not in (1.25, 1.78)]
        ax.set_xticks(ticks)
        ax.set_xticklabels([f"{w:g}" for w in ticks], fontsize=8)
        ax.minorticks_off()
        ax.set_xlabel("ωn·h (ωn = 889.8 rad/s, the Tsui rotor alone)")
        ax.grid(True, which="major", alpha=0.3)
    top_axis = axes.flat[2].secondary_xaxis("top", functions=(lambda w: w * arm_ratio,
                                                              lambda w: w / arm_ratio))
    ticks = [w * arm_ratio for w in OMEGA_H if w not in (1.25, 1.78)]
    top_axis.xaxis.set_major_locator(ticker.FixedLocator(ticks))
    top_axis.xaxis.set_major_formatter(ticker.FixedFormatter([f"{w:.2g}" for w in ticks]))
    top_axis.xaxis.set_minor_locator(ticker.NullLocator())
    top_axis.tick_params(labelsize=7)
    top_axis.set_xlabel("the arm's fastest mode ω·h (2 kg, qpos0)", fontsize=8)
    fig.suptitle("error against ωn·h: models/tsui_coupling.xml's modes (1 µs reference), "
                 "models/arm3.xml's lost steps (10 µs), H6 on models/tsui_rigid.xml's ramp")
    fig.tight_layout()
    tmp = path + ".tmp"
    fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def more_measurements(results, tmp):
    """The two-mass modes, the arm's lost steps and H6 at every point of the grid into results;
    returns the references and the arm's fastest mode (rad/s)."""
    modes = two_mass_frequencies()
    references = {"modes": [], "arm": {}}
    for name, omega in zip(["slow", "fast"], modes):
        reference, why = two_mass_ring(TWO_MASS_REFERENCE_H, "consistent", omega, tmp)
        if why:
            sys.exit(f"the 1 us two-mass reference ({name} mode) is unstable ({why})")
        references["modes"].append(reference)
        print(f"two-mass reference (1 us, consistent): {name} mode {reference:.4f} rad/s "
              f"({reference / (2 * math.pi):.3f} Hz; the mode {omega / (2 * math.pi):.3f} Hz, "
              f"{100 * (reference / omega - 1):+.3f} %)")
    for coupling in COUPLINGS:
        references["arm"][coupling] = arm_lost_steps(ARM_REFERENCE_H, coupling, tmp)
        if references["arm"][coupling] is None:
            sys.exit(f"the 10 us arm run ({coupling}) failed")
        print(f"arm reference (10 us, {coupling}): lost steps "
              + ", ".join(f"{j} {c:+d}" for j, c in zip(ARM_JOINTS, references["arm"][coupling])))
    arm_omega = arm_fastest_mode(tmp)
    print(f"arm3 with 2 kg: fastest mode at qpos0 {arm_omega / (2 * math.pi):.2f} Hz "
          f"({arm_omega:.1f} rad/s: its w*h = {arm_omega / OMEGA_N:.3f} of the grid's wn*h)")
    for coupling in COUPLINGS:
        balance, info = h6_balance(H6_CHECK_H, coupling, tmp)
        print(f"H6 check at the model's 50 us, {coupling}: {balance / info['input']:.4g} of E_in")
    torque_total_gap, friction_bound = 0.0, 0.0
    for coupling in COUPLINGS:
        for wh in OMEGA_H:
            h = wh / OMEGA_N
            r = results[(wh, coupling)]
            r["h"] = h
            for (name, omega), reference in zip(zip(["slow", "fast"], modes), references["modes"]):
                f, why = two_mass_ring(h, coupling, omega, tmp)
                r[f"{name}_mode_omega_h"] = omega * h
                r[f"{name}_mode_error_pct"] = 100 * (f / reference - 1)
                r[f"{name}_mode_unstable"] = why
            r["arm_omega_h"] = arm_omega * h
            r["arm_lost"] = arm_lost_steps(h, coupling, tmp)
            r["arm_counts_differ"] = (math.nan if r["arm_lost"] is None
                                      else int(r["arm_lost"] != references["arm"][coupling]))
            result = h6_balance(h, coupling, tmp)
            if result is None:
                r["h6_residual_pct"] = math.nan
                h6 = "failed"
            else:
                balance, info = result
                r["h6_residual_pct"] = 100 * balance / info["input"]
                friction_bound = max(friction_bound, info["friction_bound"] / info["input"])
                if coupling == "explicit":
                    torque_total_gap = max(torque_total_gap, abs(
                        info["delivered"] - info["delivered_torque_total"]) / info["input"])
                h6 = f"{balance / info['input']:+.3e} of E_in"
                if info["lost"] != 0:
                    h6 += f" ({info['lost']:+.0f} full steps lost)"
            modes_text = ", ".join(
                f"{name} {r[f'{name}_mode_error_pct']:+7.3f} %" if not r[f"{name}_mode_unstable"]
                else f"{name} unstable ({r[f'{name}_mode_unstable']})" for name in ["slow", "fast"])
            lost = ("failed" if r["arm_lost"] is None
                    else " ".join(f"{c:+d}" for c in r["arm_lost"]))
            print(f"wn*h {wh:4g} (h {1e6 * h:7.2f} us) {coupling:10s}: modes {modes_text}; arm "
                  f"(its w*h {r['arm_omega_h']:.3f}) {lost}"
                  f"{'' if r['arm_counts_differ'] == 0 else ' (differs)'}; H6 {h6}", flush=True)
    print(f"H6: W_MuJoCo from the rotor's step against the logged torque_total (explicit): at most "
          f"{torque_total_gap:.2g} of E_in apart; steps slower than {SLIDING:g} rad/s, where the "
          f"dry friction may not slide: at most {friction_bound:.2g} of E_in")
    return references, arm_omega


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
        references, arm_omega = more_measurements(results, tmp)
    write_csv(results, os.path.join(OUT, "fidelity.csv"))
    plot(results, os.path.join(OUT, "fidelity.png"))
    write_more_csv(results, os.path.join(OUT, "fidelity_more.csv"))
    plot_more(results, references, arm_omega / OMEGA_N, os.path.join(OUT, "fidelity_more.png"))
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
    for key, title in MORE_ERRORS:
        for coupling in COUPLINGS:
            ok = [passes(results, wh, coupling, key) for wh in OMEGA_H]
            first_fail = ok.index(False) if False in ok else len(ok)
            again = [wh for wh, good in zip(OMEGA_H[first_fail:], ok[first_fail:]) if good]
            extra = f" (within it again at {', '.join(f'{w:g}' for w in again)})" if again else ""
            if 0 < first_fail < len(OMEGA_H) and key != "arm_counts_differ":
                w0, w1 = OMEGA_H[first_fail - 1], OMEGA_H[first_fail]
                e0, e1 = (abs(results[(w, coupling)][key]) for w in (w0, w1))
                if math.isfinite(e1):
                    crossing = w0 + (w1 - w0) * (LIMIT - e0) / (e1 - e0)
                    extra = f" (1 % crossed near {crossing:.2f}, linearly interpolated)" + extra
                else:
                    extra = f" (unstable at {w1:g})" + extra
            print(f"  {title}, {coupling}: "
                  f"{OMEGA_H[first_fail - 1] if first_fail > 0 else 'none'}{extra}")
    keys = [k for k, _ in ERRORS + MORE_ERRORS]
    for coupling in COUPLINGS:
        ok = [all(passes(results, wh, coupling, k) for k in keys) for wh in OMEGA_H]
        first_fail = ok.index(False) if False in ok else len(ok)
        print(f"  all seven (the three above, the two modes, the arm's counts, H6), {coupling}: "
              f"{OMEGA_H[first_fail - 1] if first_fail > 0 else 'none'}")
    print(f"wrote {os.path.relpath(OUT, ROOT)}/fidelity.csv, fidelity.png, fidelity_more.csv and "
          f"fidelity_more.png in {time.monotonic() - start:.0f} s")


if __name__ == "__main__":
    main()
