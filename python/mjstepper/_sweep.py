"""Constant-speed sweeps as Ray tasks: the resonance map of `mjstepper sweep`, beyond one machine.

Each run is the C++ sweep's (src/tools/sweep.cc, RunOne) step for step: the same ramp command, the
same steps, the same metrics in the same order of operations, so the results match it to round-off
(tested to 1e-12). Runs are Ray tasks: on all local cores by default, on a cluster given its
address (every node needs this package; see docs/ray.md). `mjstepper.sweep` is this module's
`sweep`.
"""
import csv
import math
import numbers
import os
import stat
import sys
import tempfile
import time

import mujoco
import numpy as np

from . import _is_stepper, _stepper_id, _tables, add_signal_sensors, SIGNALS

# The bounds of every numeric argument: the C++ command's (`mjstepper sweep` and `map`), from its one
# range table (src/tools/options.cc, generated into _tables.py). Each is checked before any work,
# and a value outside them raises ValueError naming the argument, the value and the range.
_RANGES = _tables.OPTION_RANGES
SETTLE_RANGE = _RANGES["settle"][:2]  # s, closed
MEASURE_RANGE = _RANGES["measure"][:2]  # s, closed
MIN_MEASURED_STEPS = _tables.MIN_MEASURED_STEPS  # timesteps in `measure` (checked on the model)
# rad/s: every speed finite with 0 < |speed| <= MAX_SPEED (the command's bound; a speed of 0, which
# the command takes, would make this module's ramp of length 0 divide by zero)
MAX_SPEED = _RANGES["speed"][1]
MAX_SPEEDS = int(_RANGES["speeds"][1])  # speeds (times values, for a map) in one call
# A map's load parameter: its values (at least one) each finite, > 0 and <= its bound, in its unit.
PARAMETER_BOUNDS = {kind: (_RANGES[kind][1], _RANGES[kind][2]) for kind in ("stiffness", "mass")}

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


def _parameter_target(model, parameter):
    """(kind, id) of a load parameter, "stiffness:JOINT" or "mass:BODY", in a compiled model."""
    kind, _, name = parameter.partition(":")
    if kind == "stiffness":
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint < 0:
            raise ValueError(f"parameter = {parameter!r}: no joint named {name!r}")
        return kind, joint
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if body <= 0:
        raise ValueError(f"parameter = {parameter!r}: no body named {name!r} (other than the world)")
    if not model.body_mass[body] > 0:  # its inertia is scaled by value / mass
        raise ValueError(f"parameter = {parameter!r}: the body's mass in the model is "
                         f"{model.body_mass[body]} kg; a body without mass cannot be scaled")
    return kind, body


def _set_parameter(model, parameter, value):
    """`mjstepper map`'s edit of the compiled model (src/tools/sweep.cc WithParameter):
    stiffness:JOINT sets the joint's stiffness; mass:BODY sets the body's mass, scales its inertia
    with it and recomputes MuJoCo's constants (stepper_model.cc SetBodyMass)."""
    kind, target = _parameter_target(model, parameter)
    if kind == "stiffness":
        model.jnt_stiffness[target] = value
    else:
        scale = value / model.body_mass[target]
        model.body_mass[target] = value
        model.body_inertia[target] *= scale
        mujoco.mj_setConst(model, mujoco.MjData(model))


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


def _number(name, value, unit):
    """`value` as a float, if it is a real number (a bool is not); TypeError naming it if not."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} = {value!r} ({type(value).__name__}): expected a number ({unit})")
    return float(value)


def _in_range(name, value, unit, low, high):
    """`value` if it is a number in [low, high] (so finite); ValueError naming it if not."""
    v = _number(name, value, unit)
    if not low <= v <= high:
        raise ValueError(f"{name} = {v!r} {unit}: must be in [{low:g}, {high:g}] {unit}")
    return v


def _sequence(name, values, what, at_most=math.inf):
    """`values` as a list of 1 to `at_most` items; TypeError or ValueError naming it if not."""
    if isinstance(values, (str, bytes)):
        raise TypeError(f"{name} = {values!r}: expected a list of {what}, not a string")
    try:
        values = list(values)
    except TypeError:
        raise TypeError(f"{name} = {values!r}: expected a list of {what}") from None
    if not values:
        raise ValueError(f"{name} = []: no {what}; at least one is needed")
    if len(values) > at_most:
        raise ValueError(f"{name}: {len(values)} {what}; at most {at_most} in one call")
    return values


def _check_arguments(speeds, settle, measure, acceleration, parameter=None, values=None):
    """Every numeric argument against its bounds (the module's constants), before any work:
    (speeds, settle, measure, acceleration, values) as floats."""
    speeds = _sequence("speeds", speeds, "speeds (rad/s)", MAX_SPEEDS)
    for i, speed in enumerate(speeds):
        v = _number(f"speeds[{i}]", speed, "rad/s")
        if not 0 < abs(v) <= MAX_SPEED:
            raise ValueError(f"speeds[{i}] = {v!r} rad/s: every speed must be finite with "
                             f"0 < |speed| <= {MAX_SPEED:g} rad/s")
        speeds[i] = v
    settle = _in_range("settle", settle, "s", *SETTLE_RANGE)
    measure = _in_range("measure", measure, "s", *MEASURE_RANGE)
    acceleration = _number("acceleration", acceleration, "rad/s²")
    if not 0 < acceleration < math.inf:
        raise ValueError(f"acceleration = {acceleration!r} rad/s²: must be finite and > 0 rad/s²")
    if parameter is not None:
        kind, _, name = parameter.partition(":") if isinstance(parameter, str) else ("", "", "")
        if kind not in PARAMETER_BOUNDS or not name:
            raise ValueError(f"parameter = {parameter!r}: expected stiffness:JOINT or mass:BODY")
        high, unit = PARAMETER_BOUNDS[kind]
        values = _sequence("values", values, f"{kind} values ({unit})")
        for i, value in enumerate(values):
            v = _number(f"values[{i}]", value, unit)
            if not 0 < v <= high:
                raise ValueError(f"values[{i}] = {v!r} {unit}: every {kind} value must be "
                                 f"finite with 0 < value <= {high:g} {unit}")
            values[i] = v
        if len(speeds) * len(values) > MAX_SPEEDS:
            raise ValueError(f"speeds × values = {len(speeds)} × {len(values)} runs; at most "
                             f"{MAX_SPEEDS} in one call")
    return speeds, settle, measure, acceleration, values


def _load(model, actuator, measure, parameter):
    """The model's MJCF text and the name of the stepper to sweep (`actuator`: a name, an id or
    None for the only one), checked on the driver (the stepper, the load parameter's joint or
    body, enough timesteps in `measure`) before any run."""
    with open(model) as f:
        xml = f.read()
    spec = mujoco.MjSpec.from_string(xml)
    add_signal_sensors(spec)
    compiled = spec.compile()
    if actuator is None:
        names = [mujoco.mj_id2name(compiled, mujoco.mjtObj.mjOBJ_ACTUATOR, i)
                 for i in range(compiled.nu) if _is_stepper(compiled, i)]
        if len(names) != 1:
            raise ValueError(f"name the stepper to sweep: actuator= one of {names}")
        actuator = names[0]
    actuator = mujoco.mj_id2name(compiled, mujoco.mjtObj.mjOBJ_ACTUATOR,
                                 _stepper_id(compiled, actuator))
    h = compiled.opt.timestep
    steps = math.floor(measure / h + 0.5)  # the measured steps, as run_one counts them
    if steps < MIN_MEASURED_STEPS:
        raise ValueError(f"measure = {measure!r} s: {steps} timesteps of {h:g} s; must hold at "
                         f"least {MIN_MEASURED_STEPS} (measure >= {MIN_MEASURED_STEPS * h:g} s)")
    if parameter is not None:
        _parameter_target(compiled, parameter)
    return xml, actuator


def _import_ray(function):
    try:
        import ray
    except ImportError as e:
        raise ModuleNotFoundError(
            f'mjstepper.{function} runs on Ray, which is not installed here: '
            f'pip install "mjstepper[ray]" ({e})', name="ray") from e
    return ray


def _run_grid(ray, xml, runs, actuator, settle, measure, acceleration, address, progress, what):
    """Runs `runs` ((speed, parameter, value) each) as Ray tasks; their rows in order."""
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


def _check_output(out):
    """`out` must be a regular file or nothing (never a device, FIFO, directory or symbolic link,
    which the CSV would replace): OSError naming it if not. Checked before any run, and again just
    before the rename."""
    if out is None:
        return
    if not isinstance(out, (str, os.PathLike)) or not os.fspath(out):
        raise TypeError(f"out = {out!r}: expected a file path")
    try:
        mode = os.lstat(out).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise IsADirectoryError(f"out = {os.fspath(out)!r}: not a regular file; an output replaces "
                                "only a regular file or nothing") if stat.S_ISDIR(mode) else \
            FileExistsError(f"out = {os.fspath(out)!r}: not a regular file (a device, FIFO, socket "
                            "or symbolic link); an output replaces only a regular file or nothing")


def _write_csv(out, header, rows):
    """Every digit, written to a new temporary beside `out` (created exclusively, as the C++
    command's, src/tools/output_file.h) and renamed over it when complete."""
    out = os.fspath(out)
    _check_output(out)
    folder, name = os.path.split(os.path.abspath(out))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name[:200]}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            writer.writerows([repr(float(v)) for v in row] for row in rows)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        _check_output(out)
        os.replace(tmp, out)
    except BaseException:
        if os.path.lexists(tmp):
            os.remove(tmp)
        raise


def sweep(model, speeds, actuator=None, settle=0.4, measure=0.5, acceleration=209.44,
          address=None, out=None, progress=True):
    """Runs the constant-speed sweep of `model` (an MJCF path) at `speeds` as Ray tasks and returns
    its rows (the C++ sweep's CSV columns), written to `out` (CSV) if given.

    speeds: 1 to MAX_SPEEDS (100 000) speeds in rad/s, each finite with 0 < |speed| <= MAX_SPEED
        (1e4 rad/s).
    actuator: the stepper's name or id; None for the model's only stepper.
    settle: s at speed before measuring, in SETTLE_RANGE ([0, 60] s).
    measure: s measured, in MEASURE_RANGE ([0.01, 60] s), and at least MIN_MEASURED_STEPS (100)
        timesteps of the model.
    acceleration: of the ramp to speed, rad/s², finite and > 0.
    address: None runs a local Ray on all cores; "auto" or "ray://host:10001" joins a cluster.

    Every argument is checked before any run (and before Ray is imported): ValueError naming the
    argument, its value and its range (TypeError for a value that is not a number). Without Ray,
    ModuleNotFoundError says how to install it (pip install "mjstepper[ray]").
    """
    speeds, settle, measure, acceleration, _ = _check_arguments(speeds, settle, measure,
                                                                acceleration)
    _check_output(out)
    xml, actuator = _load(model, actuator, measure, None)
    ray = _import_ray("sweep")
    rows = _run_grid(ray, xml, [(s, None, None) for s in speeds], actuator, settle, measure,
                     acceleration, address, progress, "sweep")
    if out is not None:
        _write_csv(out, HEADER, rows)
    return rows


def resonance_map(model, speeds, parameter, values, actuator=None, settle=0.4, measure=0.5,
                  acceleration=209.44, address=None, out=None, progress=True):
    """`mjstepper map` as Ray tasks: the sweep over speeds (rad/s) × values of one load parameter.
    Rows are the C++ map's CSV columns: the value, then the sweep's; written to `out` (CSV) if
    given.

    parameter: "stiffness:JOINT" (the joint's stiffness, N·m/rad or N/m) or "mass:BODY" (the
        body's mass in kg, its inertia scaled with it; the body must have mass in the model).
    values: the parameter's values (at least one), each finite and > 0: stiffness <= 1e12,
        mass <= 1e6 kg (PARAMETER_BOUNDS).
    The other arguments, their ranges and the errors are sweep's.
    """
    speeds, settle, measure, acceleration, values = _check_arguments(
        speeds, settle, measure, acceleration, parameter, values)
    _check_output(out)
    xml, actuator = _load(model, actuator, measure, parameter)
    ray = _import_ray("resonance_map")
    runs = [(s, parameter, v) for v in values for s in speeds]
    rows = _run_grid(ray, xml, runs, actuator, settle, measure, acceleration, address, progress,
                     "map")
    rows = [(value,) + row for (_, _, value), row in zip(runs, rows)]
    if out is not None:
        _write_csv(out, (parameter,) + HEADER, rows)
    return rows
