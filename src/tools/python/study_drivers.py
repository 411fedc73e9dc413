"""The drivers study (issue 17): the belt axis of models/belt_axis.xml on a catalogue motor
(Trinamic QSH4218-51, NEMA 17) under four drives at the same 1.41 A peak current and a printer's
24 V: Tsui's PI current loop, SpreadCycle and StealthChop on a TMC2209 fed by STEP/DIR, and an ideal
current source. Writes docs/studies/drivers.md, its figures in renders/drivers/ and the video
renders/drivers/belt_axis.mp4, from the mjstepper command alone.

    .venv/bin/python src/tools/python/study_drivers.py      (bash scripts/study.sh runs it)
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
LOGS = os.path.join(ROOT, "logs", "drivers")
RENDERS = os.path.join(ROOT, "renders", "drivers")
MOTOR = "qsh4218_51"
INERTIA = "68e-7"  # kg·m², the QSH4218-51's rotor (presets.cc), as the actuator's armature
RPM = 60 / (2 * math.pi)
FULL_STEP = 2 * math.pi / 200  # rad
PEAK = 1.41421356  # A, √2 × the 1.0 A RMS rating
DRIVES = [
    ("pi", "Tsui PI (current_microstep)",
     ["drive=current_microstep", f"hold_current={PEAK}", "bus_voltage=24"]),
    ("spreadcycle", "SpreadCycle (TMC2209)",
     ["driver=tmc2209", "drive=spreadcycle", "input=steps", "run_current=1.0"]),
    ("stealthchop", "StealthChop (TMC2209)",
     ["driver=tmc2209", "drive=stealthchop", "input=steps", "run_current=1.0"]),
    ("ideal", "ideal current source",
     ["drive=ideal_current", f"hold_current={PEAK}", "bus_voltage=24"]),
]


def run(args):
    return subprocess.run([CLI] + args, cwd=ROOT, check=True, capture_output=True,
                          text=True).stdout


def sets(settings):
    out = []
    for s in settings:
        out += ["--set", f"shaft.{s}"]
    return out


def model_variant(name, timestep=None, stop=None, config=""):
    """belt_axis.xml with the catalogue motor (its rotor inertia as armature, B = 1e-4), and
    optionally another timestep or a hard stop (a joint limit) `stop` m from the carriage's
    start; written to logs/drivers/NAME.xml."""
    with open(os.path.join(ROOT, "models", "belt_axis.xml")) as f:
        xml = f.read()
    xml = xml.replace('armature="0.36e-4"', f'armature="{INERTIA}"')
    xml = xml.replace('damping="0.001">', 'damping="1e-4">')
    xml = xml.replace('<config key="motor" value="tsui2009"/>',
                      f'<config key="motor" value="{MOTOR}"/>{config}')
    if timestep is not None:
        xml = re.sub(r'timestep="[^"]*"', f'timestep="{timestep}"', xml)
    if stop is not None:
        xml = xml.replace('<joint name="carriage" type="slide" axis="1 0 0" frictionloss="1"/>',
                          '<joint name="carriage" type="slide" axis="1 0 0" frictionloss="1" '
                          f'limited="true" range="{-stop} 0.3" solreflimit="0.002 1"/>')
        assert "limited" in xml
    path = os.path.join(LOGS, name + ".xml")
    write_whole(path, xml)
    return path


def write_whole(path, text):
    """Writes a file through a temporary and a rename: never half-written."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def col(c, signal):
    return mp.column(c, "shaft", signal)[0]


def ripple(model):
    """Phase current against its reference over 10 ms at 60 r/min, 1 µs samples: RMS and peak to
    peak of ia − ia*."""
    out = {}
    for key, _, settings in DRIVES:
        log = os.path.join(LOGS, f"ripple_{key}.csv")
        run(["run", model, "--duration", "0.02", "--quiet", "--ctrl", "shaft=constant(60rpm)",
             "--log", log] + sets(settings))
        _, c = mp.read_csv(log)
        t = c["time[s]"]
        err = [a - r for a, r, tt in zip(col(c, "current_a"), col(c, "current_ref_a"), t)
               if tt >= 0.01]
        out[key] = (math.sqrt(sum(e * e for e in err) / len(err)), max(err) - min(err))
        if key in ("spreadcycle", "stealthchop", "pi"):
            out[key + "_trace"] = ([tt * 1e3 for tt in t if tt >= 0.018],
                                   [a for a, tt in zip(col(c, "current_a"), t) if tt >= 0.018],
                                   [r for r, tt in zip(col(c, "current_ref_a"), t) if tt >= 0.018])
    return out


def main():
    start = time.time()
    os.makedirs(LOGS, exist_ok=True)
    os.makedirs(RENDERS, exist_ok=True)
    model = model_variant("belt_axis_qsh4218")
    # fn at the drives' 1.41 A (`info` reads the model's own config, so a variant holding it).
    info = run(["info", model_variant("belt_axis_qsh4218_info",
                                      config=f'<config key="hold_current" value="{PEAK}"/>')])
    modes = re.findall(r"fn = \(1/2π\)·√\(T'/J\) = ([\d.]+) Hz", info)
    fn = float(modes[0]) if modes else float("nan")

    # 1. Phase current ripple (1 µs steps: the chopper's 30-40 kHz resolved).
    fine = model_variant("belt_axis_qsh4218_1us", timestep="1e-6")
    rip = ripple(fine)

    # 2. Velocity ripple through the low-speed resonances, and 3. pull-out.
    sweeps, pullouts = {}, {}
    for key, _, settings in DRIVES:
        prefix = os.path.join(LOGS, f"sweep_{key}")
        run(["sweep", model, "--speeds", "10:480:10rpm", "--settle", "0.3", "--measure", "0.3",
             "--quiet", "--out", prefix] + sets(settings))
        _, sweeps[key] = mp.read_csv(prefix + ".csv")
        prefix = os.path.join(LOGS, f"pullout_{key}")
        run(["pullout", model, "--speeds", "30:480:30rpm", "--quiet", "--out", prefix]
            + sets(settings))
        _, pullouts[key] = mp.read_csv(prefix + ".csv")

    # 4. StealthChop's (and SpreadCycle's) lag behind the commanded position at three speeds.
    lag = {}
    for key, _, settings in DRIVES[1:3]:
        for rpm in (60, 120, 240):
            log = os.path.join(LOGS, f"lag_{key}_{rpm}.csv")
            run(["run", model, "--duration", "0.8", "--quiet", "--ctrl",
                 f"shaft=ramp(0rpm,{rpm}rpm,0.2s)", "--log", log] + sets(settings))
            _, c = mp.read_csv(log)
            err = [e for e, t in zip(col(c, "position_error"), c["time[s]"]) if t >= 0.5]
            lag[(key, rpm)] = -sum(err) / len(err) / FULL_STEP  # full steps behind

    # 5. Sensorless homing: StealthChop's StallGuard4 (SGTHRS 40) toward a stop 5 mm away at
    # 20 mm/s (30 r/min on the 40 mm pulley).
    stop_model = model_variant("belt_axis_qsh4218_stop", stop=0.005)
    homing_log = os.path.join(LOGS, "homing.csv")
    homing_sets = DRIVES[2][2] + ["sgthrs=40"]
    run(["run", stop_model, "--duration", "0.6", "--quiet", "--ctrl", "shaft=constant(-30rpm)",
         "--log", homing_log] + sets(homing_sets))
    _, hc = mp.read_csv(homing_log)
    first_stall = col(hc, "first_stall_time")[-1]
    contact = 0.005 / 0.020  # s: 5 mm at 20 mm/s from a standing start (below pull-in)

    # 6. Heat: a 10-minute duty cycle on StealthChop, 0.8 s at 60 r/min forward, 0.2 s held, 0.8 s
    # back, 0.2 s held, as a motion controller's step list (steps(FILE)); 8e-5 s steps.
    heat_model = model_variant("belt_axis_qsh4218_8e-5", timestep="8e-5")
    steps_path = os.path.join(LOGS, "duty_cycle_steps.txt")
    rate = 60 / 60 * 200 * 16  # microsteps/s at 60 r/min
    with open(steps_path + ".tmp", "w") as f:
        f.write("# 300 cycles of 2 s: 0.8 s at 60 r/min forward, 0.2 s held, 0.8 s back, 0.2 s held\n")
        n = int(0.8 * rate)
        for cycle in range(300):
            t0 = 2.0 * cycle
            f.writelines(f"{t0 + (k + 1) / rate:.7f}\n" for k in range(n))
            f.writelines(f"{t0 + 1.0 + (k + 1) / rate:.7f} -1\n" for k in range(n))
    os.replace(steps_path + ".tmp", steps_path)
    heat_log = os.path.join(LOGS, "heat.csv")
    run(["run", heat_model, "--duration", "600", "--quiet", "--log-every", "1000",
         "--ctrl", f"shaft=steps({steps_path})", "--log", heat_log] + sets(DRIVES[2][2]))
    _, heat = mp.read_csv(heat_log)

    # 7. The video: SpreadCycle ramping through the resonances, a quarter of real time.
    run(["run", model, "--duration", "1.2", "--quiet", "--ctrl", "shaft=ramp(0rpm,240rpm,1.2s)",
         "--render", os.path.join(RENDERS, "belt_axis.mp4"), "--camera", "front", "--size",
         "640x480", "--fps", "30", "--playback", "0.25"] + sets(DRIVES[1][2]))

    # Figures.
    names = {key: label for key, label, _ in DRIVES}
    fig, axes = mp.plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for ax, key in zip(axes, ("pi", "spreadcycle", "stealthchop")):
        t, ia, ref = rip[key + "_trace"]
        ax.plot(t, ia, lw=0.7, label="ia")
        ax.plot(t, ref, lw=0.7, ls="--", label="ia* (table / reference)")
        ax.set_ylabel("A")
        ax.set_title(names[key], fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[-1].set_xlabel("time (ms), 60 r/min")
    fig.tight_layout()
    mp.save(fig, os.path.join(RENDERS, "current_ripple.png"))

    fig, ax = mp.plt.subplots(figsize=(9, 5))
    for key, label, _ in DRIVES:
        c = sweeps[key]
        ax.plot(c["speed[r/min]"], c["velocity_error_peak_to_peak[r/min]"], marker=".", lw=1,
                label=label)
    for h in (4, 2, 1):
        n = 60 * fn / (h * 50)
        if n <= 480:
            ax.axvline(n, color="grey", lw=0.6, ls=":")
            ax.text(n, ax.get_ylim()[1] * 0.95, f" h={h}", fontsize=7, color="grey")
    ax.legend(fontsize=8)
    mp.finish(fig, ax, "commanded speed (r/min)", "velocity error, peak to peak (r/min)",
              f"belt axis, {MOTOR}: velocity ripple through the rotor's resonance ({fn:.0f} Hz)",
              os.path.join(RENDERS, "velocity_ripple.png"))

    fig, ax = mp.plt.subplots(figsize=(9, 5))
    for key, label, _ in DRIVES:
        c = pullouts[key]
        ax.plot(c["speed[r/min]"], c["pull_out_torque[N·m]"], marker=".", lw=1, label=label)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    mp.finish(fig, ax, "speed (r/min)", "pull-out torque (N·m)",
              f"belt axis, {MOTOR}, 24 V: pull-out torque", os.path.join(RENDERS, "pullout.png"))

    fig, ax = mp.plt.subplots(figsize=(9, 4.5))
    th = [t / 60 for t in heat["time[s]"]]
    ax.plot(th, col(heat, "winding_temperature"), label="winding")
    ax.plot(th, col(heat, "housing_temperature"), label="housing")
    ax.legend(fontsize=8)
    mp.finish(fig, ax, "time (min)", "temperature (°C)",
              "StealthChop duty cycle (60 r/min back and forth, 80 % moving)",
              os.path.join(RENDERS, "temperature.png"))

    # The page.
    def worst(c):
        e = c["velocity_error_peak_to_peak[r/min]"]
        k = max(range(len(e)), key=lambda i: e[i])
        return e[k], c["speed[r/min]"][k]

    def at(c, rpm, column):
        k = min(range(len(c["speed[r/min]"])), key=lambda i: abs(c["speed[r/min]"][i] - rpm))
        return c[column][k]

    def unstable(c):
        lost = [f"{n:.0f}" for n, k in zip(c["speed[r/min]"], c["lost_steps[full steps]"]) if k]
        return ", ".join(lost) if lost else "none"

    rows = []
    for key, label, _ in DRIVES:
        peak, where = worst(sweeps[key])
        rows.append(
            f"| {label} | {rip[key][0]:.4f} | {rip[key][1]:.4f} | {peak:.1f} at {where:.0f} | "
            f"{unstable(sweeps[key])} | {at(pullouts[key], 60, 'pull_out_torque[N·m]'):.3f} | "
            f"{at(pullouts[key], 240, 'pull_out_torque[N·m]'):.3f} | "
            f"{at(pullouts[key], 480, 'pull_out_torque[N·m]'):.3f} |")
    lags = "\n".join(
        f"| {rpm} | {lag[('stealthchop', rpm)]:.2f} | {lag[('spreadcycle', rpm)]:.2f} | "
        f"{lag[('stealthchop', rpm)] - lag[('spreadcycle', rpm)]:.2f} |"
        for rpm in (60, 120, 240))
    tw = col(heat, "winding_temperature")
    elapsed = time.time() - start
    page = f"""# Drivers study: the belt axis on a catalogue motor under four drives

Regenerated by `bash scripts/study.sh` (the main job), or alone by
`.venv/bin/python src/tools/python/study_drivers.py` after the build (it prints its wall time).
Logs in `logs/drivers/`, figures and video in `renders/drivers/`.
{run_conditions(model, heat_model)}

## Setup

`models/belt_axis.xml` (a GT2 belt, 20-tooth pulley, 0.5 kg carriage; see `models/README.md`) with
its stepper replaced by a Trinamic QSH4218-51 (`motor={MOTOR}`: NEMA 17, 1.8°, 1.0 A, 0.49 N·m,
5.0 Ω, 8 mH, 68 g·cm² as the actuator's armature, B = 1e-4 N·m·s/rad), a printer's 24 V bus and
the same 1.41 A peak current under four drives (`--set shaft.…`):

| drive | settings |
|---|---|
""" + "\n".join(f"| {label} | `{' '.join(settings)}` |" for _, label, settings in DRIVES) + f"""

The TMC2209 drives take STEP/DIR at 16 microsteps with MicroPlyer interpolation (`input=steps`: the
runner turns each profile into microstep counts); the PI and ideal drives take the speed (`input`
velocity, as the model ships). The rotor on the belt rings at fn = {fn:.1f} Hz (`mjstepper info`:
the rotor with the carriage on its belt, T' at the rest current), so the detent's harmonic h
(Kd4 = 0.028 N·m from the datasheet) excites it at n_h = 60·fn/(h·Nr) = {60 * fn / 200:.0f},
{60 * fn / 100:.0f}, {60 * fn / 50:.0f} r/min for h = 4, 2, 1 (SPEC §1), and the full-step rate
(200·n/60 Hz) at n = {60 * fn / 200:.0f} r/min as well.

## Results

| drive | ia − ia* RMS at 60 r/min, ripple and lag (A) | its peak to peak (A) | worst velocity ripple, p-p (r/min) at (r/min) | speeds losing steps unloaded, sweep (r/min) | pull-out at 60 r/min (N·m) | at 240 r/min | at 480 r/min |
|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + f"""

![phase current](../../renders/drivers/current_ripple.png)

Phase A against its table (or reference) at 60 r/min, 1 µs steps: SpreadCycle chops around the
table at its 30-40 kHz (t_OFF = 10 µs, TBL 32 clocks, HSTRT 5, HEND 0), its hysteresis band well
inside the 0.05 A a TMC2209's datasheet figure suggests; StealthChop applies the table's voltage,
so its current lags the table and is smooth (the PWM is averaged, S-15); the PI loop's current
follows its 20 kHz updates.

![velocity ripple](../../renders/drivers/velocity_ripple.png)

Velocity ripple through the speeds (constant-speed sweeps 10-480 r/min, 0.3 s settle, 0.3 s
measured), up to the speeds where the pull-out torque collapses: the mid band. The STEP/DIR drives
add the microstep staircase and MicroPlyer's interpolation to the detent's excitation; the dotted
lines mark n_h. A speed listed as losing steps is one where the unloaded rotor slipped in the
sweep: the mid-band instability of an open-loop drive.

![pull-out](../../renders/drivers/pullout.png)

Pull-out torque (a load rising at 0.5 N·m/s until the first slip): the chopper drives regulate the
current until the back-EMF and L·di/dt use up the 24 V; StealthChop's voltage-mode amplitude is
capped at 255/256·248/256 of the bus, and its current falls behind the table at speed.

### StealthChop's lag

Rotor behind the commanded position at constant speed (mean over the last 0.3 s of a 0.8 s run),
in full steps:

| speed (r/min) | StealthChop | SpreadCycle | StealthChop's increase |
|---|---|---|---|
{lags}

Klipper's documentation (TMC_Drivers.md) states StealthChop's lag as an increase over SpreadCycle:
"an increased 'positional lag' of around 75% of a full-step during constant velocity moves"; the
last column is that increase here. It grows with speed from the voltage-mode current lag
atan(Nr·ω·L/R) (tests/core/stealth_chop_test.cc checks it against its closed form) on top of
the load angle both drives share.

### Sensorless homing

StealthChop with StallGuard4 (`sgthrs=40`: a stall when SG_RESULT ≤ 80 of 510) homing toward a
hard stop (a joint limit 5 mm away, reached after {contact * 1e3:.0f} ms at 20 mm/s): first stall
flag at {first_stall * 1e3:.0f} ms, {(first_stall - contact) * 1e3:.0f} ms after the contact, while
the belt stretches to the load angle the threshold sets. tests/plugin/homing_test.cc checks the
delay against its closed form and the repeatability over 16 runs for StallGuard2 and 4, and that
no stall is flagged at 5 r/min.

### Winding temperature over a 10-minute duty cycle

![temperature](../../renders/drivers/temperature.png)

StealthChop, 300 cycles of 0.8 s at 60 r/min forward, 0.2 s held, 0.8 s back, 0.2 s held, as a
step list of {300 * 2 * int(0.8 * rate)} microsteps (`--ctrl shaft=steps(FILE)`), from 25 °C
ambient: the winding reaches {tw[-1]:.1f} °C after 10 min (the housing
{col(heat, "housing_temperature")[-1]:.1f} °C); the network's time constants are the QSH4218
manual's 22/25 min (presets.cc), so this is far from steady state.

## Video

`renders/drivers/belt_axis.mp4`: SpreadCycle ramping 0 → 240 r/min in 1.2 s, a quarter of real time,
640×480.
"""
    write_whole(os.path.join(ROOT, "docs", "studies", "drivers.md"), page)
    print(f"drivers study done in {elapsed:.0f} s: docs/studies/drivers.md")


if __name__ == "__main__":
    main()
