"""The printer study (issue 18): models/corexy.xml (a Voron Trident 350-class CoreXY) measured the way
Klipper users measure their printers: TEST_RESONANCES on X and Y with a virtual ADXL345 on the
toolhead, the input shapers fitted to it, a square corner and a ringing-tower-like sequence with
and without the recommended shapers, and how the drive changes the picture. Writes
docs/studies/printer.md, its figures in renders/printer/ and the video renders/printer/corexy.mp4,
from the mjstepper command alone.

    .venv/bin/python src/tools/python/study_printer.py      (bash scripts/study_printer.sh)
"""
import math
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mjstepper_plot as mp  # noqa: E402
from study_common import run_conditions  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")
MODEL = "models/corexy.xml"  # relative to ROOT, every command's working folder: the figures'
# titles name it so, never a machine's own path
LOGS = os.path.join(ROOT, "logs", "printer")
RENDERS = os.path.join(ROOT, "renders", "printer")
RADIUS = 0.04 / (2 * math.pi)  # m, GT2 20T
COUNTS = 200 * 32 / (2 * math.pi)  # microsteps per rad (32 microsteps, as the model's drives)
MOTORS = ("stepper_a", "stepper_b")


def run(args):
    return subprocess.run([CLI] + args, cwd=ROOT, check=True, capture_output=True,
                          text=True).stdout


def write_whole(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def resonance(axis, prefix, band=("5", "133.33", "2")):
    """`mjstepper resonance-test` of corexy.xml on one axis; its printed peak, fits and
    recommendation."""
    out = run(["resonance-test", MODEL, "--axis", axis, "--out", prefix, "--min-freq", band[0],
               "--max-freq", band[1], "--hz-per-sec", band[2], "--quiet"])
    peak = float(re.search(r"largest response at ([\d.]+) Hz", out).group(1))
    fits = {m.group(1): (float(m.group(2)), float(m.group(3)), float(m.group(5)))
            for m in re.finditer(r"^  (\w+) +([\d.]+) Hz: remaining vibration +([\d.]+) %, "
                                 r"smoothing ~= ([\d.]+), max_accel <= (\d+)", out, re.M)}
    best = re.search(r"recommended: (\w+) at ([\d.]+) Hz", out)
    return peak, fits, (best.group(1), float(best.group(2)))


def resonance_on(model, axis, prefix, band):
    out = run(["resonance-test", model, "--axis", axis, "--out", prefix, "--min-freq", band[0],
               "--max-freq", band[1], "--hz-per-sec", band[2], "--quiet"])
    peak = float(re.search(r"largest response at ([\d.]+) Hz", out).group(1))
    best = re.search(r"recommended: (\w+) at ([\d.]+) Hz", out)
    return peak, (best.group(1), float(best.group(2)))


def drive_variant(name, configs):
    """corexy.xml with both steppers' chopper configuration replaced by `configs`."""
    with open(os.path.join(ROOT, MODEL)) as f:
        xml = f.read()
    xml = re.sub(r'<config key="(driver|drive|run_current|sense_resistor|interpolate)" '
                 r'value="[^"]*"/>\s*', "", xml)
    xml = xml.replace('<config key="input" value="steps"/>',
                      '<config key="input" value="steps"/>' + configs)
    path = os.path.join(LOGS, f"corexy_{name}.xml")
    write_whole(path, xml)
    return path


def trapezoid(x0, x1, speed, accel, t0, dt=1e-5):
    """Samples (t, x) of a move from x0 to x1 (m) at `speed` (m/s) and `accel` (m/s²)."""
    d = abs(x1 - x0)
    sign = 1 if x1 >= x0 else -1
    ta = min(speed / accel, math.sqrt(d / accel))
    v = accel * ta
    tc = (d - accel * ta * ta) / v if v > 0 else 0
    total = 2 * ta + tc
    out = []
    n = int(total / dt) + 1
    for k in range(n + 1):
        t = min(k * dt, total)
        if t < ta:
            s = 0.5 * accel * t * t
        elif t < ta + tc:
            s = 0.5 * accel * ta * ta + v * (t - ta)
        else:
            td = total - t
            s = d - 0.5 * accel * td * td
        out.append((t0 + t, x0 + sign * s))
    return out, t0 + total


def step_lists(path, name, kinematics=None):
    """Step lists (steps(FILE)) for each motor from a toolhead path [(t, x, y)]; `kinematics`
    maps a motor to its (rotor rad per m of x, of y, microsteps per rad); CoreXY by default:
    θA = (x + y)/r, θB = (x − y)/r. A line per count change."""
    kinematics = kinematics or {m: (1 / RADIUS, sign / RADIUS, COUNTS)
                                for m, sign in zip(MOTORS, (1, -1))}
    files = []
    for motor, (kx, ky, counts) in kinematics.items():
        lines, count = [], 0
        for t, x, y in path:
            target = round((kx * x + ky * y) * counts)
            while count != target:
                step = 1 if target > count else -1
                count += step
                lines.append(f"{t:.7f}" + ("" if step > 0 else " -1"))
        p = os.path.join(LOGS, f"{name}_{motor}.txt")
        write_whole(p, "\n".join(lines) + "\n")
        files.append(p)
    return files


def square_corner():
    """X +40 mm, a stop at the corner, Y +40 mm, 100 mm/s at 5000 mm/s², then 0.3 s still."""
    xs, t = trapezoid(0, 0.04, 0.1, 5.0, 0.05)
    ys, t_end = trapezoid(0, 0.04, 0.1, 5.0, t)
    path = [(tt, x, 0.0) for tt, x in xs] + [(tt, 0.04, y) for tt, y in ys]
    return path, [t, t_end], t_end + 0.3


def tower(axis="x"):
    """A ringing-tower-like sequence: moves of ±30 mm along `axis` at 50, 100, 150 and 200 mm/s
    (5000 mm/s²), 0.25 s apart."""
    path, ends, t, x = [], [], 0.05, 0.0
    for speed in (0.05, 0.1, 0.15, 0.2):
        for target in (0.03, 0.0):
            seg, t_end = trapezoid(x, target, speed, 5.0, t)
            path += [(tt, xx, 0.0) if axis == "x" else (tt, 0.0, xx) for tt, xx in seg]
            ends.append(t_end)
            x, t = target, t_end + 0.25
    return path, ends, t


# The ADXL345's own RMS on X and Y: 290 µg/√Hz over its 1600 Hz bandwidth, and 3.9 mg rounding.
NOISE_FLOOR = math.hypot(290e-6 * 9806.65 * math.sqrt(1600), 0.0039 * 9806.65 / math.sqrt(12))


def above_floor(rms):
    """The ringing's own RMS, the sensor's noise taken out in quadrature (mm/s²)."""
    return math.sqrt(max(rms * rms - NOISE_FLOOR * NOISE_FLOOR, 0.0))


def ringing(accel_csv, ends, axis):
    """RMS of the accelerometer's `axis` column (mm/s²) over 20-120 ms after each move's end."""
    _, c = mp.read_csv(accel_csv)
    t = c["#time"]
    a = c[f"accel_{axis}"]
    out = []
    for end in ends:
        w = [v for tt, v in zip(t, a) if end + 0.02 <= tt <= end + 0.12]
        mean = sum(w) / len(w)
        out.append(math.sqrt(sum((v - mean) ** 2 for v in w) / len(w)))
    return out


def run_path(name, files, duration, shaper=None, render=None, model=MODEL, motors=MOTORS,
             accelerometer="toolhead_accel"):
    ctrl = []
    for motor, f in zip(motors, files):
        profile = f"steps({f})"
        for s in shaper or ():
            profile = f"shaped({profile}, {s})"
        ctrl += ["--ctrl", f"{motor}={profile}"]
    log = os.path.join(LOGS, f"{name}_accel.csv")
    extra = ["--render", render, "--camera", "iso", "--size", "640x480", "--fps", "30",
             "--playback", "0.25"] if render else []
    run(["run", model, "--duration", f"{duration:.3f}", "--quiet", "--accel-log", log,
         "--accelerometer", accelerometer] + ctrl + extra)
    return log


PRINT = os.path.join(ROOT, "models", "prints", "square20")
KLIPPER_DATA = os.path.join(ROOT, "tests", "data", "klipper")


def klipper_recommends(axis):
    """What Klipper's own calibrate_shaper.py printed for this model's resonance test on `axis`
    (run once outside the build: tests/data/klipper/README.md): its recommended shaper, frequency,
    smoothing and max_accel."""
    with open(os.path.join(KLIPPER_DATA, f"corexy_{axis}_calibrate_shaper.txt")) as f:
        text = f.read()
    name, freq = re.search(r"Recommended shaper is (\w+) @ ([\d.]+) Hz", text).groups()
    smoothing = re.search(rf"Fitted shaper '{name}' frequency = [\d.]+ Hz \(vibrations = "
                          r"[\d.]+%, smoothing ~= ([\d.]+)\)", text).group(1)
    max_accel = re.search(rf"with '{name}', suggested max_accel <= (\d+)", text).group(1)
    return name, float(freq), float(smoothing), int(max_accel)


def print_moves(log):
    """The replayed print's moves from its log: the toolhead's commanded path (x = r·(θa + θb)/2,
    y = r·(θa − θb)/2 from each motor's theta_cmd), cut where the moving axis or its sign changes
    or the toolhead stops. Each move: (axis, sign, start, end) in s."""
    _, c = mp.read_csv(log)
    t = c["time[s]"]
    a0, b0 = c["stepper_a:theta_cmd[rad]"][0], c["stepper_b:theta_cmd[rad]"][0]
    x = [RADIUS * ((a - a0) + (b - b0)) / 2 for a, b in
         zip(c["stepper_a:theta_cmd[rad]"], c["stepper_b:theta_cmd[rad]"])]
    y = [RADIUS * ((a - a0) - (b - b0)) / 2 for a, b in
         zip(c["stepper_a:theta_cmd[rad]"], c["stepper_b:theta_cmd[rad]"])]
    moves, current = [], None
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        vx, vy = (x[k] - x[k - 1]) / dt, (y[k] - y[k - 1]) / dt
        moving = max(abs(vx), abs(vy)) > 1e-4  # m/s
        key = (("x" if abs(vx) >= abs(vy) else "y"), 1 if (vx if abs(vx) >= abs(vy) else vy) > 0
               else -1) if moving else None
        if current and key != tuple(current[:2]):
            moves.append(current)
            current = None
        if key and not current:
            current = [key[0], key[1], t[k - 1], t[k]]
        elif key:
            current[3] = t[k]
    if current:
        moves.append(current)
    return [tuple(m) for m in moves if m[3] - m[2] > 0.05]


def main():
    start = time.time()
    os.makedirs(LOGS, exist_ok=True)
    os.makedirs(RENDERS, exist_ok=True)

    # 1. TEST_RESONANCES on X and Y (Klipper's 5-133 Hz band, 2 Hz/s), as shipped: SpreadCycle.
    results = {}
    for axis in ("x", "y"):
        prefix = os.path.join(RENDERS, f"corexy_{axis}")
        results[axis] = resonance(axis, prefix)
        os.replace(prefix + "_raw.csv", os.path.join(LOGS, f"corexy_{axis}_raw.csv"))
        os.replace(prefix + "_psd.csv", os.path.join(LOGS, f"corexy_{axis}_psd.csv"))

    # 2. The drive changes the picture: the same test (20-110 Hz at 5 Hz/s) under StealthChop,
    # Tsui's PI drive and an ideal current source, at the same 1.125 A peak.
    band = ("20", "110", "5")
    drives = {
        "SpreadCycle (TMC2209, as shipped)": MODEL,
        "StealthChop (TMC2209)": drive_variant(
            "stealthchop", '<config key="driver" value="tmc2209"/><config key="drive" '
            'value="stealthchop"/><config key="run_current" value="0.8"/>'),
        "Tsui PI (current_microstep)": drive_variant(
            "pi", '<config key="drive" value="current_microstep"/><config key="hold_current" '
            'value="1.125"/><config key="bus_voltage" value="24"/>'),
        "ideal current source": drive_variant(
            "ideal", '<config key="drive" value="ideal_current"/><config key="hold_current" '
            'value="1.125"/>'),
    }
    by_drive = {}
    for label, model in drives.items():
        key = re.sub(r"\W+", "_", label.split(" (")[0].lower())
        by_drive[label] = {axis: resonance_on(model, axis, os.path.join(LOGS, f"drive_{key}_{axis}"),
                                              band) for axis in ("x", "y")}

    # 3. Ringing with and without the recommended shapers.
    sx = f"{results['x'][2][0]} {results['x'][2][1]:.1f}Hz"
    sy = f"{results['y'][2][0]} {results['y'][2][1]:.1f}Hz"
    corner_path, corner_ends, corner_t = square_corner()
    corner_files = step_lists(corner_path, "corner")
    tower_path, tower_ends, tower_t = tower()
    tower_files = step_lists(tower_path, "tower")
    corner = {}
    for name, shaper in (("unshaped", None), ("shaped", (sx, sy))):
        log = run_path(f"corner_{name}", corner_files, corner_t, shaper)
        corner[name] = (ringing(log, corner_ends[:1], "x")[0], ringing(log, corner_ends[1:], "y")[0],
                        log)
    towers = {}
    for name, shaper in (("unshaped", None), ("shaped", (sx,))):
        render = os.path.join(RENDERS, "corexy.mp4") if name == "unshaped" else None
        log = run_path(f"tower_{name}", tower_files, tower_t, shaper, render)
        towers[name] = (ringing(log, tower_ends, "x"), log)

    # 4. The bed-slinger (models/bedslinger.xml): each axis its own motor, shaper and sensor.
    bed_model = "models/bedslinger.xml"
    bed_radius = 0.032 / (2 * math.pi)  # m, GT2 16T
    bed_counts = 400 * 8 / (2 * math.pi)  # 0.9° motors at 8 microsteps
    bed = {}
    for axis, motor, sensor in (("x", "stepper_x", "toolhead_accel"),
                                ("y", "stepper_y", "bed_accel")):
        out = run(["resonance-test", bed_model, "--axis", axis, "--accelerometer", sensor,
                   "--out", os.path.join(LOGS, f"bed_{axis}"), "--min-freq", "20",
                   "--max-freq", "110", "--hz-per-sec", "5", "--quiet"])
        peak = float(re.search(r"largest response at ([\d.]+) Hz", out).group(1))
        best = re.search(r"recommended: (\w+) at ([\d.]+) Hz", out)
        fit = re.search(rf"^  {best.group(1)} +[\d.]+ Hz: remaining vibration +([\d.]+) %.*"
                        r"max_accel <= (\d+)", out, re.M)
        shaper = f"{best.group(1)} {float(best.group(2)):.1f}Hz"
        path, ends, t_end = tower(axis)
        files = step_lists(path, f"bed_tower_{axis}", {motor: (1 / bed_radius, 1 / bed_radius,
                                                                 bed_counts)})
        rms = {}
        for name, shapers in (("unshaped", None), ("shaped", (shaper,))):
            log = run_path(f"bed_tower_{axis}_{name}", files, t_end, shapers, model=bed_model,
                           motors=(motor,), accelerometer=sensor)
            rms[name] = ringing(log, ends, axis)
        bed[axis] = (peak, shaper, float(fit.group(1)), int(fit.group(2)), rms)

    # 5. A real print's step stream (models/prints/square20): Klipper's MCU step commands for a
    # 20 mm X move and two 20 mm squares at 100 mm/s, without and with its MZV, replayed.
    still = os.path.join(LOGS, "square20_still_accel.csv")
    run(["run", MODEL, "--duration", "3.2", "--quiet", "--accel-log", still])
    replay = {}
    for name in ("noshaper", "mzv"):
        accel = os.path.join(LOGS, f"square20_{name}_accel.csv")
        log = os.path.join(LOGS, f"square20_{name}.csv")
        video = ["--render", os.path.join(RENDERS, "square20.mp4"), "--camera", "top", "--size",
                 "640x480", "--fps", "30", "--playback", "0.25"] if name == "mzv" else []
        out = run(["run", MODEL, "--duration", "3.2", "--quiet", "--klipper",
                   os.path.join(PRINT, f"{name}.map"), "--accel-log", accel, "--log", log,
                   "--log-every", "20"] + video)
        lost = [int(v) for v in re.findall(r"lost steps ([+-]?\d+)", out)]
        _, c = mp.read_csv(log)
        _, quiet = mp.read_csv(still)
        _, moved = mp.read_csv(accel)
        noise = {round(tt, 7): (ax, ay) for tt, ax, ay in
                 zip(quiet["#time"], quiet["accel_x"], quiet["accel_y"])}
        rows = []
        for axis, sign, t0, t1 in print_moves(log):
            i = 0 if axis == "x" else 1
            w = [(v - noise[round(tt, 7)][i]) ** 2 for tt, v in
                 zip(moved["#time"], moved[f"accel_{axis}"])
                 if t1 + 0.01 <= tt < t1 + 0.1 and round(tt, 7) in noise]
            ring = math.sqrt(sum(w) / len(w))
            # The lag in the cruise (the middle half): the rotors' mean position error along the
            # move's axis, at the carriage.
            ea, eb = c["stepper_a:position_error[rad]"], c["stepper_b:position_error[rad]"]
            lo, hi = t0 + 0.25 * (t1 - t0), t0 + 0.75 * (t1 - t0)
            lag = [-RADIUS * ((a + b) if axis == "x" else (a - b)) / 2 * sign  # behind: > 0
                   for tt, a, b in zip(c["time[s]"], ea, eb) if lo <= tt <= hi]
            rows.append((f"{'+' if sign > 0 else '−'}{axis.upper()}", t0, t1, ring,
                         sum(lag) / len(lag)))
        temps = (c["stepper_a:winding_temperature[°C]"][-1],
                 c["stepper_b:winding_temperature[°C]"][-1])
        replay[name] = (rows, lost, temps)

    # Figures.
    fig, axes = mp.plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for ax, name in zip(axes, ("unshaped", "shaped")):
        _, c = mp.read_csv(corner[name][2])
        ax.plot(c["#time"], c["accel_x"], lw=0.6, label="accel_x")
        ax.plot(c["#time"], c["accel_y"], lw=0.6, label="accel_y")
        ax.set_ylabel("mm/s²")
        ax.set_title(f"square corner, {name}" + (f" ({sx}, {sy} in series)" if name == "shaped"
                                                  else ""), fontsize=9)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    mp.save(fig, os.path.join(RENDERS, "square_corner.png"))

    fig, ax = mp.plt.subplots(figsize=(9, 4.5))
    speeds = [50, 50, 100, 100, 150, 150, 200, 200]
    for name in ("unshaped", "shaped"):
        ax.plot(range(len(speeds)), towers[name][0], marker="o", label=name)
    ax.set_xticks(range(len(speeds)))
    ax.set_xticklabels([f"{s} mm/s\n{'+' if i % 2 == 0 else '−'}X" for i, s in enumerate(speeds)],
                       fontsize=7)
    ax.legend(fontsize=8)
    mp.finish(fig, ax, "move", "ringing after the move, RMS (mm/s²)",
              f"ringing tower (X moves of 30 mm at 5000 mm/s²), {sx} on X",
              os.path.join(RENDERS, "ringing_tower.png"))

    # The page.
    def fit_rows(axis):
        return "\n".join(
            f"| {name} | {f:.1f} | {v:.2f} | {acc:.0f} |"
            for name, (f, v, acc) in results[axis][1].items())

    drive_rows = "\n".join(
        f"| {label} | {r['x'][0]:.1f} | {r['x'][1][0]} {r['x'][1][1]:.1f} | {r['y'][0]:.1f} | "
        f"{r['y'][1][0]} {r['y'][1][1]:.1f} |" for label, r in by_drive.items())
    tower_rows = "\n".join(
        f"| {s} mm/s, {'+' if i % 2 == 0 else '−'}X | {u:.0f} | {sh:.0f} | {sh / u:.3f} | "
        f"{above_floor(sh) / above_floor(u):.3f} |"
        for i, (s, u, sh) in enumerate(zip(speeds, towers["unshaped"][0], towers["shaped"][0])))
    cu, cs = corner["unshaped"], corner["shaped"]

    def mean(v):
        return sum(v) / len(v)

    replay_rows = "\n".join(
        f"| {k + 1} | {u[0]} | {u[1]:.3f}-{u[2]:.3f} | {u[3]:.0f} | {m[3]:.0f} | "
        f"{m[3] / u[3]:.3f} | {1e6 * u[4]:.1f} | {1e6 * m[4]:.1f} |"
        for k, (u, m) in enumerate(zip(replay["noshaper"][0], replay["mzv"][0])))
    klipper = {axis: klipper_recommends(axis) for axis in ("x", "y")}
    ours = {axis: results[axis][2] for axis in ("x", "y")}
    side_rows = "\n".join(
        f"| {axis.upper()} | {ours[axis][0]} {ours[axis][1]:.1f} Hz | "
        f"{results[axis][1][ours[axis][0]][2]:.0f} | {klipper[axis][0]} {klipper[axis][1]:.1f} Hz "
        f"| {klipper[axis][2]:.3f} | {klipper[axis][3]} |" for axis in ("x", "y"))

    bed_rows = "\n".join(
        f"| {axis.upper()} | {p:.1f} | {sh} | {v:.2f} | {acc} | {mean(r['unshaped']):.0f} | "
        f"{mean(r['shaped']):.0f} | "
        f"{mean([above_floor(b) / above_floor(a) for a, b in zip(r['unshaped'], r['shaped'])]):.3f} |"
        for axis, (p, sh, v, acc, r) in bed.items())
    elapsed = time.time() - start
    page = f"""# Printer study: a CoreXY's resonances, input shapers and drives

Regenerated by `bash scripts/study_printer.sh` (builds, then
`.venv/bin/python src/tools/python/study_printer.py`, which prints its wall time).
Logs in `logs/printer/`, figures and video in `renders/printer/`.
{run_conditions(MODEL, bed_model)}
Not part of the main job: added to `scripts/study.sh` it would take the default study past the
two minutes after the build that issue 18 allows it.

## Setup

`models/corexy.xml` (see `models/README.md`): a Voron Trident 350-class CoreXY, two 17HS19-2004S1
steppers on TMC2209 drivers in SpreadCycle at 0.8 A RMS and 32 microsteps (Voron's Klipper
config), GT2 belts as CoreXY tendons (4.31e4 N/m each, damped for ζ ≈ 0.1), a 0.50 kg toolhead on
a 0.60 kg Y gantry, a virtual ADXL345 on the toolhead (3200 Hz, ±16 g, 3.9 mg, 290 µg/√Hz).
Closed forms of the lower (toolhead) modes: X 61.2 Hz, Y 41.4 Hz (belts in series with the
steppers' magnetic stiffness; the chopper's shorted idle phase adds 1-3 %, README).

## Resonance tests (TEST_RESONANCES, 5-133 Hz at 2 Hz/s, 75 mm/s² per Hz)

![X](../../renders/printer/corexy_x.png)
![Y](../../renders/printer/corexy_y.png)

Measured resonance: X {results['x'][0]:.1f} Hz, Y {results['y'][0]:.1f} Hz. The raw logs
(`logs/printer/corexy_x_raw.csv`) are in Klipper's raw format, `#time,accel_x,accel_y,accel_z` in
s and mm/s², the format its `calibrate_shaper.py` reads; `logs/printer/corexy_x_psd.csv` is
Klipper's calibration CSV, which the same script reads back.

| X: shaper | frequency (Hz) | remaining vibration (%) | Klipper's max_accel (mm/s²) |
|---|---|---|---|
{fit_rows('x')}

| Y: shaper | frequency (Hz) | remaining vibration (%) | Klipper's max_accel (mm/s²) |
|---|---|---|---|
{fit_rows('y')}

Recommended: X **{results['x'][2][0]} at {results['x'][2][1]:.1f} Hz**, Y **{results['y'][2][0]}
at {results['y'][2][1]:.1f} Hz** (the least-smoothing shaper leaving at most 1 % of the vibration
energy; smoothing and max_accel by Klipper's own definitions, src/core/shaper.h, with its 0.12 mm
target and 5 mm/s square corner velocity, rounded as Klipper prints it).

Klipper's own `calibrate_shaper.py` on this model's resonance test (Klipper's defaults: 5-133 Hz
at 1 Hz/s; run once outside the build, its output committed in `tests/data/klipper/`), beside this
project's fit:

| axis | this project recommends | its max_accel (mm/s²) | Klipper recommends | Klipper's smoothing (mm) | Klipper's max_accel (mm/s²) |
|---|---|---|---|---|---|
{side_rows}

Both use Klipper's definitions of smoothing and max_accel (`src/core/shaper.h`; the project's own
measure, how far the shaped path cuts a square corner, is 0.6-0.7 of Klipper's smoothing and is
printed beside it as `corner`). Where the frequencies differ, the fits differ: Klipper weighs the
PSD by 1/f and scores vibration and smoothing together, this project takes the least-smoothing
frequency among those leaving the least vibration.

## Ringing with and without the shapers

![square corner](../../renders/printer/square_corner.png)

A square corner (X +40 mm, stop, Y +40 mm; 100 mm/s, 5000 mm/s²), driven as STEP/DIR step lists
(`--ctrl stepper_a=steps(FILE)`), unshaped and shaped: the RMS of the ringing 20-120 ms after each
move, from the virtual ADXL345 (`--accel-log`):

| move | unshaped (mm/s²) | shaped (mm/s²) | ratio | ratio above the sensor's noise |
|---|---|---|---|---|
| X, after the first leg | {cu[0]:.0f} | {cs[0]:.0f} | {cs[0] / cu[0]:.3f} | {above_floor(cs[0]) / above_floor(cu[0]):.3f} |
| Y, after the second | {cu[1]:.0f} | {cs[1]:.0f} | {cs[1] / cu[1]:.3f} | {above_floor(cs[1]) / above_floor(cu[1]):.3f} |

On a CoreXY each motor carries both axes (A = x + y, B = x − y), and a profile shapes one motor's
command, so the corner is shaped by both axes' shapers in series ({sx} ∗ {sy}) on both motors:
each mode meets its own shaper (V multiplies), at the cost of both shapers' smoothing. Klipper
shapes X and Y separately before its kinematics; that would need a toolhead-level profile here.

![ringing tower](../../renders/printer/ringing_tower.png)

A ringing-tower-like sequence: X moves of 30 mm out and back at 50, 100, 150, 200 mm/s, shaped
by {sx} on both motors (pure X moves turn A and B alike):

| move | unshaped (mm/s²) | shaped (mm/s²) | ratio | ratio above the sensor's noise |
|---|---|---|---|---|
{tower_rows}

The ADXL345's own noise, 290 µg/√Hz over its 1600 Hz bandwidth plus its 3.9 mg rounding, is
{NOISE_FLOOR:.0f} mm/s² RMS: the shaped moves ring at about that floor, so the plain ratio says
more about the sensor than the shaper; the last column takes the floor out in quadrature. What
the rest is, is not settled: it is not the microstep staircase (256 microsteps leave it as it is,
issue 31), and not the switching chopper's folded ripple, which a step of the printers' 5e-5 s no
longer hands MuJoCo (docs/coupling.md, "The CoreXY after a move"). (tests/tools/resonance_test.cc checks a shaped
move against SPEC §9's V on MuJoCo's noise-free sensor: below 1/10 when tuned, within 20 % of V
when detuned.)

## A real print replayed

`models/prints/square20`: Klipper's microcontroller step commands for `square20.gcode` (one 20 mm
X move, a 200 ms dwell, then two 20 mm squares, all at 100 mm/s and 3000 mm/s², corners at
Klipper's 5 mm/s square corner velocity) on a `printer.cfg` with this model's numbers, from
Klipper's batch mode without and with its MZV (X 62.2 Hz, Y 42.2 Hz: what Klipper recommends
above), replayed with `mjstepper run models/corexy.xml --klipper MAP`: every STEP pulse at its own
time, shaped by Klipper itself. Per move: the ringing along the move's axis 10-100 ms after it
ends (during the next move, which runs along the other axis), less the sensor's noise sample by
sample, and the lag in the cruise (the middle half of the move: the rotors' mean position error
along the move's axis, at the carriage):

| move | axis | time (s) | ringing, no shaper (mm/s²) | with MZV | ratio | lag behind, no shaper (µm) | with MZV (µm) |
|---|---|---|---|---|---|---|---|
{replay_rows}

(The sensor's noise is taken out sample by sample, so the ratio is the ringing's own.) Lost steps
(stepper_a, stepper_b): {' and '.join(map(str, replay['noshaper'][1]))} without the shaper,
{' and '.join(map(str, replay['mzv'][1]))} with it. Winding temperatures at the end:
{replay['noshaper'][2][0]:.1f} and {replay['noshaper'][2][1]:.1f} °C without,
{replay['mzv'][2][0]:.1f} and {replay['mzv'][2][1]:.1f} °C with (from 25 °C: 3 s of printing
barely warms a winding, whose time constant is minutes).
`renders/printer/square20.mp4`: the shaped print from above, a quarter of real time.

## The bed-slinger

`models/bedslinger.xml` (Prusa i3 MK4 class; closed forms X 70.8 Hz, Y 50.4 Hz), each axis on its
own motor and shaper, Y measured on the bed (`--accelerometer bed_accel`): the resonance test
(20-110 Hz at 5 Hz/s) and the ringing-tower sequence along that axis, the mean over its eight moves:

| axis | peak (Hz) | recommended | remaining vibration (%) | Klipper's max_accel (mm/s²) | ringing unshaped (mm/s²) | shaped | ratio above the sensor's noise |
|---|---|---|---|---|---|---|---|
{bed_rows}

## How the drive changes the picture

The same test (20-110 Hz at 5 Hz/s) with both motors on each drive at the same 1.125 A peak:

| drive | X peak (Hz) | X recommended | Y peak (Hz) | Y recommended |
|---|---|---|---|---|
{drive_rows}

Current-regulating drives (SpreadCycle, the PI loop, the ideal source) hold the rotors with T'
and ring where the closed forms say; StealthChop's voltage-mode current answers the rotors'
motion with back-EMF currents of its own, which moves the modes (here 1-3 % up).

## Video

`renders/printer/corexy.mp4`: the unshaped ringing-tower sequence, a quarter of real time, 640×480.
`renders/printer/square20.mp4`: the real print replayed with Klipper's MZV, from above, a quarter
of real time, 640×480.
"""
    write_whole(os.path.join(ROOT, "docs", "studies", "printer.md"), page)
    print(f"printer study done in {elapsed:.0f} s: docs/studies/printer.md")


if __name__ == "__main__":
    main()
