#!/usr/bin/env python3
"""Fidelity per mode against the step, 50 µs to 2 ms (issue 30, item 3; docs/coupling.md).

The modes are the coupling (`consistent`, `substepped`) and the drive's fidelity (`switching`,
`averaged`, where the drive has an averaged form). Each measure is run by build/mjstepper on a
temporary model at each step of STEPS and in each mode, and compared with the same measure at
10 µs, consistent, switching (the reference):

  - pull-out of a 17HS19-2004S1 on a TMC2209 (SpreadCycle, 24 V, velocity input; a 1e-5 kg·m²
    body on its 8.2e-6 kg·m² armature, joint damping 1e-4 N·m·s/rad) at 300 r/min:
    `pullout --speeds 300rpm` (the load rising at 0.5 N·m/s). Target 2 %.
  - pull-out of the Tsui PI drive (models/tsui_rigid.xml) at 120 r/min. Target 2 %.
  - Tsui's servo (models/tsui_rigid.xml with drive servo and every harmonic compensated): the
    rotor's speed ripple, RMS about its mean over 0.6-1 s at 90 r/min (ramped over 0.3 s).
    Target 5 %.
  - StealthChop's lag behind STEP/DIR at 120 r/min (models/belt_axis.xml with the QSH4218-51 on a
    TMC2209 in StealthChop, tests/tools/runner_test.cc's set-up): the mean position error from
    0.5 s to 0.8 s in full steps. Target 5 %.
  - Voltage microstepping on Kim's set-up (models/kim_stmms.xml with drive voltage_microstep at
    a 20 kHz clock): the mean load angle over the cruise, 1-2 s. Target 2 %.
  - Kim's STMMS on his set-up (models/kim_stmms.xml: 1 MHz, no current feedback): the peak
    tracking error |e1| over the trajectory's first 3 s. Target 2 %.
  - The CoreXY after a move (models/corexy.xml; tests/tools/averaged_printer_test.cc's move, 1600
    microsteps on both motors and one more 2 ms after it, so that it stops where both phases
    chop): stepper_a's rotor speed RMS from 0.35 s (the reference lacks any oscillation; a mode
    passes when it is at most twice the reference's), and the toolhead's ringing, the RMS of its
    ADXL345 x 20-120 ms after the move less the sensor's own noise (the same run with the motors
    still, subtracted sample by sample). Target 5 %.

Coarse steps run with --allow-coarse: the point is to measure where each mode holds.
Writes renders/coupling/fidelity_modes.csv and fidelity_modes.png (each through a temporary
renamed into place) and prints, per measure and mode, the largest step within the target.
Two simulations at a time. Run from the repository:
    .venv/bin/python src/tools/python/fidelity_modes.py
"""
import concurrent.futures
import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
CLI = os.path.join(ROOT, "build", "mjstepper")
OUT = os.path.join(ROOT, "renders", "coupling")
STEPS = [5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3]  # s
REFERENCE_STEP = 1e-5  # s
MODES = [("consistent", "switching"), ("consistent", "averaged"),
         ("substepped", "switching"), ("substepped", "averaged")]


def read(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def with_timestep(xml, h):
    xml, n = re.subn(r'timestep="[^"]*"', f'timestep="{h!r}"', xml, count=1)
    assert n == 1, "no timestep in the model"
    return xml


def write_model(xml, h, tmp, tag, replacements=()):
    """Writes xml at timestep h, each (old, new) replaced once, to tmp/tag.xml; returns the path."""
    for old, new in replacements:
        assert old in xml, old
        xml = xml.replace(old, new, 1)
    model = os.path.join(tmp, f"{tag}.xml")
    with open(model, "w", encoding="utf-8") as f:
        f.write(with_timestep(xml, h))
    return model


def cli(args, cwd):
    """Runs mjstepper; returns its stdout, or raises with its stderr."""
    proc = subprocess.run([CLI] + args, cwd=cwd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"mjstepper {' '.join(args[:2])}: {proc.stderr.strip()}")
    return proc.stdout


def columns(path, names, t0=-math.inf, t1=math.inf):
    """The named columns of a log (by prefix) for rows with t0 <= time < t1."""
    with open(path, encoding="utf-8") as f:
        rows = csv.reader(f)
        header = next(rows)
        index = [next(i for i, h in enumerate(header) if h.startswith(n)) for n in names]
        out = [[] for _ in names]
        for row in rows:
            t = float(row[0])
            if t0 <= t < t1:
                for k, i in enumerate(index):
                    out[k].append(float(row[i]))
    return out


def mean(x):
    return sum(x) / len(x)


def rms_about_mean(x):
    m = mean(x)
    return math.sqrt(sum((v - m) ** 2 for v in x) / len(x))


BENCH_17HS19 = """<mujoco model="bench17">
  <option timestep="1e-3" integrator="implicitfast"/>
  <extension><plugin plugin="mjstepper.stepper"/></extension>
  <worldbody><body><joint name="j1" type="hinge" axis="0 0 1" damping="1e-4"/>
    <inertial pos="0 0 0" mass="0.1" diaginertia="1e-5 1e-5 1e-5"/></body></worldbody>
  <actuator><plugin name="m1" joint="j1" plugin="mjstepper.stepper" armature="8.2e-6">
    <config key="motor" value="17hs19_2004s1"/><config key="driver" value="tmc2209"/>
    <config key="input" value="velocity"/><config key="heat" value="off"/></plugin>
  </actuator>
</mujoco>
"""


def pullout(xml, actuator, speed, h, coupling, fidelity, tmp, tag):
    model = write_model(xml, h, tmp, tag)
    prefix = os.path.join(tmp, tag)
    cli(["pullout", model, "--speeds", speed, "--quiet", "--allow-coarse", "--threads", "1",
         "--out", prefix, "--set", f"{actuator}.coupling={coupling}",
         "--set", f"{actuator}.fidelity={fidelity}"], tmp)
    (torque,) = columns(prefix + ".csv", ["pull_out_torque"])
    return torque[0]


def pullout_17hs19(h, coupling, fidelity, tmp, tag):
    return pullout(BENCH_17HS19, "m1", "300rpm", h, coupling, fidelity, tmp, tag)


def pullout_tsui(h, coupling, fidelity, tmp, tag):
    xml = read(os.path.join(ROOT, "models", "tsui_rigid.xml"))
    return pullout(xml, "shaft", "120rpm", h, coupling, fidelity, tmp, tag)


def servo_tsui(h, coupling, fidelity, tmp, tag):
    model = write_model(read(os.path.join(ROOT, "models", "tsui_rigid.xml")), h, tmp, tag)
    log = os.path.join(tmp, f"{tag}.csv")
    args = ["run", model, "--allow-coarse", "--duration", "1", "--quiet",
            "--ctrl", "shaft=ramp(0rpm,90rpm,0.3s)", "--log", log]
    for s in ["drive=servo", "damping=all", f"coupling={coupling}", f"fidelity={fidelity}"]:
        args += ["--set", f"shaft.{s}"]
    cli(args, tmp)
    (omega,) = columns(log, ["shaft:omega["], 0.6)
    return rms_about_mean(omega)


def stealthchop_lag(h, coupling, fidelity, tmp, tag):
    model = write_model(read(os.path.join(ROOT, "models", "belt_axis.xml")), h, tmp, tag, [
        ('armature="0.36e-4"', 'armature="68e-7"'), ('damping="0.001">', 'damping="1e-4">'),
        ('<config key="motor" value="tsui2009"/>', '<config key="motor" value="qsh4218_51"/>')])
    log = os.path.join(tmp, f"{tag}.csv")
    args = ["run", model, "--allow-coarse", "--duration", "0.8", "--quiet",
            "--ctrl", "shaft=ramp(0rpm,120rpm,0.2s)", "--log", log]
    for s in ["driver=tmc2209", "drive=stealthchop", "input=steps", "run_current=1.0",
              f"coupling={coupling}", f"fidelity={fidelity}"]:
        args += ["--set", f"shaft.{s}"]
    cli(args, tmp)
    (error,) = columns(log, ["shaft:position_error"], 0.5)
    return -mean(error) / (2 * math.pi / 200)  # full steps behind


def kim_voltage(h, coupling, fidelity, tmp, tag):
    model = write_model(read(os.path.join(ROOT, "models", "kim_stmms.xml")), h, tmp, tag, [
        ('value="stmms"', 'value="voltage_microstep"'),
        ('<config key="isr_period" value="1e-6"/>', '<config key="isr_period" value="5e-5"/>')])
    log = os.path.join(tmp, f"{tag}.csv")
    cli(["run", model, "--allow-coarse", "--duration", "2", "--quiet", "--log", log,
         "--ctrl", "shaft=constant(15.70796rad)", "--set", f"shaft.coupling={coupling}",
         "--set", f"shaft.fidelity={fidelity}"], tmp)
    (angle,) = columns(log, ["shaft:load_angle"], 1.0)
    return mean(angle)


def kim_stmms(h, coupling, fidelity, tmp, tag):
    """Kim's STMMS on his trajectory (models/kim_stmms.xml, 1 MHz): the peak tracking error |e1|."""
    model = write_model(read(os.path.join(ROOT, "models", "kim_stmms.xml")), h, tmp, tag)
    log = os.path.join(tmp, f"{tag}.csv")
    cli(["run", model, "--allow-coarse", "--duration", "3", "--quiet", "--log", log,
         "--log-every", str(max(1, round(1e-4 / h))), "--ctrl", "shaft=constant(15.70796rad)",
         "--set", f"shaft.coupling={coupling}", "--set", f"shaft.fidelity={fidelity}"], tmp)
    (error,) = columns(log, ["shaft:position_error"])
    return max(abs(e) for e in error)


# The CoreXY move (tests/tools/averaged_printer_test.cc): X by 20 mm at 100 mm/s and 3000 mm/s²
# in 1600 microsteps from 0.05 s, and one more 2 ms after it.
MOVE_START, MOVE_SPEED, MOVE_ACCEL, MOVE_DISTANCE, STEPS_PER_MM = 0.05, 100.0, 3000.0, 20.0, 80


def move_times():
    ta = MOVE_SPEED / MOVE_ACCEL
    da = 0.5 * MOVE_ACCEL * ta * ta
    tc = (MOVE_DISTANCE - 2 * da) / MOVE_SPEED
    total = 2 * ta + tc

    def position(t):
        if t < ta:
            return 0.5 * MOVE_ACCEL * t * t
        if t < ta + tc:
            return da + MOVE_SPEED * (t - ta)
        u = t - ta - tc
        return da + MOVE_SPEED * tc + MOVE_SPEED * u - 0.5 * MOVE_ACCEL * u * u

    times = []
    for k in range(1, int(MOVE_DISTANCE * STEPS_PER_MM) + 1):
        lo, hi = 0.0, total
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if position(mid) < k / STEPS_PER_MM:
                lo = mid
            else:
                hi = mid
        times.append(MOVE_START + hi)
    times.append(MOVE_START + total + 0.002)
    return times, MOVE_START + total


def accel_x(path):
    samples = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                continue
            t, x = line.split(",")[:2]
            samples[round(float(t), 7)] = float(x)
    return samples


def corexy(h, coupling, fidelity, tmp, tag):
    """(rotor speed RMS after the move, ringing less the sensor's noise)."""
    steps = os.path.join(tmp, "move.txt")
    times, end = move_times()
    if not os.path.exists(steps):
        with open(steps, "w", encoding="utf-8") as f:
            f.write("".join(f"{t:.12f}\n" for t in times))
    model = write_model(read(os.path.join(ROOT, "models", "corexy.xml")), h, tmp, tag)
    noise = os.path.join(tmp, f"{tag}_noise.csv")
    cli(["run", model, "--allow-coarse", "--duration", "0.7", "--quiet", "--accel-log", noise],
        tmp)
    log, accel = os.path.join(tmp, f"{tag}.csv"), os.path.join(tmp, f"{tag}_accel.csv")
    args = ["run", model, "--allow-coarse", "--duration", "0.7", "--quiet", "--log", log,
            "--log-every", str(max(1, round(1e-4 / h))), "--accel-log", accel]
    for s in ["stepper_a", "stepper_b"]:
        args += ["--ctrl", f"{s}=steps({steps})", "--set", f"{s}.coupling={coupling}",
                 "--set", f"{s}.fidelity={fidelity}"]
    cli(args, tmp)
    (omega,) = columns(log, ["stepper_a:omega["], 0.35)
    still, moved = accel_x(noise), accel_x(accel)
    ring = [moved[t] - still[t] for t in moved if end + 0.02 <= t < end + 0.12 and t in still]
    return rms_about_mean(omega), math.sqrt(sum(v * v for v in ring) / len(ring))


# (name, target fraction, function, fidelities it has, unit)
MEASURES = [
    ("pull-out, 17HS19 on a TMC2209 at 300 r/min", 0.02, pullout_17hs19,
     ("switching", "averaged"), "N·m"),
    ("pull-out, Tsui PI drive at 120 r/min", 0.02, pullout_tsui, ("switching", "averaged"),
     "N·m"),
    ("Tsui servo, damped: speed ripple at 90 r/min", 0.05, servo_tsui,
     ("switching", "averaged"), "rad/s"),
    ("StealthChop's lag at 120 r/min", 0.05, stealthchop_lag, ("switching", "averaged"),
     "full steps"),
    ("voltage microstepping (Kim): load angle in cruise", 0.02, kim_voltage,
     ("switching", "averaged"), "rad"),
    ("Kim's STMMS: peak tracking error |e1|", 0.02, kim_stmms, ("switching", "averaged"),
     "rad"),
    ("CoreXY after a move: ringing less the sensor's noise", 0.05, None,
     ("switching", "averaged"), "mm/s²"),
    ("CoreXY after a move: rotor speed RMS (pass: <= 2× the reference)", None, None,
     ("switching", "averaged"), "rad/s"),
]


def run_all(tmp):
    jobs = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        for m, (name, _, fn, fidelities, _) in enumerate(MEASURES):
            if fn is None:
                continue
            jobs[(m, "reference")] = pool.submit(fn, REFERENCE_STEP, "consistent", "switching",
                                                 tmp, f"m{m}_ref")
            for coupling, fidelity in MODES:
                if fidelity not in fidelities:
                    continue
                for h in STEPS:
                    tag = f"m{m}_{coupling}_{fidelity}_{h!r}"
                    jobs[(m, coupling, fidelity, h)] = pool.submit(fn, h, coupling, fidelity, tmp,
                                                                   tag)
        corexy_dir = os.path.join(tmp, "corexy")
        os.makedirs(corexy_dir)
        jobs["corexy", "reference"] = pool.submit(corexy, REFERENCE_STEP, "consistent",
                                                  "switching", corexy_dir, "ref")
        for coupling, fidelity in MODES:
            for h in STEPS:
                jobs["corexy", coupling, fidelity, h] = pool.submit(
                    corexy, h, coupling, fidelity, corexy_dir, f"{coupling}_{fidelity}_{h!r}")
        results = {}
        for key, job in jobs.items():
            try:
                results[key] = job.result()
            except RuntimeError as e:
                print(f"  {key}: {e}", file=sys.stderr)
                results[key] = None
    # The CoreXY's two measures, the last two of MEASURES (corexy returns them rotor first).
    ringing, rotor = len(MEASURES) - 2, len(MEASURES) - 1
    for key in list(results):
        if key[0] == "corexy":
            value = results.pop(key)
            results[(ringing,) + key[1:]] = None if value is None else value[1]
            results[(rotor,) + key[1:]] = None if value is None else value[0]
    return results


def rows(results):
    out = []
    for m, (name, target, _, fidelities, unit) in enumerate(MEASURES):
        reference = results.get((m, "reference"))
        for coupling, fidelity in MODES:
            if fidelity not in fidelities:
                continue
            for h in STEPS:
                value = results.get((m, coupling, fidelity, h))
                if value is None or not reference:  # no run, or a reference of 0
                    error, passed = math.nan, False
                elif target is None:  # an oscillation the reference lacks
                    error = value / reference
                    passed = error <= 2
                else:
                    error = value / reference - 1
                    passed = abs(error) <= target
                out.append({"measure": name, "unit": unit, "coupling": coupling,
                            "fidelity": fidelity, "timestep_s": h, "value": value,
                            "reference": reference, "error": error, "passes": passed})
    return out


def write_csv(table, path):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    os.replace(tmp, path)


def plot(table, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 4, figsize=(20, 8.5))
    for ax in axes.flat[len(MEASURES):]:
        ax.set_visible(False)
    styles = {("consistent", "switching"): ("C0", "-", "o"),
              ("consistent", "averaged"): ("C0", "--", "s"),
              ("substepped", "switching"): ("C3", "-", "o"),
              ("substepped", "averaged"): ("C3", "--", "s")}
    for ax, (m, (name, target, _, _, _)) in zip(axes.flat, enumerate(MEASURES)):
        for (coupling, fidelity), (color, line, marker) in styles.items():
            points = [r for r in table if r["measure"] == name and r["coupling"] == coupling
                      and r["fidelity"] == fidelity and not math.isnan(r["error"])]
            if not points:
                continue
            x = [r["timestep_s"] * 1e3 for r in points]
            y = [r["error"] * (100 if target is not None else 1) for r in points]
            ax.plot(x, y, color=color, linestyle=line, marker=marker,
                    label=f"{coupling}, {fidelity}")
        if target is not None:
            ax.axhspan(-100 * target, 100 * target, color="0.9", zorder=0)
            ax.set_ylabel("error against 10 µs switching (%)")
            ax.set_ylim(-max(20, 300 * target), max(20, 300 * target))
        else:
            ax.axhline(2, color="0.5", linestyle=":")
            ax.set_yscale("log")
            ax.set_ylabel("× the reference's")
        ax.set_xscale("log")
        ax.set_xlabel("timestep (ms)")
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("Fidelity per mode against the step (grey: the issue's target), "
                 "src/tools/python/fidelity_modes.py", fontsize=10)
    fig.tight_layout()
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)


def main():
    start = time.monotonic()
    if not os.path.exists(CLI):
        sys.exit(f"fidelity_modes.py: build first ({CLI} is missing)")
    os.makedirs(OUT, exist_ok=True)
    # FIDELITY_MODES_CACHE=FILE keeps the raw results (a JSON list), so that the table and the plot
    # can be remade without the runs.
    cache = os.environ.get("FIDELITY_MODES_CACHE")
    if cache and os.path.exists(cache):
        with open(cache, encoding="utf-8") as f:
            results = {tuple(k): v for k, v in json.load(f)}
    else:
        with tempfile.TemporaryDirectory() as tmp:
            results = run_all(tmp)
        if cache:
            with open(cache, "w", encoding="utf-8") as f:
                json.dump([[list(k), v] for k, v in results.items()], f)
    for m, (name, *_rest) in enumerate(MEASURES):
        print(f"reference ({name}): {results.get((m, 'reference'))}")
    table = rows(results)
    write_csv(table, os.path.join(OUT, "fidelity_modes.csv"))
    plot(table, os.path.join(OUT, "fidelity_modes.png"))
    for name, target, _, _, unit in MEASURES:
        reference = next((r["reference"] for r in table if r["measure"] == name), None)
        print(f"{name} (reference {reference!r} {unit}):")
        for coupling, fidelity in MODES:
            points = [r for r in table if r["measure"] == name and r["coupling"] == coupling
                      and r["fidelity"] == fidelity]
            if not points:
                continue
            held = [r["timestep_s"] for r in points if r["passes"]]
            errors = "  ".join(
                f"{r['timestep_s'] * 1e3:g} ms " +
                (f"{100 * r['error']:+.1f} %" if target is not None else f"{r['error']:.2f}×")
                for r in points)
            print(f"  {coupling:10s} {fidelity:9s} {errors}")
    print(f"wrote {os.path.relpath(OUT, ROOT)}/fidelity_modes.csv and fidelity_modes.png in "
          f"{time.monotonic() - start:.0f} s")


if __name__ == "__main__":
    main()
