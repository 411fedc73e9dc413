"""Constant-speed sweeps as Ray tasks: the resonance map of `mjstepper sweep`, beyond one machine.

Each run is the C++ sweep's (src/tools/sweep.cc, RunOne) step for step: the same ramp command, the
same steps, the same metrics in the same order of operations, so the results match it to round-off
(tested to 1e-12). Runs are Ray tasks: on all local cores by default, on a cluster given its
address (every node needs this package; see docs/ray.md). `mjstepper.sweep` is this module's
`sweep`.
"""
import csv
import math
import os
import sys
import time

import mujoco

from . import add_signal_sensors, SIGNALS

HEADER = ("speed[r/min]", "speed[rad/s]", "velocity_error_rms[r/min]",
          "velocity_error_peak_to_peak[r/min]", "dominant_frequency[Hz]",
          "lost_steps[full steps]")
RPM = 60 / (2 * math.pi)


def _ramp_angle(t, speed, ramp):
    """CommandProfile::Angle of ramp(0, speed, ramp) (src/core/command_profile.cc)."""
    if t <= 0:
        return 0.0 * t
    tr = min(t, ramp)
    return 0.0 * tr + 0.5 * (speed - 0.0) * tr * tr / ramp + speed * (t - tr)


def _ramp_speed(t, speed, ramp):
    return 0.0 if t <= 0 else speed if t >= ramp else 0.0 + (speed - 0.0) * t / ramp


def _dominant_frequency(x, sample_rate, f_min, f_max, df):
    """core/analysis.cc DominantFrequency: Goertzel power on a grid, refined by a parabola."""
    import numpy as np
    mean = sum(x) / len(x)  # summed in order, as std::accumulate
    freqs = []
    f = f_min
    while f <= f_max + 1e-9 * df:
        freqs.append(f)
        f += df
    # libm's cos, as the C++ (numpy's vectorised cos may differ in the last bit)
    coefficient = np.array([2 * math.cos(2 * math.pi * f / sample_rate) for f in freqs])
    s1 = np.zeros(len(freqs))
    s2 = np.zeros(len(freqs))
    for v in x:
        s0 = (v - mean) + coefficient * s1 - s2
        s2 = s1
        s1 = s0
    power = s1 * s1 + s2 * s2 - coefficient * s1 * s2
    k = int(np.argmax(power))
    offset = 0.0
    if 0 < k < len(power) - 1:
        a, b, c = power[k - 1], power[k], power[k + 1]
        denominator = a - 2 * b + c
        if denominator < 0:
            offset = 0.5 * (a - c) / denominator
    return f_min + (k + offset) * df


def _set_parameter(model, parameter, value):
    """`mjstepper map`'s edit of the compiled model (src/tools/sweep.cc WithParameter):
    stiffness:JOINT sets the joint's stiffness; mass:BODY sets the body's mass, scales its inertia
    with it and recomputes MuJoCo's constants (stepper_model.cc SetBodyMass)."""
    kind, _, name = parameter.partition(":")
    if kind == "stiffness":
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint < 0:
            raise ValueError(f"{parameter}: no joint named {name!r}")
        model.jnt_stiffness[joint] = value
    elif kind == "mass":
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if body <= 0:
            raise ValueError(f"{parameter}: no body named {name!r}")
        scale = value / model.body_mass[body]
        model.body_mass[body] = value
        model.body_inertia[body] *= scale
        mujoco.mj_setConst(model, mujoco.MjData(model))
    else:
        raise ValueError(f"{parameter}: expected stiffness:JOINT or mass:BODY")


def run_one(xml, actuator, speed, settle, measure, acceleration, parameter=None, value=None):
    """One run of the C++ sweep (ramp to `speed` rad/s, settle, measure): the sweep's CSV row.
    With `parameter` ("stiffness:JOINT" or "mass:BODY"), the model is first edited as
    `mjstepper map` edits it."""
    spec = mujoco.MjSpec.from_string(xml)
    add_signal_sensors(spec)
    model = spec.compile()
    if parameter is not None:
        _set_parameter(model, parameter, value)
    data = mujoco.MjData(model)
    aid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator)
    ctrladr, outadr = model.actuator_ctrladr[aid], model.actuator_outadr[aid]
    mujoco.mj_forward(model, data)
    ramp = max(abs(speed) / acceleration, 1e-6)
    h = model.opt.timestep
    start = math.floor((ramp + settle) / h + 0.5)
    steps = start + math.floor(measure / h + 0.5)
    error = []
    for k in range(steps):
        t = data.time
        # CommandProfile::ControlForStep for velocity input: the mean speed over the step.
        data.ctrl[ctrladr] = (_ramp_angle(t + h, speed, ramp) - _ramp_angle(t, speed, ramp)) / h
        mujoco.mj_step(model, data)
        if k >= start:
            error.append(data.actuator_velocity[outadr] - _ramp_speed(t, speed, ramp))
    rms = math.sqrt(sum(e * e for e in error) / len(error))
    peak_to_peak = max(error) - min(error)
    frequency = _dominant_frequency(error, 1.0 / h, 5.0, 1000.0, 0.5)
    lost = float(data.sensor(f"mjstepper:{actuator}").data[SIGNALS.index("lost_steps")])
    return (speed * RPM, speed, rms * RPM, peak_to_peak * RPM, frequency, lost)


def _run_grid(model, runs, actuator, settle, measure, acceleration, address, progress, what):
    """Runs `runs` ((speed, parameter, value) each) as Ray tasks; their rows in order."""
    import ray
    with open(model) as f:
        xml = f.read()
    if actuator is None:
        probe = mujoco.MjSpec.from_string(xml)
        names = [a.name for a in probe.actuators if a.plugin.active]
        if len(names) != 1:
            raise ValueError(f"name the stepper to sweep: actuator= one of {names}")
        actuator = names[0]
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    task = ray.remote(run_one)
    pending = [task.remote(xml, actuator, float(speed), settle, measure, acceleration, parameter,
                           value) for speed, parameter, value in runs]
    order = {ref: i for i, ref in enumerate(pending)}
    rows = [None] * len(pending)
    begin = time.time()
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        for ref in done:
            rows[order[ref]] = ray.get(ref)
        if progress:
            print(f"\r  {what} on Ray: {len(rows) - len(pending)}/{len(rows)} runs "
                  f"({time.time() - begin:.0f} s)", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return rows


def _write_csv(out, header, rows):
    """Every digit, written to out.tmp and renamed when complete."""
    tmp = out + ".tmp"
    with open(tmp, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([repr(float(v)) for v in row] for row in rows)
    os.replace(tmp, out)


def sweep(model, speeds, actuator=None, settle=0.4, measure=0.5, acceleration=209.44,
          address=None, out=None, progress=True):
    """Runs the constant-speed sweep of `model` (an MJCF path) at `speeds` (rad/s) as Ray tasks and
    returns its rows (the C++ sweep's CSV columns), written to `out` (CSV) if given.

    address: None runs a local Ray on all cores; "auto" or "ray://host:10001" joins a cluster.
    """
    rows = _run_grid(model, [(s, None, None) for s in speeds], actuator, settle, measure,
                     acceleration, address, progress, "sweep")
    if out is not None:
        _write_csv(out, HEADER, rows)
    return rows


def resonance_map(model, speeds, parameter, values, actuator=None, settle=0.4, measure=0.5,
                  acceleration=209.44, address=None, out=None, progress=True):
    """`mjstepper map` as Ray tasks: the sweep over speeds (rad/s) × values of one load parameter
    ("stiffness:JOINT" in N·m/rad or N/m, "mass:BODY" in kg). Rows are the C++ map's CSV
    columns: the value, then the sweep's; written to `out` (CSV) if given."""
    runs = [(s, parameter, v) for v in values for s in speeds]
    rows = _run_grid(model, runs, actuator, settle, measure, acceleration, address, progress,
                     "map")
    rows = [(value,) + row for (_, _, value), row in zip(runs, rows)]
    if out is not None:
        _write_csv(out, (parameter,) + HEADER, rows)
    return rows
