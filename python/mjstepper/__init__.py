"""mjstepper: stepper motors and their drives as a MuJoCo actuator plugin.

`import mjstepper` loads the plugin library into the installed mujoco (which must be the version it
was built against), after which MJCF models may use `mjstepper.stepper` actuators and sensors.

    import mujoco, mjstepper
    spec = mujoco.MjSpec.from_file("models/tsui_rigid.xml")
    mjstepper.add_signal_sensors(spec)
    model = spec.compile(); data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    mjstepper.signals(model, data, "shaft")["current_a"]   # (value, "A")

The command's experiments, computed by the same C++ engine, with results as Tables (NumPy records
with named columns and `.units`):

    table = mjstepper.sweep("models/tsui_rigid.xml", "10:200:2.5rpm")
    table.speed, table.rms_error, table.units["rms_error"]          # rad/s
    mjstepper.run("models/tsui_rigid.xml", 0.8, ctrl={"shaft": "ramp(0rpm,200rpm,0.8s)"})

and the same on Ray: mjstepper.distributed.sweep and .map. `mjstepper` on the command line (or
`python -m mjstepper`) is the command.
"""
import collections.abc
import difflib
import functools
import numbers
import operator
import os
import sys

import mujoco
import numpy as np

from . import _tables

if mujoco.__version__ != _tables.MUJOCO_VERSION:
    raise ImportError(
        f"mjstepper was built for MuJoCo {_tables.MUJOCO_VERSION} but the installed mujoco is "
        f"{mujoco.__version__}: install mujoco=={_tables.MUJOCO_VERSION}, or rebuild mjstepper "
        f"against this mujoco (pip install --force-reinstall --no-cache-dir <mjstepper source>)")

PLUGIN_NAME = "mjstepper.stepper"
LIBRARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "libmjstepper.so")
mujoco.mj_loadPluginLibrary(LIBRARY)

#: Signal names, in sensordata order, and their units (from the C++ signal table).
SIGNALS = tuple(name for name, _, _ in _tables.SIGNALS)
UNITS = {name: unit for name, unit, _ in _tables.SIGNALS}
MEANINGS = {name: meaning for name, _, meaning in _tables.SIGNALS}
#: Every preset's parameters as {name: (value, unit)}.
PRESETS = _tables.PRESETS
#: Plugin attribute names (MJCF <config key=...>), in the plugin's order, and their units (from
#: the C++ attribute table).
ATTRIBUTES = tuple(name for name, _, _, _, _ in _tables.ATTRIBUTES)
ATTRIBUTE_UNITS = {name: unit for name, _, _, unit, _ in _tables.ATTRIBUTES}
_ATTRIBUTE_TYPES = {name: kind for name, kind, _, _, _ in _tables.ATTRIBUTES}


@functools.cache
def _stepper_slot():
    """The plugin slot MuJoCo gave mjstepper.stepper in this process (mjModel.plugin's values),
    from the smallest model with a stepper (no rotor inertia, so none needed in the model)."""
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><extension><plugin plugin="{PLUGIN_NAME}"/></extension>'
        '<worldbody><body><joint name="j"/><geom size="0.1"/></body></worldbody>'
        f'<actuator><plugin joint="j" plugin="{PLUGIN_NAME}">'
        '<config key="rotor_inertia" value="0"/></plugin></actuator></mujoco>')
    return int(model.plugin[0])


def _actuator_id(model, actuator):
    """The id of `actuator` (a name, or an id: any integer but a bool) in a compiled model."""
    if isinstance(actuator, str):
        actuator_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator)
        if actuator_id < 0:
            raise KeyError(f"no actuator named {actuator!r}")
        return actuator_id
    if isinstance(actuator, (bool, np.bool_)):
        raise TypeError(f"actuator must be a name (str) or an id (int), not a bool ({actuator!r})")
    try:
        actuator_id = operator.index(actuator)
    except TypeError:
        raise TypeError(f"actuator must be a name (str) or an id (int), not "
                        f"{type(actuator).__name__} ({actuator!r})") from None
    if not 0 <= actuator_id < model.nactuator:
        raise IndexError(f"no actuator {actuator_id}: actuator ids are in "
                         f"[0, model.nactuator) = [0, {model.nactuator})")
    return actuator_id


def _is_stepper(model, actuator_id):
    instance = model.actuator_plugin[actuator_id]
    return instance >= 0 and model.plugin[instance] == _stepper_slot()


def _stepper_id(model, actuator):
    """The id of the stepper `actuator` (a name, or an id: any integer but a bool, in
    [0, model.nactuator)): TypeError, KeyError, IndexError, or ValueError for an actuator that is
    not a stepper."""
    actuator_id = _actuator_id(model, actuator)
    if not _is_stepper(model, actuator_id):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator_id)
        why = ("it has no plugin" if model.actuator_plugin[actuator_id] < 0
               else f"its plugin is not {PLUGIN_NAME}")
        raise ValueError(f"actuator {name!r} (id {actuator_id}) is not an mjstepper stepper: {why}")
    return actuator_id


def signals(model, data, actuator):
    """{name: (value, unit)} of the stepper on `actuator` (its name, or its id: any integer in
    [0, model.nactuator)), from its signal sensor (mjstepper.add_signal_sensors adds one to every
    stepper). Raises TypeError for another kind of `actuator`, KeyError for an unknown name,
    IndexError for an id out of range, ValueError for an actuator that is not a stepper."""
    actuator_id = _stepper_id(model, actuator)
    for s in range(model.nsensor):
        if (model.sensor_type[s] == mujoco.mjtSensor.mjSENS_PLUGIN
                and model.sensor_objtype[s] == mujoco.mjtObj.mjOBJ_ACTUATOR
                and model.sensor_objid[s] == actuator_id):
            adr = model.sensor_adr[s]
            values = data.sensordata[adr:adr + len(SIGNALS)]
            return {name: (float(v), UNITS[name]) for name, v in zip(SIGNALS, values)}
    raise KeyError(f"actuator {actuator!r} has no mjstepper signal sensor; "
                   "call mjstepper.add_signal_sensors(spec) before compiling")


# What each type of attribute takes besides a str, and how it is written.
_ATTRIBUTE_VALUES = {
    "real": ((numbers.Real,), "a str or a number", str),
    "integer": ((numbers.Integral,), "a str or an integer", str),
    "name": ((bool, np.bool_), "a str or a bool (on/off)", lambda v: "on" if v else "off"),
    "list": ((), "a str", str),
}


def _attribute_text(name, value):
    """The config text of one attribute value; ValueError for an unknown attribute, TypeError for
    a value its type does not take."""
    if name not in _ATTRIBUTE_TYPES:
        close = difflib.get_close_matches(name, ATTRIBUTES, n=3)
        hint = (f"did you mean {' or '.join(close)}?" if close
                else f"known attributes: {', '.join(ATTRIBUTES)}")
        from ._experiments import _shown
        raise ValueError(f"unknown mjstepper attribute {_shown(name)}: {hint}")
    kind = _ATTRIBUTE_TYPES[name]
    types, expected, text = _ATTRIBUTE_VALUES[kind]
    if isinstance(value, str):
        return value
    is_bool = isinstance(value, (bool, np.bool_))
    if isinstance(value, types) and (kind == "name" or not is_bool):
        return text(value)
    from ._experiments import _shown  # (a bounded, escaped repr, as every message quotes)
    raise TypeError(f"{name} = {_shown(value)} ({type(value).__name__}): {name} ({kind}) takes "
                    f"{expected}")


def configure(spec, actuator, **attributes):
    """Sets plugin attributes (plugin/README.md) of the stepper on `actuator` in an MjSpec, through
    the spec's own plugin config, e.g. configure(spec, "shaft", drive="servo", hold_current=1.5).
    An actuator on a named instance changes the instance (and every actuator sharing it).

    Every name must be one of ATTRIBUTES (ValueError, suggesting the closest, if not); every
    value a str, or a number for a real or integer attribute, or a bool (on/off) for a
    name-valued one (TypeError if not). The values themselves are checked when the spec compiles.
    Nothing is changed when any attribute is rejected."""
    texts = {k: _attribute_text(k, v) for k, v in attributes.items()}
    a = next((x for x in spec.actuators if x.name == actuator), None)
    if a is None or not a.plugin.active:
        raise KeyError(f"no mjstepper actuator named {actuator!r}")
    target = a.plugin
    if not a.plugin.plugin_name:  # on a named instance
        target = next(p for p in spec.plugins if p.name == a.plugin.name)
    target.config = {**target.config, **texts}


def add_signal_sensors(spec):
    """Adds a signal sensor to every mjstepper actuator of an MjSpec that has none; returns the
    names of the actuators that got one."""
    covered = {s.objname for s in spec.sensors
               if s.type == mujoco.mjtSensor.mjSENS_PLUGIN
               and s.objtype == mujoco.mjtObj.mjOBJ_ACTUATOR}
    added = []
    for a in spec.actuators:
        if not a.plugin.active or a.name in covered:
            continue
        plugin_name = a.plugin.plugin_name
        if not plugin_name:  # an actuator on a named instance: the instance names the plugin
            instance = next((p for p in spec.plugins if p.name == a.plugin.name), None)
            plugin_name = instance.plugin_name if instance is not None else ""
        if plugin_name != PLUGIN_NAME:
            continue
        if not a.name:
            raise ValueError("a stepper actuator has no name; name it to read its signals")
        probe = spec.add_plugin(plugin_name=PLUGIN_NAME, active=True)
        sensor = spec.add_sensor(name=f"mjstepper:{a.name}", type=mujoco.mjtSensor.mjSENS_PLUGIN,
                                 objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname=a.name)
        sensor.plugin = probe
        added.append(a.name)
    return added


class StepTimes:
    """A motion controller's STEP/DIR output for a stepper with input="steps": the microstep count
    at any time, to write into ctrl. The same format as the command line's steps(FILE) (README):
    one step time in s per line, non-decreasing, in [0, 1e6], optionally followed by its
    direction, +1 (default) or -1; blank lines and lines starting with # skipped.

        steps = mjstepper.StepTimes.read("moves.txt")      # or StepTimes(times, directions)
        start = data.ctrl[0]
        while data.time < steps.last_time:
            data.ctrl[0] = start + steps.count(data.time + model.opt.timestep)
            mujoco.mj_step(model, data)
    """

    MAX_STEPS = 10_000_000  # as the C++ reader (src/core/step_times.h)

    @classmethod
    def _numbers(cls, name, values, flat=True):
        """`values` (a number, a sequence or an array of numbers) as a flat float array: its size
        checked first, without reading it (a broadcast view of 1e9 elements was copied whole, a
        range(10**9) listed, issue 33), then converted; TypeError or ValueError naming `name`."""
        if isinstance(values, np.ndarray):
            size = values.size
        elif isinstance(values, collections.abc.Sequence) and not isinstance(values, (str, bytes)):
            size = len(values)
        elif isinstance(values, numbers.Real) and not isinstance(values, (bool, np.bool_)):
            size = 1
        else:
            raise TypeError(f"{name}: a {type(values).__name__}; {name} takes a number or a "
                            "sequence of numbers")
        if size > cls.MAX_STEPS:
            raise ValueError(f"{name}: {size} values; more than {cls.MAX_STEPS} steps")
        try:
            if isinstance(values, np.ndarray):
                array = values.astype(float, copy=False)
            elif size == 1 and not isinstance(values, collections.abc.Sequence):
                array = np.array([float(values)])
            else:  # exactly its items, each a number (a nested range is no step time)
                array = np.fromiter(values, dtype=float, count=size)
            return array.reshape(-1) if flat else array
        except (TypeError, ValueError, OverflowError) as e:
            raise ValueError(f"{name}: not numbers a double holds "
                             f"({type(e).__name__}: {str(e)[:60]})") from None

    def __init__(self, times, directions=None):
        times = self._numbers("times", times)
        directions = (np.ones_like(times) if directions is None
                      else self._numbers("directions", directions))
        if times.size == 0:
            raise ValueError("no step times")
        if times.size > self.MAX_STEPS:
            raise ValueError(f"more than {self.MAX_STEPS} steps")
        if directions.shape != times.shape:
            raise ValueError(f"{times.size} times but {directions.size} directions")
        if not np.all(np.isfinite(times)) or times.min() < 0 or times.max() > 1e6:
            raise ValueError("a step time is a number of seconds in [0, 1e6]")
        if np.any(np.diff(times) < 0):
            k = int(np.argmax(np.diff(times) < 0)) + 1
            raise ValueError(f"step {k + 1} at {times[k]:g} s comes before the step before it "
                             f"({times[k - 1]:g} s): step times must not decrease")
        if not np.all(np.isin(directions, (1.0, -1.0))):
            raise ValueError("a direction is +1 or -1")
        self.times = times
        self.counts = np.cumsum(directions)

    @classmethod
    def read(cls, path):
        """Reads a step-time file with the command's own reader (steps(FILE); one reader of the
        format): ValueError naming the file, the line and the rule of a bad one, a file that is
        not a regular one, or one larger than the most it may hold."""
        times, directions = _engine.read_step_times(os.fspath(path))
        return cls(times, directions)

    @property
    def last_time(self):
        return float(self.times[-1])

    def count(self, t):
        """The signed count of steps at times <= t (s); t may be an array. A NaN time has no
        count: ValueError (searchsorted put it after every step, issue 33)."""
        t = self._numbers("count", t, flat=False) if not isinstance(t, numbers.Real) else t
        if np.any(np.isnan(t)):
            raise ValueError("count: a time is NaN")
        i = np.searchsorted(self.times, t, side="right")
        return np.where(i > 0, self.counts[np.maximum(i - 1, 0)], 0.0)[()]


# The experiments (run, sweep, map, pullout, identify, resonance_test, size, attach) over the C++
# engine, which
# finds this package's plugin library, and plots with this interpreter and the package's script.
from . import _engine  # noqa: E402
_HERE = os.path.dirname(os.path.abspath(__file__))
_engine.set_installation(LIBRARY, sys.executable, os.path.join(_HERE, "_plot.py"),
                         os.path.join(_HERE, "models"))  # the example models (pip install)
from ._experiments import (  # noqa: E402,F401
    Identified, ResonanceTest, RunResult, Sizing, Table, attach, identify, map, model_path,
    pullout, resonance_test, run, size, sweep)
