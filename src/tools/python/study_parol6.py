"""The real PAROL6 study (issue 29, item 8): models/parol6.xml, PAROL6 as its builders own it
(URDF masses, gear trains, BOM motors, TMC5160s in StealthChop at the firmware's run and hold
currents), answers three questions with the mjstepper command:
  1. the sizing of a pick-and-place cycle with its 0.5 kg rated payload: each joint's margin at
     the worst point, lost steps, and the winding after 100 cycles, with the firmware's hold
     current (IHOLD) and without it (ihold = IRUN: the drives hold at the run current);
  2. the payload at which each joint first slips, holding the standby pose and running the cycle,
     settled (gravity ramped in while the drives hold, the default) and aligned (gravity at full
     strength on the rotors at t = 0), against PAROL6's rating of 1 kg near the base and 0.5 kg
     over the whole workspace;
  3. the pull-out curves of the joints, renders/parol6/built_jN.png.
Writes docs/studies/parol6.md and renders/parol6/.

    .venv/bin/python src/tools/python/study_parol6.py      (bash scripts/study.sh runs it)
"""
import concurrent.futures
import csv
import os
import tempfile
import time

from study_common import ROOT, cli, move_args, read_table, run_conditions

MODEL = "models/parol6.xml"
JOINTS = ["j1", "j2", "j3", "j4", "j5", "j6"]
IRUN = 31  # every joint's run current scale on our TMC5160 (GLOBALSCALER scales the rest)

# The cycle, joint angles in degrees from the standby pose (qpos0): over the pick, down to it, over
# the place (base turned 90°, tool rolled 90°), down to it, back to standby. J4 holds.
POSES = {
    "j1": [-45, -45, 45, 45, 0],
    "j2": [20, 35, 20, 35, 0],
    "j3": [25, 40, 25, 40, 0],
    "j5": [30, 10, 30, 10, 0],
    "j6": [0, 0, 90, 90, 0],
}
DWELL = 0.3  # s at each pose (the gripper's time)
CYCLES = 100
PAYLOAD = 0.5  # kg, PAROL6's rating over its whole workspace
PAYLOADS = [0.25 * k for k in range(1, 17)]  # kg, the slip scan: 0.25 to 4 kg
HOLD_TIME = 1.0  # s holding the standby pose


def size(out, payload, extra=(), cycles=CYCLES, points=12):
    cli(["size", MODEL, *move_args(POSES), "--dwell", str(DWELL), "--cycles", str(cycles),
         "--pullout-points", str(points), "--mass", f"payload={payload}", "--quiet", "--out", out,
         *extra])
    return read_table(os.path.join(ROOT, out + ".csv"))


def hold_lost(payload, start):
    """Each joint's lost steps holding the standby pose for HOLD_TIME with `payload`."""
    with tempfile.TemporaryDirectory() as scratch:
        log = os.path.join(scratch, "hold.csv")
        cli(["run", MODEL, "--duration", str(HOLD_TIME), "--mass", f"payload={payload}",
             "--start", start, "--quiet", "--log", log, "--log-every", "100"])
        with open(log, newline="") as f:
            rows = list(csv.DictReader(f))
    return {j: abs(float(rows[-1][f"{j}:lost_steps[full steps]"])) for j in JOINTS}


def cycle_lost(payload, start):
    """Each joint's lost steps in one cycle with `payload` (a coarse bench: only the lost steps are
    read)."""
    with tempfile.TemporaryDirectory() as scratch:
        table = size(os.path.join(scratch, "cycle"), payload, ["--start", start], cycles=1,
                     points=3)
    return {j: abs(float(table[j]["lost_steps[full steps]"])) for j in JOINTS}


def first_slips(measure, start):
    """{joint: the least payload of PAYLOADS at which it lost a step, or None}, scanning on two
    workers."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda p: measure(p, start), PAYLOADS))
    first = {j: None for j in JOINTS}
    for payload, lost in zip(PAYLOADS, results):
        for j in JOINTS:
            if lost[j] != 0 and first[j] is None:
                first[j] = payload
    return first


def f(row, key):
    return float(row[key])


def kg(value):
    return f"{value:g} kg" if value is not None else f"> {PAYLOADS[-1]:g} kg"


def write_report(sized, no_ihold, slips, elapsed):
    lines = [
        "# The real PAROL6: sizing, slip payloads, heat with and without IHOLD",
        "",
        "Made by `src/tools/python/study_parol6.py` (`bash scripts/study.sh`, the main job) from "
        f"`mjstepper size` and `mjstepper run` on `models/parol6.xml`. The "
        "model is PAROL6 as its builders own it: the URDF's kinematics, masses and inertias, the "
        "firmware's gear ratios, the BOM's motors (17HS24-2104S on J1-J2, 17HS16-2004S1 on "
        "J3-J5, 17HS08-1004S on J6), TMC5160s in StealthChop at 32 microsteps with the firmware's "
        "run currents (1.70, 1.70, 1.60, 1.44, 1.44, 0.81 A RMS) and hold currents (IHOLD = "
        "0.69-0.88 of IRUN), belts and EG17 planetary gear trains with their friction and "
        "efficiency (models/README.md, \"Gear trains\"). The file cites every number and says "
        "which are estimates.",
        "",
        run_conditions(MODEL),
        "",
        "## 1. The pick-and-place cycle with the rated 0.5 kg",
        "",
        "Joint angles (deg from standby): " + "; ".join(
            f"{j} " + ", ".join(str(a) for a in POSES[j]) for j in POSES) +
        f"; J4 holds; {DWELL} s at each pose. Settled start (the default). Rotor-side torques; "
        "the margin is 1 − |τ|/T_po at the worst point of the move, against the pull-out curve of "
        "the joint's motor and drive on a bench of its reflected inertia "
        "(renders/parol6/built_jN.png); the winding after "
        f"{CYCLES} cycles from 25 °C with the firmware's IHOLD and with ihold = IRUN (no "
        "standstill reduction).",
        "",
        "| joint | motor | gear | top r/min | peak τ N·m | worst at r/min | τ N·m | T_po N·m | "
        f"margin | lost steps | winding after {CYCLES} cycles °C, IHOLD | without IHOLD | "
        "continuous °C, IHOLD | without |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for j in JOINTS:
        r, n = sized[j], no_ihold[j]
        lines.append(
            f"| {j} | {r['motor']} | {f(r, 'gear[rad/unit]'):.4g} | {f(r, 'peak_speed[rad/s]') * 60 / 6.283185307179586:.0f} | "
            f"{f(r, 'peak_torque[N·m]'):.4f} | {abs(f(r, 'worst_speed[rad/s]')) * 60 / 6.283185307179586:.0f} | "
            f"{abs(f(r, 'worst_torque[N·m]')):.4f} | {f(r, 'worst_pullout[N·m]'):.4f} | "
            f"{100 * f(r, 'margin[1]'):.1f} % | {f(r, 'lost_steps[full steps]'):+.0f} | "
            f"{f(r, 'winding_temperature_cycles[°C]'):.1f} | "
            f"{f(n, 'winding_temperature_cycles[°C]'):.1f} | "
            f"{f(r, 'winding_temperature_steady[°C]'):.1f} | "
            f"{f(n, 'winding_temperature_steady[°C]'):.1f} |")
    lines += [
        "",
        "A negative margin at a speed where the joint loses no step is a dip of the bench's "
        "pull-out curve (the drive's mid-speed resonance on the joint's reflected inertia: see "
        "the curves), which the move crosses in a few milliseconds: the cycle's own lost-step "
        "count is the answer for this move; the margin says where a slower transit would fail.",
        "",
        "## 2. The payload at which each joint first slips",
        "",
        f"Payloads {PAYLOADS[0]:g}-{PAYLOADS[-1]:g} kg in steps of 0.25 kg at the gripper "
        "(62.8 + 45.25 mm beyond the wrist centre). Holding: the standby pose for "
        f"{HOLD_TIME:g} s. Cycle: the cycle above, once. Settled: gravity ramped in over 0.3 s "
        "while the drives hold (a powered-up arm); aligned: gravity at full strength at t = 0 on "
        "rotors at their aligned angle.",
        "",
        "| joint | holding, settled | holding, aligned | cycle, settled | cycle, aligned |",
        "|---|---|---|---|---|",
    ]
    for j in JOINTS:
        lines.append(f"| {j} | {kg(slips['hold', 'settled'][j])} | {kg(slips['hold', 'aligned'][j])} "
                     f"| {kg(slips['cycle', 'settled'][j])} | {kg(slips['cycle', 'aligned'][j])} |")
    def least(key):
        values = [v for v in slips[key].values() if v is not None]
        return min(values) if values else None
    lines += [
        "",
        f"PAROL6's rating: 1 kg near the base, 0.5 kg over the whole workspace. The first slip "
        f"holding: {kg(least(('hold', 'settled')))} settled, {kg(least(('hold', 'aligned')))} "
        f"aligned; in the cycle: {kg(least(('cycle', 'settled')))} settled, "
        f"{kg(least(('cycle', 'aligned')))} aligned. The aligned start asks the motors to catch a "
        "dropped arm (the rotor overshoots to about twice its static load angle): its answers "
        "are the pessimistic ones a simulation without a settled start gives.",
        "",
    ]
    path = os.path.join(ROOT, "docs", "studies", "parol6.md")
    with open(path + ".tmp", "w") as out:
        out.write("\n".join(lines))
    os.replace(path + ".tmp", path)


def main():
    start = time.time()
    figures = os.path.join("renders", "parol6")
    os.makedirs(os.path.join(ROOT, figures), exist_ok=True)
    sized = size(os.path.join(figures, "built"), PAYLOAD)
    with tempfile.TemporaryDirectory() as scratch:
        no_ihold = size(os.path.join(scratch, "no_ihold"), PAYLOAD,
                        [a for j in JOINTS for a in ("--set", f"{j}.ihold={IRUN}")])
    slips = {}
    for start_mode in ("settled", "aligned"):
        slips["hold", start_mode] = first_slips(hold_lost, start_mode)
        slips["cycle", start_mode] = first_slips(cycle_lost, start_mode)
    write_report(sized, no_ihold, slips, time.time() - start)
    for entry in os.listdir(os.path.join(ROOT, figures)):
        if entry.endswith("_demand.csv"):
            os.remove(os.path.join(ROOT, figures, entry))
    print(f"study_parol6: docs/studies/parol6.md in {time.time() - start:.0f} s")


if __name__ == "__main__":
    main()
