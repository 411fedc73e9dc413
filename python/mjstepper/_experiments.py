"""The experiments of the mjstepper command as Python functions, over the C++ engine.

Each function turns its arguments into the command line they stand for (`sweep(model, speeds,
settle=0.3)` is `mjstepper sweep MODEL --speeds ... --settle 0.3`) and hands it to the bound engine
(mjstepper._engine, src/python/engine.cc): the command's own parser checks it (every bound and
message is the command's: README, "Options"), the experiment runs in C++ (src/tools), the files
named are written as the command writes them, and the result comes back as Tables, NumPy records
with named columns and SI units. A number is passed as its shortest round-trip text (repr), so the
engine computes with the very double given.
"""
import collections.abc
import dataclasses
import numbers
import os
import re
import reprlib

import numpy as np

from . import _engine


class Table(np.recarray):
    """Rows with named columns (`t.speed`, `t["speed"]`) and `t.units` ({column: unit}, SI)."""

    def __new__(cls, columns, parameter=None):
        """`columns`: (name, unit, values) each, as the engine returns them."""
        n = len(columns[0][2]) if columns else 0
        dtype = []
        for name, unit, values in columns:
            if unit == "bool":
                dtype.append((name, np.bool_))
            elif values and isinstance(values[0], str):
                dtype.append((name, f"U{max(len(v) for v in values)}"))
            else:
                dtype.append((name, np.float64))
        table = np.recarray(n, dtype=dtype).view(cls)
        for name, _, values in columns:
            table[name] = values
        table.units = {name: ("" if unit == "bool" else unit) for name, unit, _ in columns}
        table.parameter = parameter
        return table

    def __array_finalize__(self, obj):
        self.units = getattr(obj, "units", None)
        self.parameter = getattr(obj, "parameter", None)

    def columns(self):
        """{column: values} (plain arrays)."""
        return {name: np.asarray(self[name]) for name in self.dtype.names}


@dataclasses.dataclass
class RunResult:
    """`run`'s result: per-stepper summary rows, and each stepper's per-step trace."""
    steppers: Table  # name, profile, final_speed, rms/max velocity error, max_load_angle, lost_steps
    traces: dict  # stepper name → Table(time, omega_cmd, velocity_error, current_a, load_angle)
    steps: int
    sim_time: float  # s
    wall_time: float  # s
    frames: int


@dataclasses.dataclass
class Identified:
    """`identify`'s estimates: detent harmonics, static friction Fs and viscous damping B."""
    harmonics: Table  # order, amplitude (N·m), phase (rad)
    static_friction: float  # N·m
    viscous_damping: float  # N·m·s/rad
    residual_rms: float  # N·m
    damping_detent: str  # the estimates as a damping_detent attribute value


@dataclasses.dataclass
class ResonanceTest:
    """`resonance_test`'s result: the tested axis' PSD and every input shaper's fit."""
    psd: Table  # frequency (Hz), psd ((m/s²)²/Hz)
    fits: Table  # shaper, frequency (Hz), vibration, smoothing (m), max_accel (m/s²)
    peak_frequency: float  # Hz
    recommended: str  # the shaper recommended, or None
    samples: int


@dataclasses.dataclass
class Sizing:
    """`size`'s result: one row per stepper, each joint's demand along the move and its motor's
    simulated pull-out curve (rotor side, SI)."""
    table: Table  # joint, motor, drive, gear, ..., margin, lost_steps, winding temperatures (°C)
    demand: dict  # joint → Table(time, speed, torque, motor_speed, motor_torque)
    pullout: dict  # joint → Table(speed, torque, slipped_unloaded, held_max, carriage_speed, force)
    cycle_time: float  # s
    cycles: int


# A value as a message shows it: reprlib's bounded repr (a million-character str or a 1e5-item
# list in a message was the whole of it, issue 33), control characters escaped.
_SHOWN = reprlib.Repr()
_SHOWN.maxstring = _SHOWN.maxother = 60
_SHOWN.maxlevel = 3
_SHOWN_MOST = 120  # characters of the whole (nested sequences of 60-character objects add up)
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def _shown(value):
    text = _SHOWN.repr(value)
    if len(text) > _SHOWN_MOST:
        text = text[:_SHOWN_MOST] + "…"
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group(0)):02x}", text)


def _wrong_type(name, value, what):
    return TypeError(f"{name} = {_shown(value)} ({type(value).__name__}): {name} takes {what}")


def _number(name, value):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise _wrong_type(name, value, "a number")
    if isinstance(value, numbers.Integral):
        value = int(value)
        if abs(value) > 2 ** 63:  # (and str() of 10**5000 is itself a ValueError)
            raise ValueError(f"{name} = {_shown(value)}: beyond ±2^63, out of every option's range")
        return str(value)
    try:
        return repr(float(value))
    except (OverflowError, ValueError):  # a Fraction of 10**400, say
        raise ValueError(f"{name} = {_shown(value)}: not a number a double holds") from None


def _text(name, value):
    if isinstance(value, os.PathLike):
        return _text(name, os.fspath(value))
    if not isinstance(value, str):
        raise _wrong_type(name, value, "a str")
    return value


def _sequence(name, value):
    """A sequence argument's items as a list: TypeError naming `name` when it is no sized
    sequence (a generator, a number, a set's unordered items count), ValueError when it holds more
    than any list of the command may (_engine.max_items, the command's kMaxRuns), both before an
    item is read, so a broadcast view of 1e9 elements is never copied (issue 33)."""
    limit = int(_engine.max_items)
    if isinstance(value, np.ndarray):
        if value.size > limit:
            raise ValueError(f"{name}: {value.size} values; at most {limit}")
        return list(value.reshape(-1))
    if isinstance(value, (str, bytes)) or not isinstance(value, collections.abc.Sequence):
        raise _wrong_type(name, value, "a list of values")
    if len(value) > limit:
        raise ValueError(f"{name}: {len(value)} values; at most {limit}")
    return list(value)


def _mapping(name, value):
    """A {name: value} argument's items, bounded as _sequence's."""
    if not isinstance(value, collections.abc.Mapping):
        raise _wrong_type(name, value, "a dict")
    limit = int(_engine.max_items)
    if len(value) > limit:
        raise ValueError(f"{name}: {len(value)} items; at most {limit}")
    return list(value.items())


def model_path(model):
    """The file `model` names: itself when it is a file, else the package's example model of that
    path in the clone or that name ("models/tsui_rigid.xml", "tsui_rigid"; `mjstepper models`
    lists them), as every experiment reads it; FileNotFoundError naming it when neither."""
    found = _engine.find_model(_text("model", model))
    if not found:
        raise FileNotFoundError(f"{os.fspath(model)!r}: no such file, nor an example model of that "
                                "name (`mjstepper models` lists them)")
    return found


def speeds_text(speeds):
    """A speed list as the command takes it: a str as it is ("10:200:2.5rpm"), a number or a
    sequence of numbers as rad/s, each to the last bit."""
    if isinstance(speeds, str):
        return speeds
    if isinstance(speeds, numbers.Real) and not isinstance(speeds, (bool, np.bool_)):
        speeds = [speeds]
    values = [repr(float(_number("speeds", s))) for s in _sequence("speeds", speeds)]
    if not values:
        raise ValueError("speeds: no speed")
    return ",".join(values) + "rad/s"


# The options whose values are text (paths, names, profiles, --set items); every other takes
# numbers only (a str there is a TypeError, as a list where a number belongs).
_TEXT_OPTIONS = {"ctrl", "klipper", "log", "keyframe", "start", "stepper", "meshdir", "render", "frames", "camera", "plot", "accel_log",
                 "accelerometer", "actuator", "out", "speeds", "vary", "axis", "dyno", "set",
                 "overlay", "move", "speed", "accel"}


# The options that are flags: True gives the flag, False leaves it out. Any other option takes a
# value, and a bool there is a TypeError (issue 33: run(model, True) gave "--duration" no value,
# and the command read "--quiet" as it).
_FLAGS = {"allow_coarse", "no_overlay", "quiet"}


def _keywords():
    """{"--option": its Python spelling} from the command's own option list (_engine.options)."""
    return {option: f"{python}=True" if flag else python
            for _, option, python, flag in _engine.options() if option.startswith("--")}


_OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def in_python_words(message):
    """A message of the command's parser or engine in a Python user's words: each option named as
    its keyword ("--allow-coarse" → "allow_coarse=True", "--log-every" → "log_every")."""
    keywords = _keywords()
    return _OPTION.sub(lambda m: keywords.get(m.group(0), m.group(0)), message)


def compute(args, keep_traces=False):
    """_engine.compute, its ValueErrors in a Python user's words (in_python_words)."""
    try:
        return _engine.compute(args, keep_traces)
    except ValueError as e:
        raise ValueError(in_python_words(str(e))) from None


def check(args):
    """_engine.check, its ValueErrors in a Python user's words (in_python_words)."""
    try:
        _engine.check(args)
    except ValueError as e:
        raise ValueError(in_python_words(str(e))) from None


def command_line(subcommand, positional, options):
    """The command line of `subcommand` with `positional` arguments and `options`
    ({python_name: value}): None leaves an option out, a flag (_FLAGS) is given for True and left
    out for False, a dict gives NAME=VALUE items, a list or tuple the option repeated, a number
    its repr."""
    args = [subcommand] + [_text("model", p) for p in positional]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if name in _FLAGS:
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{name} = {_shown(value)} ({type(value).__name__}): {name} takes "
                                "True or False")
            if value:
                args.append(flag)
            continue
        if value is None:
            continue
        elif isinstance(value, collections.abc.Mapping):
            for key, v in _mapping(name, value):
                v = (_text(f"{name}[{key!r}]", v) if name in _TEXT_OPTIONS
                     else _number(f"{name}[{key!r}]", v))
                args += [flag, f"{_text(name, key)}={v}"]
        elif isinstance(value, (list, tuple)) and name != "size":
            for v in _sequence(name, value):
                args += [flag, _text(name, v) if name in _TEXT_OPTIONS else _number(name, v)]
        elif name == "size":
            pair = _sequence("size", value)
            if len(pair) != 2:
                raise ValueError(f"size = {_shown(value)}: size is (width, height) in pixels")
            args += [flag, f"{_number('size', pair[0])}x{_number('size', pair[1])}"]
        elif name in _TEXT_OPTIONS:
            args += [flag, _text(name, value)]
        else:
            args += [flag, _number(name, value)]
    return args


def _items(value, name="set"):
    """A repeatable option's values: a lone str (or number) is one value, not its characters."""
    if value is None:
        return []
    if isinstance(value, (str, bytes, numbers.Number, os.PathLike)):
        return [value]
    return _sequence(name, value)


def run_args(model, duration, *, ctrl=None, klipper=None, log=None, log_every=None, set=(),
             load=None, mass=None, keyframe=None, start=None, allow_coarse=False, render=None,
             frames=None, camera=None, size=None, fps=None, playback=None, overlay=(),
             no_overlay=False, plot=None, accel_log=None, accelerometer=None, quiet=True):
    """The command line `run` gives the engine (every experiment has one: `*_args`; `check`
    parses it without running)."""
    return command_line("run", [model], dict(
        duration=duration, ctrl=ctrl, klipper=klipper, log=log, log_every=log_every,
        set=_items(set), load=load, mass=mass, keyframe=keyframe, start=start,
        allow_coarse=allow_coarse, render=render, frames=frames, camera=camera, size=size,
        fps=fps, playback=playback, overlay=_items(overlay, "overlay"), no_overlay=no_overlay, plot=plot,
        accel_log=accel_log, accelerometer=accelerometer, quiet=quiet))


def run(model, duration, *, ctrl=None, klipper=None, log=None, log_every=None, set=(), load=None,
        mass=None, keyframe=None, start=None, allow_coarse=False, render=None, frames=None,
        camera=None, size=None, fps=None, playback=None, overlay=(), no_overlay=False, plot=None,
        accel_log=None, accelerometer=None, traces=True, quiet=True):
    """`mjstepper run`: steps `model` for `duration` s with a command profile per stepper
    (`ctrl={"shaft": "ramp(0rpm,200rpm,0.8s)"}`) or a real print's step stream
    (`klipper="models/prints/square20/mzv.map"`: Klipper's MCU step commands onto the steppers
    the map names), writing the CSV log, video, frames or
    accelerometer log asked for; returns a RunResult (with each stepper's per-step trace unless
    traces=False). `set` ("shaft.damping=all", ...), `load` and `mass` ({name: value}) and the
    rest are the command's options (README, "The command"); `start` "settled" (the default: under
    gravity the drives first settle while it is ramped in) or "aligned" (full gravity at t = 0)."""
    r = compute(run_args(
        model, duration, ctrl=ctrl, klipper=klipper, log=log, log_every=log_every, set=set,
        load=load, mass=mass, keyframe=keyframe, start=start, allow_coarse=allow_coarse,
        render=render, frames=frames, camera=camera, size=size, fps=fps, playback=playback,
        overlay=overlay, no_overlay=no_overlay, plot=plot, accel_log=accel_log,
        accelerometer=accelerometer, quiet=quiet), traces)
    return RunResult(steppers=Table(r["steppers"]),
                     traces={name: Table(t) for name, t in r["traces"].items()},
                     steps=r["steps"], sim_time=r["sim_time"], wall_time=r["wall_time"],
                     frames=r["frames"])


def sweep_args(model, speeds, *, actuator=None, settle=None, measure=None, threads=None, set=(),
               out=None, allow_coarse=False, quiet=True):
    return command_line("sweep", [model], dict(
        speeds=speeds_text(speeds), actuator=actuator, settle=settle, measure=measure,
        threads=threads, set=_items(set), out=out, allow_coarse=allow_coarse, quiet=quiet))


def sweep(model, speeds, **options):
    """`mjstepper sweep`: one constant-speed run per speed (a str such as "10:200:2.5rpm" or, on
    a linear axis, "50:200:10mm/s"; or numbers in rad/s) on all cores; a Table of speed,
    rms_error, peak_to_peak_error (rad/s), dominant_frequency (Hz), lost_steps, carriage_speed
    (m/s at a linear axis's carriage, NaN on a rotary one). `out=PREFIX` also writes PREFIX.csv and PREFIX.png.
    Options: actuator, settle, measure, threads, set, out, allow_coarse, quiet."""
    return Table(compute(sweep_args(model, speeds, **options), False)["table"])


def map_args(model, speeds, vary, *, actuator=None, settle=None, measure=None, threads=None,
             set=(), out=None, allow_coarse=False, quiet=True):
    pair = _sequence("vary", vary)
    if len(pair) != 2:
        raise ValueError(f"vary = {_shown(vary)}: vary is (parameter, values), e.g. "
                         "(\"mass:payload\", [1, 2])")
    parameter, values = pair
    if isinstance(values, numbers.Real) and not isinstance(values, (bool, np.bool_)):
        values = [values]
    text = f"{_text('vary', parameter)}=" + ",".join(_number("vary", v)
                                                     for v in _sequence("vary", values))
    return command_line("map", [model], dict(
        speeds=speeds_text(speeds), vary=text, actuator=actuator, settle=settle, measure=measure,
        threads=threads, set=_items(set), out=out, allow_coarse=allow_coarse, quiet=quiet))


def map(model, speeds, vary, **options):
    """`mjstepper map`: the sweep over speeds × values of one load parameter,
    vary=("stiffness:JOINT", [values]) (N·m/rad or N/m) or ("mass:BODY", [kg]); a Table of value
    and the sweep's columns, values outermost. Options as `sweep`."""
    r = compute(map_args(model, speeds, vary, **options), False)
    return Table(r["table"], parameter=r["parameter"])


def pullout_args(model, speeds, *, actuator=None, rate=None, max_torque=None, threads=None,
                 set=(), out=None, allow_coarse=False, quiet=True):
    return command_line("pullout", [model], dict(
        speeds=speeds_text(speeds), actuator=actuator, rate=rate, max_torque=max_torque,
        threads=threads, set=_items(set), out=out, allow_coarse=allow_coarse, quiet=quiet))


def pullout(model, speeds, **options):
    """`mjstepper pullout`: the pull-out torque curve; a Table of speed (rad/s), torque (N·m,
    rotor side), slipped_unloaded, held_max, and at a linear axis's carriage carriage_speed
    (m/s) and force (N) (NaN on a rotary one). Options: actuator, rate (N·m/s), max_torque (N·m),
    threads, set, out, allow_coarse, quiet."""
    return Table(compute(pullout_args(model, speeds, **options), False)["table"])


def identify_args(model, speeds="10,30rpm", *, actuator=None, dyno=None, orders=None, set=()):
    return command_line("identify", [model], dict(
        speeds=speeds_text(speeds), actuator=actuator, dyno=dyno,
        orders=None if orders is None else _items(orders, "orders"), set=_items(set)))


def identify(model, speeds="10,30rpm", **options):
    """`mjstepper identify`: Tsui's bench; the detent harmonics, Fs and B (Identified). Options:
    actuator, dyno, orders, set."""
    r = compute(identify_args(model, speeds, **options), False)
    return Identified(harmonics=Table(r["harmonics"]), static_friction=r["static_friction"],
                      viscous_damping=r["viscous_damping"], residual_rms=r["residual_rms"],
                      damping_detent=r["damping_detent"])


def resonance_test_args(model, axis, out, *, min_freq=None, max_freq=None, accel_per_hz=None,
                        hz_per_sec=None, accelerometer=None, accel_rate=None, accel_range=None,
                        accel_noise=None, seed=None, set=(), quiet=True):
    return command_line("resonance-test", [model], dict(
        axis=axis, out=out, min_freq=min_freq, max_freq=max_freq, accel_per_hz=accel_per_hz,
        hz_per_sec=hz_per_sec, accelerometer=accelerometer, accel_rate=accel_rate,
        accel_range=accel_range, accel_noise=accel_noise, seed=seed, set=_items(set),
        quiet=quiet))


def resonance_test(model, axis, out, **options):
    """`mjstepper resonance-test`: Klipper's TEST_RESONANCES on a simulated printer; writes
    OUT_raw.csv (Klipper's raw accelerometer format), OUT_psd.csv and OUT.png, returns a
    ResonanceTest. accel_per_hz in mm/s² per Hz, accel_noise in µg/√Hz, as the command. Options:
    min_freq, max_freq, accel_per_hz, hz_per_sec, accelerometer, accel_rate, accel_range,
    accel_noise, seed, set, quiet."""
    r = compute(resonance_test_args(model, axis, out, **options), False)
    return ResonanceTest(psd=Table(r["psd"]), fits=Table(r["fits"]),
                         peak_frequency=r["peak_frequency"], recommended=r["recommended"],
                         samples=r["samples"])


def _joint_values(name, values, unit):
    """A joint's values as the command takes them: a str as it is ("30,60deg"), a number or a
    sequence of numbers in SI on a hinge (`unit`: rad, rad/s, rad/s²)."""
    if isinstance(values, str):
        return values
    if isinstance(values, numbers.Real) and not isinstance(values, (bool, np.bool_)):
        values = [values]
    return ",".join(repr(float(_number(name, v))) for v in _sequence(name, values)) + unit


def attach(robot, stepper, out, *, meshdir=None):
    """`mjstepper attach`: puts a stepper on each joint of `robot` (an MJCF or URDF path) named in
    `stepper` (the command's repeatable --stepper), {joint: {"motor": "17hs24_2104s", "driver": "tmc5160", "gear": 6.4, ...}} (gear
    sets the actuator's gear; every other key is a plugin attribute, plugin/README.md), and writes
    the MJCF `out` with the motors' rotor inertia as armature, the timestep the rule recommends and
    a keyframe "start". `meshdir`: the robot's mesh folder, for a URDF's package:// URIs. Returns
    {"out": path, "timestep": s, "joints": [...]}; errors name the joint and the fix."""
    return dict(compute(attach_args(robot, stepper, out, meshdir=meshdir), False))


def attach_args(robot, stepper, out, *, meshdir=None):
    robot = _text("robot", robot)
    items = []
    for joint, spec in _mapping("stepper", stepper):
        joint = _text("stepper", joint)
        pairs = []
        for key, value in _mapping(f"stepper[{joint!r}]", spec):
            key = _text(f"stepper[{joint!r}]", key)
            if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
                value = _number(f"stepper[{joint!r}][{key!r}]", value)
            pairs.append(f"{key}={_text(f'stepper[{joint!r}][{key!r}]', value)}")
        items.append(f"{joint}:" + ",".join(pairs))
    return command_line("attach", [_text("robot", robot)],
                        dict(stepper=items, out=out, meshdir=meshdir))


def size(model, move, *, speed=None, accel=None, dwell=None, cycles=None, pullout_points=None,
         out=None, threads=None, set=(), mass=None, keyframe=None, start=None, allow_coarse=False,
         log=None, render=None, camera=None, size=None, fps=None, playback=None, quiet=True):
    """`mjstepper size`: does each joint's motor, drive and bus carry `move`, {actuator:
    waypoints} ("30,0deg", or numbers in rad), at `speed` and `accel` ({actuator: "90deg/s"} /
    {actuator: "600deg/s²"}, or numbers in rad/s, rad/s² — numbers are a hinge's: give a slide's
    as a str, "10,20mm"; default: each drive's own profile)?
    Returns a Sizing: the table (margin at the worst point, lost steps, winding temperature after
    1 and `cycles` cycles and in continuous duty), each joint's demand and pull-out curve; with
    `out`, writes the command's CSVs and PNGs. `start`: as run's ("settled" or "aligned")."""
    r = compute(size_args(
        model, move, speed=speed, accel=accel, dwell=dwell, cycles=cycles,
        pullout_points=pullout_points, out=out, threads=threads, set=set, mass=mass,
        keyframe=keyframe, start=start, allow_coarse=allow_coarse, log=log, render=render,
        camera=camera, size=size, fps=fps, playback=playback, quiet=quiet), False)
    return Sizing(table=Table(r["table"]),
                  demand={name: Table(t) for name, t in r["demand"].items()},
                  pullout={name: Table(t) for name, t in r["pullout"].items()},
                  cycle_time=r["cycle_time"], cycles=r["cycles"])


def size_args(model, move, *, speed=None, accel=None, dwell=None, cycles=None,
              pullout_points=None, out=None, threads=None, set=(), mass=None, keyframe=None,
              start=None, allow_coarse=False, log=None, render=None, camera=None, size=None,
              fps=None, playback=None, quiet=True):
    def joints(name, values, unit):
        return None if values is None else {
            key: _joint_values(f"{name}[{key!r}]", v, unit) for key, v in _mapping(name, values)}
    args = command_line("size", [model], dict(
        move=joints("move", move, "rad"), speed=joints("speed", speed, "rad/s"),
        accel=joints("accel", accel, "rad/s²"), dwell=dwell, cycles=cycles,
        pullout_points=pullout_points, out=out, threads=threads, set=_items(set), mass=mass,
        keyframe=keyframe, start=start, allow_coarse=allow_coarse, log=log, render=render,
        camera=camera, size=size, fps=fps, playback=playback, quiet=quiet))
    return args
